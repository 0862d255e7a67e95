"""The decision stage of training (``[decision]``): the decision model of :mod:`classify.decision` fitted on the
objects recon finalizes in simulated surveys, after the networks are final.

The surveys are drawn like the survey stage's (:mod:`classify.training.survey_tuning`: the survey space of
``auvlink eval --surveys`` and the acoustic space, every ``ideal_every``-th survey under the idealized model), from
their own seed, so the networks never trained on these objects and their probabilities are what they give on
surveys they have not seen. Each object brings its cloud (through the finished classifier: its class probabilities),
its evidence (:data:`classify.decision.EVIDENCE`) and its label from the simulator's truth (``clutter`` where no
object lies within 1 m). The regression is fitted twice: on a part of the surveys' objects (``holdout`` of them, a
seeded draw, left out) to report how the decision and the network's own rule do on the rest
(:func:`decision_stage`'s metrics), then on all of them: that one is stored.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from classify.cloud_classifier import CloudClassifier
from classify.decision import DecisionModel, fit_decision
from classify.labels import CLUTTER
from classify.training.dataset import CloudSet


@dataclass(frozen=True)
class DecisionSettings:
    """``[decision]``: the surveys whose objects fit the decision model (0: none, the network's rule decides), their
    draw, the regression's inverse penalty ``c`` and the share of objects held out for the report."""

    surveys: int = 0
    seed: int = 43
    acoustics: str = "random"  # acoustic space of auvlink.evaluation.acoustic_draw
    sonar: str = "didson"  # the sonar model flown, or random per survey (auvlink.evaluation.draw.survey_sonar)
    ideal_every: int = 4  # every k-th survey (indices k - 1, 2k - 1, ...) under the idealized model; 0: none
    c: float = 1.0
    holdout: float = 0.25
    workers: int = 2

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> DecisionSettings:
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


#: what gives the surveys' objects: the settings and the class names -> their clouds and evidence (the application
#: layer's :func:`auvlink.evaluation.survey_clouds.survey_object_set`)
SurveyObjects = Callable[[DecisionSettings, Sequence[str]], tuple[CloudSet, npt.NDArray[np.float64]]]


def cloud_probabilities(clf: CloudClassifier, data: CloudSet) -> npt.NDArray[np.float32]:
    """Probabilities ``(len(data), k)`` of every cloud of ``data`` through the inference path (the clouds back in
    metres over a seabed at z = 0)."""
    pts = data.points * data.scale_m if data.scale_m > 0 else data.points
    return clf.probabilities(list(pts), batch_size=16, seabed_depths=[0.0] * len(pts))


def _scores(names: Sequence[str], pred: Sequence[str], true: npt.NDArray[np.int64]) -> dict[str, float]:
    """Over objects: the share named right; over the clusters that are objects, the share reported with their class
    (recall-like); over the reported, the share right (precision-like)."""
    truth = np.array([names[k] for k in true])
    pred_a = np.asarray(pred)
    reported = pred_a != CLUTTER
    objects = truth != CLUTTER
    right = (pred_a == truth) & reported
    return {"accuracy": float(np.mean(pred_a == truth)) if len(truth) else float("nan"),
            "object_recall": float(right.sum() / max(int(objects.sum()), 1)),
            "reported_precision": float(right.sum() / max(int(reported.sum()), 1))}


def decision_stage(clf: CloudClassifier, settings: DecisionSettings,
                   survey_objects: SurveyObjects) -> tuple[DecisionModel, dict[str, Any]]:
    """The decision model of the finished classifier ``clf`` fitted on the objects of ``settings.surveys`` simulated
    surveys (module docstring), and the stage's metrics (objects per class, the held-out comparison)."""
    names = list(clf.class_names)
    data, evidence = survey_objects(settings, tuple(names))
    if len(np.unique(data.labels)) < 2:
        raise ValueError(f"{settings.surveys} surveys gave objects of {len(np.unique(data.labels))} class(es): "
                         "draw more ([decision] surveys)")
    prob = cloud_probabilities(clf, data)
    fitted_on = {k: v for k, v in settings.to_dict().items() if k != "workers"}
    rng = np.random.default_rng(settings.seed)
    held = rng.random(len(data)) < settings.holdout
    metrics: dict[str, Any] = {"settings": settings.to_dict(), "n_objects": len(data),
                               "objects_per_class": dict(zip(names, np.bincount(data.labels, minlength=len(names))
                                                             .tolist(), strict=True))}
    if held.any() and len(np.unique(data.labels[~held])) >= 2:
        part = fit_decision(prob[~held], evidence[~held], data.labels[~held], names, settings.c)
        rows = np.flatnonzero(held)
        heights = evidence[rows, 0].tolist()
        before = [c for c, _ in clf.decide(prob[rows], shadow_heights=heights)]
        after = [c for c, _ in clf.rule(part.probabilities(prob[rows], evidence[rows]),
                                        threshold=part.clutter_threshold)]
        metrics["holdout"] = {"n_objects": int(rows.size), "network_rule": _scores(names, before, data.labels[rows]),
                              "decision": _scores(names, after, data.labels[rows])}
    model = fit_decision(prob, evidence, data.labels, names, settings.c, fitted_on=fitted_on)
    return model, metrics
