"""SeabedMemory.within: the plane samples in a box, as the row-wise mask gave them, after every kind of add."""

from __future__ import annotations

import numpy as np

from recon.seabed import SeabedConfig
from recon.seabed_memory import SeabedMemory
from recon.seabed_texture import TextureConfig


def _reference(sb: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return sb[np.all((sb[:, :2] >= lo) & (sb[:, :2] <= hi), axis=1)]


def test_within_matches_the_row_mask_as_samples_grow() -> None:
    rng = np.random.default_rng(3)
    mem = SeabedMemory(SeabedConfig(), TextureConfig(enabled=False))
    for step in range(4):
        pts = np.column_stack([rng.uniform(-50, 50, (500, 2)), rng.normal(20, 0.1, 500)])
        pts[::97, 0] = np.nan  # a sample without a position is in no box
        mem.add_planes(pts)
        for lo, hi in (((-10.0, -5.0), (10.0, 30.0)), ((-60.0, -60.0), (60.0, 60.0)), ((5.0, 5.0), (5.5, 5.2))):
            got = mem.within(np.array(lo), np.array(hi))
            ref = _reference(mem.points, np.array(lo), np.array(hi))
            if ref.shape[0] < mem.seabed_config.min_points:
                assert got is None
            else:
                assert got is not None and got.tobytes() == ref.tobytes(), step
    other = np.column_stack([rng.uniform(-5, 5, (40, 2)), np.full(40, 21.0)])
    got = mem.within(np.array([-1.0, -1.0]), np.array([1.0, 1.0]), other)  # an explicit sample array
    ref = _reference(other, np.array([-1.0, -1.0]), np.array([1.0, 1.0]))
    assert (got is None and ref.shape[0] < 8) or (got is not None and got.tobytes() == ref.tobytes())
