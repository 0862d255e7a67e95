"""How a cloud (metres) becomes the classifier's input: unit sphere, or a fixed scale with z the height above the
seabed (:class:`classify.training.synthesis_settings.SynthesisSettings` ``scale_m`` and ``z_ref``); shared by synthesis
and inference."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from classify.errors import SynthesisError

F64 = npt.NDArray[np.float64]
F32 = npt.NDArray[np.float32]


def normalize_cloud(points: F64 | F32, scale_m: float = 0.0, z_ref: str = "mean", seabed_z: float = 0.0) -> F64:
    """Unit sphere (``scale_m <= 0``), else centred on the mean and divided by ``scale_m`` metres.

    ``z_ref = "seabed"`` (with ``scale_m > 0``): centred on the mean horizontally only; z becomes
    ``(z - seabed_z) / scale_m``, the (NED, so negative) height above a seabed at depth ``seabed_z``.
    """
    if scale_m <= 0:
        return normalize_unit_sphere(points)
    p = np.asarray(points, dtype=np.float64)
    if z_ref == "seabed":
        c = np.array([*p[:, :2].mean(axis=0), seabed_z]) if len(p) else np.array([0.0, 0.0, seabed_z])
        return (p - c) / scale_m
    if z_ref != "mean":
        raise SynthesisError(f"z_ref must be 'mean' or 'seabed', not {z_ref!r}")
    return (p - p.mean(axis=0)) / scale_m


def normalize_unit_sphere(points: F64 | F32) -> F64:
    """Centre on the mean and divide by the largest norm (a single point maps to the origin)."""
    p = np.asarray(points, dtype=np.float64)
    p = p - p.mean(axis=0)
    r = float(np.linalg.norm(p, axis=1).max()) if len(p) else 0.0
    return p / r if r > 0 else p
