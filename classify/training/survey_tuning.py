"""The survey stage of training: the networks trained on synthesized clouds, trained on from the clouds recon makes
of simulated surveys (``[surveys]`` of the training settings).

Synthesis models what lies between a mesh and the classifier (the first return per beam, the lower beam edge, the
acoustic effects drawn over their space: :mod:`classify.training.scan_acoustics`); a survey goes through all of it
as it is: the rendered image under acoustic conditions drawn over the whole space (every sonar model and profile,
beam pattern, sidelobes, pulse, gain, TVG error, noise floor, interference), recon's highlight extension, seabed
removal, clustering and the fusion of passes. The survey clouds
(:func:`auvlink.evaluation.survey_clouds.survey_cloud_set`: recon's final objects labelled by the simulator's
truth, every cluster that is no object as ``clutter``) come from a draw seed kept apart from evaluation seeds.

Every ``ideal_every``-th survey of the draw is flown under the idealized model instead, and synthesized training
clouds make up ``synthesized_share`` of the stage's clouds (:func:`mixed_with_synthesized`): a network trained on
from its weights forgets what the new clouds do not show (on the survey clouds of one acoustic space alone, the
shipped networks lost ~0.07 of precision under the idealized model while gaining 0.06 on realistic acoustics).

Each network continues from its synthesized-cloud weights on the stage's clouds (:func:`classify.training.train.train`
with ``init``: the same augmentation, a stratified validation split, early stopping), at the stage's own epochs and
learning rate; the clutter threshold is then calibrated on the survey clouds of the validation split, whose clutter
is what recon really hands over.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from classify.pointnet import PointNet
from classify.training.dataset import CloudSet
from classify.training.train import TrainConfig, TrainResult, train


@dataclass(frozen=True)
class SurveySettings:
    """``[surveys]``: how many simulated surveys give training clouds (0: no survey stage), their draw, and the
    stage's training budget."""

    surveys: int = 0
    seed: int = 31
    acoustics: str = "random"  # acoustic space of auvlink.evaluation.acoustic_draw
    sonar: str = "didson"  # the sonar model flown, or random per survey (auvlink.evaluation.draw.survey_sonar)
    ideal_every: int = 0  # every k-th survey (indices k - 1, 2k - 1, ...) under the idealized model; 0: none
    synthesized_share: float = 0.0  # share of the stage's training clouds drawn from the synthesized ones
    epochs: int = 30
    lr: float = 1e-3
    workers: int = 2

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SurveySettings:
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


#: what gives the survey clouds: the settings and the class names -> the clouds (the application layer's
#: :func:`auvlink.evaluation.survey_clouds.survey_cloud_set`)
SurveyClouds = Callable[[SurveySettings, Sequence[str]], CloudSet]


def _form(c: CloudSet) -> tuple[Any, ...]:
    return c.class_names, c.points.shape[1], c.scale_m, c.z_ref


def mixed_with_synthesized(surveys: CloudSet, synthesized: CloudSet | None, share: float,
                           seed: int) -> tuple[CloudSet, npt.NDArray[np.bool_]]:
    """The survey clouds with synthesized clouds drawn (without replacement, seeded by ``seed``) to make up
    ``share`` of the whole, and which clouds of the whole are survey clouds. The synthesized clouds must be
    normalized alike (points per cloud, ``scale_m``, ``z_ref``) and name the same classes."""
    if not 0.0 <= share < 1.0:
        raise ValueError(f"synthesized share {share}: expected 0 <= share < 1")
    n = len(surveys)
    if synthesized is None or share == 0.0 or not len(synthesized):
        return surveys, np.ones(n, bool)
    if _form(synthesized) != _form(surveys):
        raise ValueError(f"synthesized clouds (classes, points, scale_m, z_ref) {_form(synthesized)} differ from "
                         f"the survey clouds' {_form(surveys)}")
    k = min(len(synthesized), round(n * share / (1.0 - share)))
    pick = np.sort(np.random.default_rng(seed).choice(len(synthesized), k, replace=False))
    extra = synthesized.subset(pick)
    measured = np.concatenate([np.ones(n, bool) if surveys.measured is None else surveys.measured,
                               np.zeros(k, bool) if extra.measured is None else extra.measured])
    mixed = CloudSet(np.concatenate([surveys.points, extra.points]), np.concatenate([surveys.labels, extra.labels]),
                     surveys.class_names, np.concatenate([surveys.headings_deg, extra.headings_deg]),
                     np.concatenate([surveys.tilts_deg, extra.tilts_deg]), surveys.scale_m, surveys.z_ref, measured)
    return mixed, np.arange(n + k) < n


def tune_on_surveys(members: Sequence[PointNet], data: CloudSet, settings: SurveySettings, train_cfg: TrainConfig,
                    progress: bool = True) -> list[TrainResult]:
    """Each network of ``members`` trained on from its weights on the stage's clouds ``data`` (module docstring);
    the results in order (each with its own validation split, seeded by ``train_cfg.seed`` + its index)."""
    cfg = replace(train_cfg, epochs=settings.epochs, lr=settings.lr, patience=settings.epochs)
    return [train(data, replace(cfg, seed=train_cfg.seed + k), progress=progress, init=m)
            for k, m in enumerate(members)]
