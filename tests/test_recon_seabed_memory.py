"""recon.seabed_memory: the seabed samples recon keeps and the model of a poll fitted from them."""

from __future__ import annotations

import numpy as np
import pytest

from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_memory import SeabedMemory
from recon.seabed_texture import TextureConfig, TexturedSeabed


def _plane(n: int, rng: np.random.Generator, size: float = 30.0) -> np.ndarray:
    """Samples of the plane depth = 20 + 0.05 north - 0.02 east (m), with 1 cm of noise."""
    xy = rng.uniform(0.0, size, (n, 2))
    z = 20.0 + 0.05 * xy[:, 0] - 0.02 * xy[:, 1] + rng.normal(0.0, 0.01, n)
    return np.column_stack([xy, z])


def test_empty_memory_fits_nothing() -> None:
    mem = SeabedMemory(SeabedConfig(), TextureConfig())
    assert not mem
    assert mem.points.shape == (0, 3)
    assert mem.fit(np.zeros(2), np.ones(2)) is None
    assert np.isnan(mem.depth_at([[1.0, 1.0]])).all()


def test_points_keep_their_order_across_adds() -> None:
    rng = np.random.default_rng(1)
    a, b, c = _plane(10, rng), _plane(7, rng), _plane(3, rng)
    mem = SeabedMemory(SeabedConfig(), TextureConfig())
    mem.add(a)
    mem.add_planes(b)
    assert np.array_equal(mem.points, np.concatenate([a, b]))
    mem.add_planes(c)
    assert np.array_equal(mem.points, np.concatenate([a, b, c]))
    assert mem.n_planes == 20
    mem.add_texture(_plane(50, rng))  # texture samples are not plane samples
    assert mem.n_planes == 20
    assert len(mem.cells) > 0


def test_fit_and_depth_follow_the_plane() -> None:
    rng = np.random.default_rng(2)
    mem = SeabedMemory(SeabedConfig(), TextureConfig())
    mem.add(_plane(4000, rng))
    model = mem.fit(np.array([10.0, 10.0]), np.array([20.0, 20.0]))
    assert isinstance(model, TexturedSeabed)
    q = np.array([[12.0, 15.0], [18.0, 11.0]])
    truth = 20.0 + 0.05 * q[:, 0] - 0.02 * q[:, 1]
    assert model.depth_at(q) == pytest.approx(truth, abs=0.02)
    assert mem.depth_at(q) == pytest.approx(truth, abs=0.02)


def test_texture_off_fits_the_planes_alone() -> None:
    rng = np.random.default_rng(3)
    mem = SeabedMemory(SeabedConfig(), TextureConfig(enabled=False))
    mem.add(_plane(2000, rng))
    assert len(mem.cells) == 0  # no grid kept
    model = mem.fit(np.array([5.0, 5.0]), np.array([25.0, 25.0]))
    assert isinstance(model, SeabedModel)
    assert model.depth_at(np.array([[15.0, 15.0]]))[0] == pytest.approx(20.0 + 0.75 - 0.3, abs=0.02)


def test_too_few_samples_near_the_box() -> None:
    rng = np.random.default_rng(4)
    mem = SeabedMemory(SeabedConfig(), TextureConfig())
    mem.add(_plane(500, rng, size=10.0))  # all of them far from the box below
    assert mem.fit(np.array([200.0, 200.0]), np.array([210.0, 210.0])) is None
    assert mem.within(np.array([200.0, 200.0]), np.array([210.0, 210.0])) is None


def test_highlights_feed_the_grid_only_when_configured() -> None:
    rng = np.random.default_rng(5)
    crests = _plane(40, rng)
    on = SeabedMemory(SeabedConfig(), TextureConfig())
    on.add_highlights(crests)
    assert len(on.cells) > 0 and on.n_planes == 0  # texture samples, never plane samples
    off = SeabedMemory(SeabedConfig(), TextureConfig(highlights=False))
    off.add_highlights(crests)
    assert len(off.cells) == 0
