"""What every classifier of reconstructed clouds does around its network, without PyTorch: check, subsample and
normalize a cloud, batch clouds, and decide the class (or ``clutter``) from the probabilities.

:class:`CloudClassifier` holds a checkpoint's inference settings (class names, points per cloud, normalization
``scale_m`` / ``z_ref``, clutter threshold, yaw views, the decision model over each object's evidence,
:mod:`classify.decision`); a subclass supplies the forward pass of one batch of normalized clouds
(:meth:`CloudClassifier.batch_probabilities`): :class:`classify.infer.Classifier` with PyTorch,
:class:`classify.numpy_infer.NumpyClassifier` with NumPy from an inference export. The pre- and post-processing
below is theirs alike. See :mod:`classify.infer` for what a classification is (subsampling, seabed reference, yaw
views, clutter rule).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from classify.decision import DecisionMeta, DecisionModel
from classify.errors import CheckpointError, InvalidCloudError
from classify.labels import CLUTTER
from classify.normalize import normalize_cloud
from classify.shadow_height import weighed

DEFAULT_MODEL = Path(__file__).resolve().parent / "data" / "pointnet_default.pt"
#: the clutter threshold of a checkpoint whose calibration has none
DEFAULT_CLUTTER_THRESHOLD = 0.5
#: views per cloud, turned about the vertical in equal steps, whose probabilities are averaged (1: the cloud as is)
YAW_VIEWS = 4


def check_cloud(points: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """The cloud as float64 ``(n, 3)``; raises :class:`InvalidCloudError` on a bad shape, no points, NaN or inf."""
    try:
        p = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidCloudError(f"point cloud is not numeric: {exc}") from exc
    if p.ndim != 2 or p.shape[1] != 3:
        raise InvalidCloudError(f"point cloud must have shape (n, 3), got {p.shape}")
    if len(p) == 0:
        raise InvalidCloudError("point cloud is empty")
    bad = ~np.isfinite(p).all(axis=1)
    if bad.any():
        raise InvalidCloudError(
            f"point cloud holds {int(bad.sum())} point(s) with NaN or inf (first at index {int(np.argmax(bad))}); "
            "drop them before classifying")
    return p


def pad_by_repeating(points: npt.NDArray[np.float32], n: int) -> npt.NDArray[np.float32]:
    """The cloud ``(m, 3)`` grown to ``(n, 3)``, ``n >= m``, by repeating its points in order (the set is unchanged)."""
    return points if len(points) == n else np.resize(points, (n, points.shape[1]))


def seabed_or_deepest(points: npt.NDArray[np.float64], seabed_depth: float | None) -> float:
    """``seabed_depth`` when known (finite), else the cloud's deepest point (NED z max)."""
    if seabed_depth is None or not np.isfinite(seabed_depth):
        return float(points[:, 2].max())
    return float(seabed_depth)


