"""The classifier's network in NumPy (float32), from a checkpoint's inference export: no PyTorch at inference.

:class:`NumpyStack` is :class:`classify.ensemble.StackedPointNets` in NumPy: every ensemble member, yaw view and
cloud in one pass, one batched matrix product per layer over ``members x (clouds x views x points)`` rows (the
folded weights of :mod:`classify.inference_export`, ``(M, out, in)``), ReLU, the max pool over each cloud's points,
each cloud's T-Net transform, the head, and the softmax mean over the members as :class:`classify.ensemble.Ensemble`
takes it (the softmax of the log of the members' mean probability). Its probabilities equal PyTorch's to float32
rounding (about 1e-7; the two libraries' matrix products sum in different orders), not to the bit.

:func:`load_classifier` is what replay, live and batch runs call: the checkpoint's export when it matches the
checkpoint (:func:`classify.inference_export.matching_export`), else the checkpoint with PyTorch
(:class:`classify.infer.Classifier`, imported only then) and an :class:`~classify.errors.InferenceExportWarning`
saying why.
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import numpy.typing as npt
from threadpoolctl import ThreadpoolController

from classify.cloud_classifier import DEFAULT_MODEL, YAW_VIEWS, CloudClassifier
from classify.errors import CheckpointError, InferenceExportWarning
from classify.inference_export import F32, InferenceExport, export_path, matching_export

LOG_FLOOR = np.float32(1e-12)  # the probability floor before the log, as Ensemble.forward's clamp_min(1e-12)


class _Layer:
    """One layer of every member: ``x @ w^T + b`` with ``w`` ``(M, out, in)`` (read through a transposed view)."""

    def __init__(self, weight: F32, bias: F32) -> None:
        self.wt = weight.transpose(0, 2, 1)  # (M, in, out)
        self.b = bias[:, None, :]  # (M, 1, out)

    def linear(self, x: F32) -> F32:
        """``x`` ``(M or 1, R, in)`` -> ``(M, R, out)`` (a shared ``x`` broadcast over the members)."""
        y = np.matmul(x, self.wt)
        y += self.b
        return y

    def __call__(self, x: F32, relu: bool = True) -> F32:
        y = self.linear(x)
        return np.maximum(y, 0, out=y) if relu else y

    def pooled(self, x: F32, clouds: int) -> F32:
        """``relu(x @ w^T + b)`` max-pooled over each cloud's points: ``(M, clouds * n, in)`` -> ``(M, clouds,
        out)`` (the ReLU after the maximum: the same numbers, the per-point tensor passed over once)."""
        y = self.linear(x)
        g = y.reshape(y.shape[0], clouds, -1, y.shape[-1]).max(axis=2)
        return np.maximum(g, 0, out=g)


def _sequence(export: InferenceExport, prefix: str) -> list[_Layer]:
    """The layers ``prefix.0``, ``prefix.1``, ... of the export, in order."""
    pattern = re.compile(re.escape(prefix) + r"\.(\d+)")
    found = sorted((int(m.group(1)), name) for name in export.layers if (m := pattern.fullmatch(name)))
    if not found or [i for i, _ in found] != list(range(len(found))):
        raise CheckpointError(f"inference export: the layers {prefix}.0, {prefix}.1, ... are missing or have gaps")
    return [_Layer(*export.layers[name]) for _, name in found]


def _layer(export: InferenceExport, name: str) -> _Layer:
    if name not in export.layers:
        raise CheckpointError(f"inference export: layer {name!r} is missing")
    return _Layer(*export.layers[name])


class _TNet:
    """Every member's T-Net (:class:`classify.pointnet.TNet`): ``(M or 1, clouds * n, k)`` -> ``(M, clouds, k, k)``."""

    def __init__(self, export: InferenceExport, prefix: str) -> None:
        self.point = _sequence(export, f"{prefix}.point_mlp")
        self.fc = _sequence(export, f"{prefix}.fc")
        self.out = _layer(export, f"{prefix}.out")
        self.k = math.isqrt(self.out.b.shape[-1])

    def __call__(self, x: F32, clouds: int) -> F32:
        for layer in self.point[:-1]:
            x = layer(x)
        g = self.point[-1].pooled(x, clouds)
        for layer in self.fc:
            g = layer(g)
        t = self.out(g, relu=False)
        return t.reshape(t.shape[0], clouds, self.k, self.k)


def _transform(x: F32, trans: F32) -> F32:
    """Each cloud's points ``x`` ``(M or 1, B * n, k)`` times its transform ``trans`` ``(M, B, k, k)``."""
    m, b, k, _ = trans.shape
    return np.matmul(x.reshape(x.shape[0], b, -1, k), trans).reshape(m, -1, k)


def softmax(x: F32, axis: int) -> F32:
    """Softmax along ``axis`` in float32 (shifted by the maximum)."""
    e = np.exp(x - x.max(axis=axis, keepdims=True))
    return e / e.sum(axis=axis, keepdims=True)


