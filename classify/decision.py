"""An object's class from all its evidence: the network's class probabilities, what its acoustic shadows measure,
and its cloud's size, weighed by a multinomial logistic regression fitted on the objects of simulated surveys.

The network sees a cloud; recon also measures an object's top from its shadows (:mod:`recon.shadow`: two ranges,
independent of the beam pattern), how the shadow tops over its footprint spread and how high the seabed's own
shadows around it reach (a rough seabed's), its extent, its point count and how long it was seen. How much a
shadow height should overrule the network depends on those: on a rough seabed a half pipe's shadow reads high. A
:class:`DecisionModel` learns the weights from data: the objects recon finalizes on simulated surveys drawn over the
survey space and the acoustic space (``[decision]`` of the training settings, fitted after the networks,
:mod:`classify.training.decision_fit`), each labelled by the simulator's truth (its class, or ``clutter``).

The evidence of one object is a float vector (:data:`EVIDENCE`, NaN where unknown); :func:`features` turns the
network's probabilities and the evidence into the regression's inputs (:data:`FEATURES`): the log-probabilities,
the shadow height and its square with a flag (so each class's weight is a Gaussian in the height, as
:mod:`classify.shadow_height` assumes, with a width the data choose), the shadow tops' quantiles over the footprint
and over the ring with their flags and counts, and the cloud's extents, top over the seabed, log point count and
log time span. Inputs are standardized with the training set's mean and scale; the output is a probability per
class (softmax), which takes the place of the network's in the clutter rule and the class.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field

F64 = npt.NDArray[np.float64]

#: an object's evidence besides its cloud (m, s, counts; NaN: unknown), in this order
EVIDENCE: tuple[str, ...] = (
    "shadow_height_m",  # its top over the seabed from its shadows (recon.shadow), NaN: not measured
    "length_m", "width_m", "height_m",  # the cloud's extent (north, east, down)
    "top_m",  # the cloud's top over the seabed under it
    "n_points",
    "span_s",  # time between its first and last point
    "footprint_q50_m", "footprint_q75_m", "footprint_q90_m",  # shadow tops over its footprint
    "ring_q50_m", "ring_q75_m", "ring_q90_m",  # the seabed's shadow tops around it
    "footprint_tops", "ring_tops",  # how many of each
)
#: the regression's inputs after the class log-probabilities (:func:`features`)
FEATURES: tuple[str, ...] = (
    "has_height", "height", "height^2",
    "short_side_m", "long_side_m", "height_m", "top_m", "log_points", "log_span",
    "has_footprint", "footprint_q50", "footprint_q75", "footprint_q90",
    "footprint_q50^2", "footprint_q75^2", "footprint_q90^2",
    "has_ring", "ring_q50", "ring_q75", "ring_q90", "log_footprint_tops", "log_ring_tops", "q90_over_ring",
)
#: the probability of ``clutter`` from which a decision calls an object clutter: the regression's probabilities are
#: calibrated on its own objects, so the most probable of two classes, as a threshold
CLUTTER_THRESHOLD = 0.5
#: the least probability taken into a logarithm (a network certain of a class gives others ~1e-9)
LOG_FLOOR = 1e-6
#: most classes and inputs a stored model may have (a checkpoint is data from anywhere)
MAX_CLASSES = 256
MAX_FEATURES = MAX_CLASSES + len(FEATURES)


def _col(ev: F64, name: str) -> F64:
    return ev[:, EVIDENCE.index(name)]


def features(prob: npt.ArrayLike, evidence: npt.ArrayLike) -> F64:
    """The regression's inputs ``(n, k + len(FEATURES))`` of ``n`` objects: their class probabilities ``(n, k)`` and
    evidence ``(n, len(EVIDENCE))`` (module docstring)."""
    p = np.asarray(prob, dtype=np.float64)
    ev = np.asarray(evidence, dtype=np.float64).reshape(p.shape[0], len(EVIDENCE))
    h = _col(ev, "shadow_height_m")
    has_h = np.isfinite(h)
    h0 = np.where(has_h, h, 0.0)
    ext = ev[:, [EVIDENCE.index(n) for n in ("length_m", "width_m")]]
    short, long = np.nan_to_num(ext.min(axis=1)), np.nan_to_num(ext.max(axis=1))
    foot = ev[:, [EVIDENCE.index(f"footprint_q{q}_m") for q in (50, 75, 90)]]
    ring = ev[:, [EVIDENCE.index(f"ring_q{q}_m") for q in (50, 75, 90)]]
    has_f: npt.NDArray[np.bool_] = np.all(np.isfinite(foot), axis=1)
    has_r: npt.NDArray[np.bool_] = np.all(np.isfinite(ring), axis=1)
    f0, r0 = np.where(has_f[:, None], foot, 0.0), np.where(has_r[:, None], ring, 0.0)
    cols = [np.log(np.clip(p, LOG_FLOOR, 1.0)),
            np.column_stack([has_h, h0, h0 * h0, short, long, np.nan_to_num(_col(ev, "height_m")),
                             np.nan_to_num(_col(ev, "top_m")),
                             np.log(np.maximum(np.nan_to_num(_col(ev, "n_points")), 1.0)),
                             np.log1p(np.maximum(np.nan_to_num(_col(ev, "span_s")), 0.0)), has_f]),
            f0, f0 * f0,
            np.column_stack([has_r, r0, np.log1p(np.nan_to_num(_col(ev, "footprint_tops"))),
                             np.log1p(np.nan_to_num(_col(ev, "ring_tops"))),
                             np.where(has_f & has_r, f0[:, 2] - r0[:, 2], 0.0)])]
    return np.hstack(cols)


class DecisionMeta(BaseModel):
    """A :class:`DecisionModel` as stored in a checkpoint's calibration and its inference export (lists of
    numbers; shapes checked by :meth:`DecisionModel.from_meta`)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    class_names: Annotated[tuple[str, ...], Field(min_length=2, max_length=MAX_CLASSES)]
    evidence: tuple[str, ...]
    mean: Annotated[list[float], Field(max_length=MAX_FEATURES)]
    scale: Annotated[list[Annotated[float, Field(gt=0.0)]], Field(max_length=MAX_FEATURES)]
    coef: Annotated[list[list[float]], Field(max_length=MAX_CLASSES)]
    intercept: Annotated[list[float], Field(max_length=MAX_CLASSES)]
    clutter_threshold: Annotated[float, Field(ge=0.0, le=1.0)] = CLUTTER_THRESHOLD
    fitted_on: dict[str, Any] = Field(default_factory=dict)


