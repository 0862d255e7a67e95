"""Points removed as seabed are tested again once the seabed model under them has matured (recon.object_stage)."""

from __future__ import annotations

import numpy as np
import pytest

from recon.object_stage import ObjectStage
from recon.range_arcs import ARC_COLUMNS
from recon.recon_config import ReconConfig
from recon.seabed import SeabedModel

SPREAD = np.radians(14.0)


class LevelMemory:
    """A seabed memory whose fitted model is a level seabed at ``depth`` (m, NED) over any box: the depth is what
    the samples gathered so far say, changed by the test as the survey would change it."""

    def __init__(self, depth: float) -> None:
        self.depth = depth
        self.fits = 0

    def __bool__(self) -> bool:
        return True

    def fit(self, lo: np.ndarray, hi: np.ndarray) -> SeabedModel:
        self.fits += 1
        n, e = np.meshgrid(np.arange(lo[0] - 8.0, hi[0] + 8.0, 0.5), np.arange(lo[1] - 8.0, hi[1] + 8.0, 0.5))
        return SeabedModel.fit(np.column_stack([n.ravel(), e.ravel(), np.full(n.size, self.depth)]))


def low_object(t0: float, n: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A half-pipe-like patch of points 0.3 m above a seabed at 10 m (depth 9.7), one per time step from ``t0``."""
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(0, 0.6, n), rng.uniform(0, 2.0, n), np.full(n, 9.7)])
    arcs = np.tile(np.arange(ARC_COLUMNS, dtype=np.float64), (n, 1))
    return p, t0 + np.linspace(0.0, 1.0, n), arcs


def far_points(t0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A few points far from the low object, 1 m above the seabed, at ``t0``."""
    p = np.array([[40.0, 40.0, 9.0], [40.2, 40.1, 9.0]])
    return p, np.full(2, t0), np.zeros((2, ARC_COLUMNS))


def stage(memory: LevelMemory) -> ObjectStage:
    return ObjectStage(ReconConfig(), memory, SPREAD)  # type: ignore[arg-type]


def test_points_removed_by_an_early_model_come_back_once_due() -> None:
    mem = LevelMemory(depth=9.72)  # the first fit follows the object (0.02 m under its points)
    s = stage(mem)
    p, t, e = low_object(0.0)
    s.add(p, t, e)
    kept, _, _ = s.take_pending()
    assert kept.shape[0] == 0 and s.seabed_removed == p.shape[0]
    mem.depth = 10.0  # the next lines' samples put the seabed 0.3 m under the object
    s.add(*far_points(0.5 * s.config.seabed.revisit_s))  # not due yet: nothing comes back
    kept, _, _ = s.take_pending()
    assert kept.shape[0] == 2
    s.add(*far_points(2.0 + s.config.seabed.revisit_s))
    kept, times, arcs = s.take_pending()
    assert kept.shape[0] == 2 + p.shape[0]
    back = kept[:, 0] < 1.0
    np.testing.assert_array_equal(kept[back], p)  # the same points, times and arcs, in their order
    np.testing.assert_array_equal(times[back], t)
    np.testing.assert_array_equal(arcs[back], e)
    assert s.seabed_removed == 0
    s.add(*far_points(3.0 + 2.0 * s.config.seabed.revisit_s))  # tested once: they are no longer stored
    assert s.take_pending()[0].shape[0] == 2


def test_points_the_later_model_still_calls_seabed_are_dropped() -> None:
    mem = LevelMemory(depth=9.72)
    s = stage(mem)
    s.add(*low_object(0.0))
    s.take_pending()
    s.add(*far_points(1.0 + s.config.seabed.revisit_s))  # the seabed did not change: still seabed
    kept, _, _ = s.take_pending()
    assert kept.shape[0] == 2 and s.seabed_removed == 400
    s.add(*far_points(2.0 + 2.0 * s.config.seabed.revisit_s))
    assert s.take_pending()[0].shape[0] == 2  # tested once, then gone


@pytest.mark.parametrize("streaming", [True, False])
def test_the_end_of_the_mission_tests_every_removed_point_again(streaming: bool) -> None:
    mem = LevelMemory(depth=9.72)
    s = stage(mem)
    p, t, e = low_object(0.0)
    s.add(p, t, e)
    if streaming:  # a poll removed them; the survey ends before they are due
        assert s.poll(np.array([100.0, 100.0, 5.0]), 2.0) == []
        mem.depth = 10.0
        objects = s.finish()
        assert len(objects) == 1 and objects[0].points.shape[0] == p.shape[0]
    else:  # batch: one model over every point, no second test by the same data
        fits = mem.fits
        mem.depth = 9.72
        assert s.finish() == [] and mem.fits == fits + 1


def test_points_next_to_an_emitted_object_stay_removed() -> None:
    mem = LevelMemory(depth=9.0)  # the object at 8.7 stands 0.3 m out: emitted
    s = stage(mem)
    p, t, e = low_object(0.0)
    s.add(p - np.array([0.0, 0.0, 1.0]), t, e)
    assert len(s.poll(np.array([100.0, 100.0, 5.0]), 10.0)) == 1
    mem.depth = 9.72  # its flank, 0.02 m over the next fit, removed ...
    s.add(p, t + 20.0, e)
    s.take_pending()
    mem.depth = 10.0  # ... stands out later, next to the emitted object: not brought back to grow it
    s.add(*far_points(25.0 + s.config.seabed.revisit_s))
    assert s.take_pending()[0].shape[0] == 2
