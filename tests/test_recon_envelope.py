"""recon's target envelope (recon.target_envelope) against the object catalogue it stands for."""

from __future__ import annotations

import numpy as np

from auvlink.sim.object_meshes import CLASSES, mesh_for
from recon.target_envelope import (
    LARGEST_OBJECT_M,
    LOWEST_OBJECT_M,
    MAX_OBJECT_EXTENT_M,
    MAX_SEABED_THRESHOLD_M,
    MIN_OBJECT_HEIGHT_M,
)


def _extents() -> dict[str, np.ndarray]:
    return {c: np.ptp(mesh_for(c)[0], axis=0) for c in CLASSES}


def test_largest_and_lowest_are_the_catalogue_s() -> None:
    ext = _extents()
    longest = max(float(max(e[0], e[1])) for e in ext.values())
    lowest = min(float(e[2]) for e in ext.values())
    assert abs(longest - LARGEST_OBJECT_M) < 0.02, longest
    assert abs(lowest - LOWEST_OBJECT_M) < 0.02, lowest


def test_every_catalogue_object_passes_the_size_limits() -> None:
    """Any object, at any heading, fits the widest cluster kept, and stands higher than the top and threshold
    limits."""
    for name, e in _extents().items():
        assert float(np.hypot(e[0], e[1])) < MAX_OBJECT_EXTENT_M, name
        assert float(e[2]) > MIN_OBJECT_HEIGHT_M and float(e[2]) > MAX_SEABED_THRESHOLD_M, name
