"""Classifying reconstructed clouds with a trained checkpoint.

``Classifier.load(path).classify(points)`` takes one object's points ``(n, 3)`` in the world frame
(NED, metres), subsamples them to the model's point count when there are more (a fixed-seed draw:
same cloud, same answer), centres and scales them into the unit sphere as in training, and returns
``(class_name, score)`` with the softmax probability as the score. Batch-norm layers are folded
into their linear layers once at load time; inference runs under ``torch.inference_mode``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import torch

from classify.checkpoint import Checkpoint, load_checkpoint
from classify.errors import InvalidCloudError
from classify.pointnet import default_device
from classify.synthesis import normalize_cloud

DEFAULT_MODEL = Path(__file__).resolve().parent / "data" / "pointnet_default.pt"


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


class Classifier:
    """A trained PointNet ready for inference (CPU by default, CUDA when present)."""

    def __init__(self, ckpt: Checkpoint, device: torch.device | None = None) -> None:
        self.device = device or default_device()
        self.class_names = ckpt.class_names
        self.n_points = ckpt.n_points
        self.checkpoint = ckpt
        self.scale_m = float(ckpt.synthesis.get("scale_m", 0.0) or 0.0)
        self.model = ckpt.model.to(self.device).fused().eval()

    @classmethod
    def load(cls, path: Path | str | None = None, device: torch.device | None = None) -> Classifier:
        """Load a checkpoint (the shipped default model when ``path`` is None)."""
        device = device or default_device()
        return cls(load_checkpoint(Path(path) if path is not None else DEFAULT_MODEL, device), device)

    def prepare(self, points: npt.ArrayLike) -> npt.NDArray[np.float32]:
        """Checked, subsampled, normalized cloud ``(min(n, n_points), 3)`` float32 (unit sphere, or centred
        and divided by the checkpoint's ``scale_m`` metres)."""
        p = check_cloud(points)
        if len(p) > self.n_points:
            idx = np.random.default_rng(0).choice(len(p), self.n_points, replace=False)
            p = p[np.sort(idx)]
        return normalize_cloud(p, self.scale_m).astype(np.float32)

    def probabilities(self, clouds: Sequence[npt.ArrayLike], batch_size: int = 8) -> npt.NDArray[np.float32]:
        """Class probabilities ``(len(clouds), k)``; clouds of unequal size run one by one."""
        prepared = [self.prepare(c) for c in clouds]
        out = np.zeros((len(prepared), len(self.class_names)), dtype=np.float32)
        with torch.inference_mode():
            i = 0
            while i < len(prepared):
                n = len(prepared[i])
                j = i + 1
                while j < len(prepared) and j - i < batch_size and len(prepared[j]) == n:
                    j += 1
                x = torch.from_numpy(np.stack(prepared[i:j])).to(self.device)
                out[i:j] = torch.softmax(self.model(x)[0].float(), dim=1).cpu().numpy()
                i = j
        return out

    def classify(self, points: npt.ArrayLike) -> tuple[str, float]:
        """``(class_name, score)`` of one object's cloud ``(n, 3)`` (world frame)."""
        prob = self.probabilities([points])[0]
        k = int(np.argmax(prob))
        return self.class_names[k], float(prob[k])

    def classify_many(self, clouds: Sequence[npt.ArrayLike]) -> list[tuple[str, float]]:
        prob = self.probabilities(clouds)
        ks = prob.argmax(axis=1)
        return [(self.class_names[int(k)], float(prob[i, k])) for i, k in enumerate(ks)]