class CloudClassifier:
    """A checkpoint's inference settings and the steps around its network (see the module doc). ``clutter_threshold``
    None: :data:`DEFAULT_CLUTTER_THRESHOLD`."""

    #: what runs the network: ``"torch"`` or ``"numpy"``
    backend = "none"

    def __init__(self, class_names: Sequence[str], n_points: int, scale_m: float, z_ref: str,
                 clutter_threshold: float | None, yaw_views: int = YAW_VIEWS,
                 shadow_tops: Mapping[str, float] | None = None,
                 decision: DecisionMeta | Mapping[str, object] | None = None) -> None:
        if yaw_views < 1:
            raise ValueError(f"yaw_views must be >= 1, got {yaw_views}")
        self.yaw_views = int(yaw_views)
        self.class_names = tuple(class_names)
        self.n_points = int(n_points)
        self.scale_m = float(scale_m or 0.0)
        self.z_ref = str(z_ref or "mean")
        #: index of ``clutter`` among the outputs (None: a model without it)
        self.clutter_index = self.class_names.index(CLUTTER) if CLUTTER in self.class_names else None
        self.clutter_threshold = DEFAULT_CLUTTER_THRESHOLD if clutter_threshold is None else float(clutter_threshold)
        #: m: the top height of each class of solid shape, weighed against an object's shadow height in
        #: :meth:`decide` (:mod:`classify.shadow_height`; None or empty: never)
        self.shadow_tops = dict(shadow_tops) if shadow_tops else None
        #: the decision over the network's probabilities and each object's evidence (:mod:`classify.decision`): what
        #: :meth:`decide` applies when it is given the evidence; None: the network's probabilities and the shadow
        #: heights' weights decide
        self.decision: DecisionModel | None = None
        if decision is not None:
            try:
                self.decision = DecisionModel.from_meta(
                    decision if isinstance(decision, DecisionMeta) else dict(decision), self.class_names)
            except ValueError as exc:
                raise CheckpointError(f"calibration.decision: {exc}") from exc

    @property
    def object_classes(self) -> tuple[str, ...]:
        """The object classes the model names (its outputs less ``clutter``): what a scene can place."""
        return tuple(n for n in self.class_names if n != CLUTTER)

    @property
    def needs_seabed(self) -> bool:
        """True when the model reads the height above the seabed (pass ``seabed_depth``)."""
        return self.z_ref == "seabed" and self.scale_m > 0

    def prepare(self, points: npt.ArrayLike, seabed_depth: float | None = None) -> npt.NDArray[np.float32]:
        """Checked, subsampled, normalized cloud ``(min(n, n_points), 3)`` float32 (unit sphere, or centred
        and divided by the checkpoint's ``scale_m`` metres; z from ``seabed_depth`` for a seabed model)."""
        p = check_cloud(points)
        seabed = seabed_or_deepest(p, seabed_depth)  # from the whole cloud, before subsampling
        if len(p) > self.n_points:
            idx = np.random.default_rng(0).choice(len(p), self.n_points, replace=False)
            p = p[np.sort(idx)]
        return self.normalize(p, seabed)

    def normalize(self, points: npt.NDArray[np.float64], seabed_depth: float | None = None) -> npt.NDArray[np.float32]:
        """The checkpoint's normalization of a checked cloud, as is (no subsampling); ``seabed_depth`` None or
        NaN: the cloud's deepest point."""
        return normalize_cloud(points, self.scale_m, self.z_ref if self.scale_m > 0 else "mean",
                               seabed_or_deepest(points, seabed_depth)).astype(np.float32)

    def batch_probabilities(self, clouds: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """Class probabilities ``(B, k)`` of normalized clouds of equal size ``(B, n, 3)``, each the mean over its
        :attr:`yaw_views` views (the subclass's network)."""
        raise NotImplementedError

    def probabilities(self, clouds: Sequence[npt.ArrayLike], batch_size: int = 16,
                      seabed_depths: Sequence[float | None] | None = None) -> npt.NDArray[np.float32]:
        """Class probabilities ``(len(clouds), k)``. ``seabed_depths``: per cloud the seabed depth under it (m, NED;
        None/NaN: unknown).

        One forward pass serves every ensemble member, every yaw view and up to ``batch_size`` clouds (16 clouds x 4
        views x 256 points x 4 members: about 64 MB for the widest layer's output; an engine poll rarely hands over
        more). Clouds of unequal size share a pass: each is padded to the longest by repeating its own points
        (:func:`pad_by_repeating`); the network pools every per-point feature with a maximum, which repeated points
        leave unchanged, so a cloud's probabilities do not depend on the others in its batch (to float32
        rounding)."""
        depths = list(seabed_depths) if seabed_depths is not None else [None] * len(clouds)
        if len(depths) != len(clouds):
            raise InvalidCloudError(f"{len(depths)} seabed depths for {len(clouds)} clouds")
        prepared = [self.prepare(c, d) for c, d in zip(clouds, depths, strict=True)]
        out = np.zeros((len(prepared), len(self.class_names)), dtype=np.float32)
        for i in range(0, len(prepared), batch_size):
            chunk = prepared[i:i + batch_size]
            n = max(len(p) for p in chunk)
            out[i:i + len(chunk)] = self.batch_probabilities(np.stack([pad_by_repeating(p, n) for p in chunk]))
        return out

    def set_clutter_threshold(self, threshold: float) -> None:
        """Call clutter from ``threshold`` on (``math.inf``: never), the network's rule and the decision's alike."""
        self.clutter_threshold = float(threshold)
        if self.decision is not None:
            self.decision = replace(self.decision, clutter_threshold=float(threshold))

    def decide_with_probabilities(self, prob: npt.NDArray[np.float32], allow_clutter: bool | Sequence[bool] = True,
                                  shadow_heights: Sequence[float] | None = None, evidence: npt.ArrayLike | None = None
                                  ) -> tuple[list[tuple[str, float]], npt.NDArray[np.float64]]:
        """:meth:`decide`'s classes and the probabilities ``(n, k)`` its rule was applied to: the :attr:`decision`'s
        over ``prob`` and the objects' ``evidence`` (``(n, len(classify.decision.EVIDENCE))``) when both are there,
        else ``prob``."""
        p = np.asarray(prob, dtype=np.float64).reshape(-1, len(self.class_names))
        if self.decision is not None and evidence is not None:
            q = self.decision.probabilities(p, evidence)
            return self.rule(q, allow_clutter, self.decision.clutter_threshold), q
        return self.rule(p, allow_clutter, self.clutter_threshold, shadow_heights), p

    def decide(self, prob: npt.NDArray[np.float32], allow_clutter: bool | Sequence[bool] = True,
               shadow_heights: Sequence[float] | None = None,
               evidence: npt.ArrayLike | None = None) -> list[tuple[str, float]]:
        """``(class_name, score)`` per row of probabilities ``(n, k)`` (:meth:`rule`). With the objects' ``evidence``
        and a :attr:`decision`, the decision's probabilities and threshold; else the network's and
        :attr:`clutter_threshold`, the object classes weighed by the objects' ``shadow_heights`` (m, one per row,
        NaN: none; :func:`classify.shadow_height.weighed` with :attr:`shadow_tops`) when given."""
        return self.decide_with_probabilities(prob, allow_clutter, shadow_heights, evidence)[0]

    def rule(self, prob: npt.ArrayLike, allow_clutter: bool | Sequence[bool] = True, threshold: float | None = None,
             shadow_heights: Sequence[float] | None = None) -> list[tuple[str, float]]:
        """``(class_name, score)`` per row of probabilities ``(n, k)``: ``clutter`` with its probability where that
        reaches ``threshold`` (None: :attr:`clutter_threshold`; and ``allow_clutter``, per row or for all), else the
        most probable object class with its probability, weighed by ``shadow_heights`` when given."""
        p = np.asarray(prob, dtype=np.float64).reshape(-1, len(self.class_names))
        allow = np.broadcast_to(np.asarray(allow_clutter, dtype=bool), (p.shape[0],))
        obj = p.copy()
        if self.clutter_index is not None:
            obj[:, self.clutter_index] = 0.0
        obj = weighed(obj, shadow_heights, self.class_names, self.shadow_tops)
        clutter = np.zeros(p.shape[0], bool)
        if self.clutter_index is not None:
            limit = self.clutter_threshold if threshold is None else threshold
            clutter = allow & (p[:, self.clutter_index] >= limit)
            obj[:, self.clutter_index] = -1.0
        ks = np.where(clutter, self.clutter_index if self.clutter_index is not None else 0, obj.argmax(axis=1))
        return [(self.class_names[int(k)], float(p[i, k] if clutter[i] else obj[i, k])) for i, k in enumerate(ks)]

    def classify(self, points: npt.ArrayLike, seabed_depth: float | None = None,
                 allow_clutter: bool = True) -> tuple[str, float]:
        """``(class_name, score)`` of one object's cloud ``(n, 3)`` (world frame, NED m) over a seabed at
        ``seabed_depth`` (m; None: unknown); ``allow_clutter`` False: an object class whatever the model says."""
        return self.decide(self.probabilities([points], seabed_depths=[seabed_depth]), allow_clutter)[0]

    def classify_many(self, clouds: Sequence[npt.ArrayLike], seabed_depths: Sequence[float | None] | None = None,
                      allow_clutter: bool | Sequence[bool] = True) -> list[tuple[str, float]]:
        """:meth:`classify` for several clouds (``allow_clutter``: for all, or one flag per cloud)."""
        if not len(clouds):
            return []
        return self.decide(self.probabilities(clouds, seabed_depths=seabed_depths), allow_clutter)
