"""Classifying reconstructed clouds with a trained checkpoint.

``Classifier.load(path).classify(points)`` takes one object's points ``(n, 3)`` in the world frame
(NED, metres), subsamples them to the model's point count when there are more (a fixed-seed draw:
same cloud, same answer), centres and scales them into the unit sphere as in training, and returns
``(class_name, score)`` with the softmax probability as the score. A model trained on
seabed-referenced clouds (synthesis ``z_ref = "seabed"``) also takes the depth of the seabed under the
object (``seabed_depth``, m, NED; recon fits it: :meth:`recon.pipeline.Reconstructor.seabed_depth_at`):
the object's height above the seabed is then a feature. Without it, the cloud's deepest point stands
in for the seabed (objects then look shorter than they are: pass the depth). Batch-norm layers are folded
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


def _seabed_or_deepest(points: npt.NDArray[np.float64], seabed_depth: float | None) -> float:
    """``seabed_depth`` when known (finite), else the cloud's deepest point (NED z max)."""
    if seabed_depth is None or not np.isfinite(seabed_depth):
        return float(points[:, 2].max())
    return float(seabed_depth)


class Classifier:
    """A trained PointNet ready for inference (CPU by default, CUDA when present)."""

    def __init__(self, ckpt: Checkpoint, device: torch.device | None = None) -> None:
        self.device = device or default_device()
        self.class_names = ckpt.class_names
        self.n_points = ckpt.n_points
        self.checkpoint = ckpt
        self.scale_m = float(ckpt.synthesis.get("scale_m", 0.0) or 0.0)
        self.z_ref = str(ckpt.synthesis.get("z_ref", "mean") or "mean")
        self.model = ckpt.model.to(self.device).fused().eval()

    @classmethod
    def load(cls, path: Path | str | None = None, device: torch.device | None = None) -> Classifier:
        """Load a checkpoint (the shipped default model when ``path`` is None)."""
        device = device or default_device()
        return cls(load_checkpoint(Path(path) if path is not None else DEFAULT_MODEL, device), device)

    @property
    def needs_seabed(self) -> bool:
        """True when the model reads the height above the seabed (pass ``seabed_depth``)."""
        return self.z_ref == "seabed" and self.scale_m > 0

    def prepare(self, points: npt.ArrayLike, seabed_depth: float | None = None) -> npt.NDArray[np.float32]:
        """Checked, subsampled, normalized cloud ``(min(n, n_points), 3)`` float32 (unit sphere, or centred
        and divided by the checkpoint's ``scale_m`` metres; z from ``seabed_depth`` for a seabed model)."""
        p = check_cloud(points)
        seabed = _seabed_or_deepest(p, seabed_depth)  # from the whole cloud, before subsampling
        if len(p) > self.n_points:
            idx = np.random.default_rng(0).choice(len(p), self.n_points, replace=False)
            p = p[np.sort(idx)]
        return self.normalize(p, seabed)

    def normalize(self, points: npt.NDArray[np.float64], seabed_depth: float | None = None) -> npt.NDArray[np.float32]:
        """The checkpoint's normalization of a checked cloud, as is (no subsampling); ``seabed_depth`` None or
        NaN: the cloud's deepest point."""
        return normalize_cloud(points, self.scale_m, self.z_ref if self.scale_m > 0 else "mean",
                               _seabed_or_deepest(points, seabed_depth)).astype(np.float32)

    def probabilities(self, clouds: Sequence[npt.ArrayLike], batch_size: int = 8,
                      seabed_depths: Sequence[float | None] | None = None) -> npt.NDArray[np.float32]:
        """Class probabilities ``(len(clouds), k)``; clouds of unequal size run one by one.
        ``seabed_depths``: per cloud the seabed depth under it (m, NED; None/NaN: unknown)."""
        depths = list(seabed_depths) if seabed_depths is not None else [None] * len(clouds)
        if len(depths) != len(clouds):
            raise InvalidCloudError(f"{len(depths)} seabed depths for {len(clouds)} clouds")
        prepared = [self.prepare(c, d) for c, d in zip(clouds, depths, strict=True)]
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

    def classify(self, points: npt.ArrayLike, seabed_depth: float | None = None) -> tuple[str, float]:
        """``(class_name, score)`` of one object's cloud ``(n, 3)`` (world frame, NED m) over a seabed at
        ``seabed_depth`` (m; None: unknown)."""
        prob = self.probabilities([points], seabed_depths=[seabed_depth])[0]
        k = int(np.argmax(prob))
        return self.class_names[k], float(prob[k])

    def classify_many(self, clouds: Sequence[npt.ArrayLike],
                      seabed_depths: Sequence[float | None] | None = None) -> list[tuple[str, float]]:
        prob = self.probabilities(clouds, seabed_depths=seabed_depths)
        ks = prob.argmax(axis=1)
        return [(self.class_names[int(k)], float(prob[i, k])) for i, k in enumerate(ks)]