class NumpyStack:
    """The export's members as one network: ``__call__(points (B, N, 3) float32) -> class probability (B, k)``.
    :class:`CheckpointError` when the export's layers do not make that network (a layer missing, sizes that do
    not chain: tried on a two-point cloud)."""

    def __init__(self, export: InferenceExport) -> None:
        meta = export.meta
        self.input_tnet = _TNet(export, "input_tnet") if meta.input_transform else None
        self.mlp1 = _sequence(export, "mlp1")
        self.feature_tnet = _TNet(export, "feature_tnet") if meta.feature_transform else None
        self.mlp2 = _sequence(export, "mlp2")
        self.head = _sequence(export, "head")
        self.classifier = _layer(export, "classifier")
        try:
            self(np.zeros((1, 2, 3), dtype=np.float32))
        except ValueError as exc:
            raise CheckpointError(f"inference export: its layers do not chain into a PointNet: {exc}") from exc

    def __call__(self, points: F32) -> F32:
        b, n, _ = points.shape
        x = np.ascontiguousarray(points, dtype=np.float32).reshape(1, b * n, 3)  # shared until a member's transform
        if self.input_tnet is not None:
            x = _transform(x, self.input_tnet(x, b))
        for layer in self.mlp1:
            x = layer(x)
        if self.feature_tnet is not None:
            x = _transform(x, self.feature_tnet(x, b))
        for layer in self.mlp2[:-1]:
            x = layer(x)
        g = self.mlp2[-1].pooled(x, b)
        for layer in self.head:
            g = layer(g)
        logits = self.classifier(g, relu=False)
        if logits.shape[0] == 1:
            return softmax(logits[0], axis=1)
        mean = softmax(logits, axis=2).mean(axis=0, dtype=np.float32)
        return softmax(np.log(np.maximum(mean, LOG_FLOOR)), axis=1)


def turned_views(x: F32, views: int) -> F32:
    """Normalized clouds ``(B, n, 3)`` as ``(B * views, n, 3)``, each turned about the vertical axis by ``0, 360 /
    views, ...`` degrees, the views of one cloud consecutive (:func:`classify.infer.turned_views` in NumPy)."""
    if views <= 1:
        return x
    a = np.arange(views, dtype=np.float32) * np.float32(2.0 * np.pi / views)
    c, s = np.cos(a), np.sin(a)
    rot = np.zeros((views, 3, 3), dtype=np.float32)
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
    return np.matmul(x[:, None], rot.transpose(0, 2, 1)[None]).reshape(-1, x.shape[1], 3)


class NumpyClassifier(CloudClassifier):
    """A checkpoint's inference export ready to classify (NumPy, CPU); ``source``: the export's file; ``threads``:
    the BLAS threads of each forward pass (None: the library's default, every core), the process's other BLAS calls
    left as they are."""

    backend = "numpy"

    def __init__(self, export: InferenceExport, yaw_views: int = YAW_VIEWS, source: Path | None = None,
                 threads: int | None = None) -> None:
        m = export.meta
        super().__init__(m.class_names, m.n_points, m.scale_m, m.z_ref, m.clutter_threshold, yaw_views,
                         m.shadow_tops_m, m.decision)
        self.export = export
        self.source = source
        self.threads = threads
        self.stack = NumpyStack(export)
        self._blas = ThreadpoolController() if threads is not None else None

    def batch_probabilities(self, clouds: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """Class probabilities ``(B, k)`` of normalized clouds ``(B, n, 3)``: one pass of :attr:`stack` over every
        member, view and cloud, the views' probabilities averaged."""
        x = turned_views(np.asarray(clouds, dtype=np.float32), self.yaw_views)
        if self._blas is None:
            prob = self.stack(x)
        else:
            with self._blas.limit(limits=self.threads, user_api="blas"):
                prob = self.stack(x)
        return prob.reshape(len(clouds), self.yaw_views, -1).mean(axis=1, dtype=np.float32)


def load_classifier(path: Path | str | None = None, yaw_views: int = YAW_VIEWS,
                    threads: int | None = None) -> CloudClassifier:
    """The classifier of the checkpoint at ``path`` (None: the shipped model): its inference export when that
    matches the checkpoint (:class:`NumpyClassifier`, no PyTorch), else the checkpoint with PyTorch
    (:class:`classify.infer.Classifier`) and an :class:`~classify.errors.InferenceExportWarning` naming why and how
    to export it. ``threads``: the forward pass's threads (NumPy's BLAS threads during a pass; PyTorch's intra-op
    threads, set for the process); None: as they are."""
    checkpoint = Path(path) if path is not None else DEFAULT_MODEL
    export, why = matching_export(checkpoint)
    if export is not None:
        try:
            return NumpyClassifier(export, yaw_views, export_path(checkpoint), threads)
        except CheckpointError as exc:
            why = f"{export_path(checkpoint)}: {exc}"
    import torch  # only on this path: a run with a matching export never loads PyTorch

    from classify.infer import Classifier

    if threads is not None:
        torch.set_num_threads(threads)
    clf = Classifier.load(checkpoint, yaw_views=yaw_views)  # a bad checkpoint fails here, with its one error line
    warnings.warn(f"{why}: classifying with PyTorch from {checkpoint} (write the export with "
                  f"`auvlink train --export-inference {checkpoint}`)", InferenceExportWarning, stacklevel=2)
    return clf