@dataclass(frozen=True)
class DecisionModel:
    """A fitted decision (module docstring): standardization ``mean``/``scale`` and the regression's ``coef``
    ``(k, f)`` and ``intercept`` ``(k,)`` over :func:`features` of the classes ``class_names``;
    ``clutter_threshold``: the probability of ``clutter`` from which an object is called clutter."""

    class_names: tuple[str, ...]
    mean: F64
    scale: F64
    coef: F64
    intercept: F64
    clutter_threshold: float = CLUTTER_THRESHOLD
    fitted_on: dict[str, Any] | None = None

    def probabilities(self, prob: npt.ArrayLike, evidence: npt.ArrayLike) -> F64:
        """Class probabilities ``(n, k)`` of objects with network probabilities ``prob`` ``(n, k)`` (same classes,
        same order) and ``evidence`` ``(n, len(EVIDENCE))``."""
        x = (features(prob, evidence) - self.mean) / self.scale
        z = x @ self.coef.T + self.intercept
        z -= z.max(axis=1, keepdims=True)
        e = np.exp(z)
        return np.asarray(e / e.sum(axis=1, keepdims=True), dtype=np.float64)

    def to_meta(self) -> DecisionMeta:
        return DecisionMeta(class_names=self.class_names, evidence=EVIDENCE, mean=self.mean.tolist(),
                            scale=self.scale.tolist(), coef=self.coef.tolist(), intercept=self.intercept.tolist(),
                            clutter_threshold=self.clutter_threshold, fitted_on=dict(self.fitted_on or {}))

    @classmethod
    def from_meta(cls, meta: DecisionMeta | dict[str, Any], class_names: Sequence[str]) -> DecisionModel:
        """The model stored as ``meta``, for a classifier of ``class_names``; ValueError when it was fitted for
        other classes or other evidence, or its arrays do not fit together."""
        m = meta if isinstance(meta, DecisionMeta) else DecisionMeta.model_validate(meta)
        if tuple(m.class_names) != tuple(class_names):
            raise ValueError(f"decision model of classes {list(m.class_names)}, the network's are {list(class_names)}")
        if tuple(m.evidence) != EVIDENCE:
            raise ValueError(f"decision model over evidence {list(m.evidence)}, this version reads {list(EVIDENCE)}")
        k, f = len(class_names), len(class_names) + len(FEATURES)
        coef = np.asarray(m.coef, dtype=np.float64)
        if coef.shape != (k, f) or len(m.mean) != f or len(m.scale) != f or len(m.intercept) != k:
            raise ValueError(f"decision model arrays: coef {coef.shape}, mean {len(m.mean)}, scale {len(m.scale)}, "
                             f"intercept {len(m.intercept)}; expected ({k}, {f}), {f}, {f}, {k}")
        return cls(tuple(class_names), np.asarray(m.mean, np.float64), np.asarray(m.scale, np.float64), coef,
                   np.asarray(m.intercept, np.float64), float(m.clutter_threshold), dict(m.fitted_on))


