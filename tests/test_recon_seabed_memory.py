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
    on = SeabedMemory(SeabedConfig(), TextureConfig(highlights=True))
    on.add_highlights(crests)
    assert len(on.cells) > 0 and on.n_planes == 0  # texture samples, never plane samples
    off = SeabedMemory(SeabedConfig(), TextureConfig())  # the default: the grid from seabed returns alone
    off.add_highlights(crests)
    assert len(off.cells) == 0


def _rough_depth(xy: np.ndarray, rms: float, seed: int) -> np.ndarray:
    """Depth (m) of a level seabed at 20 m with a texture of 8 sinusoids, wavelengths 0.5-8 m, of ``rms`` m."""
    rng = np.random.default_rng(seed)
    lam = np.exp(rng.uniform(np.log(0.5), np.log(8.0), 8))
    ang, ph = rng.uniform(0.0, 2 * np.pi, 8), rng.uniform(0.0, 2 * np.pi, 8)
    k = 2 * np.pi / lam[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    return 20.0 + rms * np.sqrt(2.0 / 8) * np.sin(xy @ k.T + ph).sum(axis=1)


def _half_pipe_kept(seed: int, texture: TextureConfig) -> float:
    """Share of a half pipe's highlight points (0.3 m high, 3 m long, across two 0.5 m cells of a 0.09 m rms seabed
    of texture ``seed``) that stand above the grid fitted with ``texture``."""
    from recon.poll_seabed import object_points

    rng = np.random.default_rng(6)
    xy = rng.uniform(0.0, 30.0, (80_000, 2))
    hidden = (np.abs(xy[:, 0] - 15.0) < 0.3) & (np.abs(xy[:, 1] - 15.0) < 1.5)  # its footprint
    dx = rng.uniform(-0.26, 0.26, 60)  # its top, seen where it stands 0.15 m or more
    top = np.column_stack([15.0 + dx, 15.0 + rng.uniform(-1.4, 1.4, dx.size)])
    pipe = np.column_stack([top, _rough_depth(top, 0.09, seed) - 0.3 * np.sqrt(1.0 - (dx / 0.3) ** 2)])
    mem = SeabedMemory(SeabedConfig(), texture)
    mem.add(np.column_stack([xy[~hidden], _rough_depth(xy[~hidden], 0.09, seed)]))
    mem.add_highlights(pipe)
    model = mem.fit(np.array([10.0, 10.0]), np.array([20.0, 20.0]))
    assert isinstance(model, TexturedSeabed)
    return float(object_points(pipe, model, SeabedConfig()).mean())


def test_a_low_object_on_a_rough_seabed_stays_above_the_grid() -> None:
    """The lowest object on a rough seabed: its cells stand less than clip_k sigma over their neighbourhood on most
    textures, so the grid there must come from the seabed returns beside it (the default). Fed its own highlight
    points, the grid rises under it and most of it falls under the seabed threshold."""
    seeds = range(7, 11)
    alone = [_half_pipe_kept(s, TextureConfig()) for s in seeds]
    fed = [_half_pipe_kept(s, TextureConfig(highlights=True)) for s in seeds]
    assert min(alone) > 0.7
    assert all(a >= f for a, f in zip(alone, fed, strict=True))
    assert np.mean(alone) - np.mean(fed) > 0.2
