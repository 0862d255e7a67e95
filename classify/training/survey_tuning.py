"""The survey stage of training: the networks trained on synthesized clouds, trained on from the clouds recon makes
of simulated surveys (``[surveys]`` of the training settings).

Synthesis models what lies between a mesh and the classifier (the first return per beam, the lower beam edge, the
acoustic effects drawn over their space: :mod:`classify.training.scan_acoustics`); a survey goes through all of it
as it is: the rendered image under acoustic conditions drawn over the whole space (every sonar model and profile,
beam pattern, sidelobes, pulse, gain, TVG error, noise floor, interference), recon's highlight extension, seabed
removal, clustering and the fusion of passes. The survey clouds
(:func:`auvlink.evaluation.survey_clouds.survey_cloud_set`: recon's final objects labelled by the simulator's
truth, every cluster that is no object as ``clutter``) come from a draw seed kept apart from evaluation seeds.

Each network continues from its synthesized-cloud weights on the survey clouds (:func:`classify.training.train.train`
with ``init``: the same augmentation, a stratified validation split, early stopping), at the stage's own epochs and
learning rate; the clutter threshold is then calibrated on the survey clouds' validation split, whose clutter is
what recon really hands over.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

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


def tune_on_surveys(members: Sequence[PointNet], data: CloudSet, settings: SurveySettings, train_cfg: TrainConfig,
                    progress: bool = True) -> list[TrainResult]:
    """Each network of ``members`` trained on from its weights on the survey clouds ``data`` (module docstring);
    the results in order (each with its own validation split, seeded by ``train_cfg.seed`` + its index)."""
    cfg = replace(train_cfg, epochs=settings.epochs, lr=settings.lr, patience=settings.epochs)
    return [train(data, replace(cfg, seed=train_cfg.seed + k), progress=progress, init=m)
            for k, m in enumerate(members)]