def fit_decision(prob: npt.ArrayLike, evidence: npt.ArrayLike, labels: npt.ArrayLike, class_names: Sequence[str],
                 c: float = 1.0, clutter_threshold: float = CLUTTER_THRESHOLD,
                 fitted_on: dict[str, Any] | None = None) -> DecisionModel:
    """Fit a :class:`DecisionModel` (scikit-learn's multinomial logistic regression, L2 penalty of inverse
    strength ``c``) on objects with network probabilities ``prob`` ``(n, k)``, ``evidence`` and true class indices
    ``labels`` (into ``class_names``). A class with no object gets an intercept that keeps it below 1e-9."""
    from sklearn.linear_model import LogisticRegression

    x = features(prob, evidence)
    y = np.asarray(labels, dtype=np.int64)
    if len(np.unique(y)) < 2:
        raise ValueError(f"a decision model needs objects of two classes at least, got {len(np.unique(y))}")
    mean = x.mean(axis=0)
    scale = x.std(axis=0)
    scale = np.where(scale > 1e-9, scale, 1.0)
    reg = LogisticRegression(C=float(c), max_iter=5000).fit((x - mean) / scale, y)
    k = len(class_names)
    coef = np.zeros((k, x.shape[1]))
    intercept = np.full(k, -30.0 + float(np.min(reg.intercept_)) if len(reg.classes_) < k else 0.0)
    if len(reg.classes_) == 2:  # scikit-learn's binary form: one row for the second class
        coef[reg.classes_[1]], intercept[reg.classes_[1]] = reg.coef_[0], reg.intercept_[0]
        intercept[reg.classes_[0]] = 0.0
    else:
        coef[reg.classes_], intercept[reg.classes_] = reg.coef_, reg.intercept_
    return DecisionModel(tuple(class_names), mean, scale, coef, intercept, clutter_threshold, fitted_on)


def no_evidence(n: int) -> F64:
    """``(n, len(EVIDENCE))`` of NaN: objects of which nothing but the cloud is known."""
    return np.full((n, len(EVIDENCE)), math.nan)
