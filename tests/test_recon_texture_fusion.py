"""The seabed at the scale of its texture (recon.seabed_texture) and fusion across passes (recon.fusion)."""

from __future__ import annotations

import numpy as np
import pytest

from recon.cluster import ClusterConfig, StreamingClusterer
from recon.fusion import FusionConfig, ObjectStore, align_offset
from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_texture import SeabedCells, TextureConfig, fit_textured


def rough_depth(ne: np.ndarray, rms: float, seed: int = 3) -> np.ndarray:
    """The simulator's texture model, written independently: 8 sinusoids, wavelengths 0.5-8 m, on a 3 deg slope."""
    rng = np.random.default_rng(seed)
    lam = np.exp(rng.uniform(np.log(0.5), np.log(8.0), 8))
    ang = rng.uniform(0, 2 * np.pi, 8)
    ph = rng.uniform(0, 2 * np.pi, 8)
    k = 2 * np.pi / lam
    arg = ne[:, :1] * (k * np.cos(ang)) + ne[:, 1:2] * (k * np.sin(ang)) + ph
    return 20.0 + np.tan(np.radians(3.0)) * ne[:, 0] + rms * np.sqrt(2 / 8) * np.sin(arg).sum(axis=1)


def box_points(rng: np.random.Generator, centre: tuple[float, float], size: tuple[float, float, float],
               ground: float, n: int = 400) -> np.ndarray:
    u = rng.uniform(-0.5, 0.5, (n, 3)) * np.array(size)
    u[:, 2] = -rng.uniform(0.2, 1.0, n) * size[2]  # upper part (the sonar sees the top and the near side)
    return np.column_stack([centre[0] + u[:, 0], centre[1] + u[:, 1], ground + u[:, 2]])


@pytest.mark.parametrize("rms", [0.0, 0.05, 0.10])
def test_textured_seabed_follows_the_texture_and_passes_under_objects(rms: float) -> None:
    rng = np.random.default_rng(7)
    ne = np.column_stack([rng.uniform(0, 30, 40_000), rng.uniform(0, 8, 40_000)])
    sea = np.column_stack([ne, rough_depth(ne, rms) + rng.normal(0, 0.01, ne.shape[0])])
    objs = [(10.0, 4.0, (1.2, 0.8, 0.6)), (20.0, 3.0, (1.0, 1.0, 0.5)), (5.0, 5.0, (3.0, 0.6, 0.3))]
    clouds = [box_points(rng, (n, e), s, float(rough_depth(np.array([[n, e]]), rms)[0])) for n, e, s in objs]
    cells = SeabedCells(0.5)
    cells.add(sea)
    for c in clouds:
        cells.add(c)
    coarse = SeabedModel.fit(sea[::20], SeabedConfig())
    model = fit_textured(cells, coarse, np.array([0.0, 0.0]), np.array([30.0, 8.0]), TextureConfig())
    thr = model.min_height(0.05)
    away = np.all([np.hypot(sea[:, 0] - n, sea[:, 1] - e) > 2.5 for n, e, _ in objs], axis=0)
    inner = away & (sea[:, 0] > 1) & (sea[:, 0] < 29) & (sea[:, 1] > 1) & (sea[:, 1] < 7)
    seabed_kept = float(np.mean(model.height_above(sea[inner]) >= thr))
    assert seabed_kept < 0.01, f"{seabed_kept:.3f} of the textured seabed kept as object points"
    tiles_kept = float(np.mean(coarse.height_above(sea[inner]) >= 0.05))  # the former fixed 5 cm threshold
    if rms >= 0.05:  # the 6 m tiles and a fixed threshold cannot follow the texture: the grid is what removes it
        assert tiles_kept > 5 * max(seabed_kept, 0.002)
    for c, (_, _, size) in zip(clouds, objs, strict=True):
        h = model.height_above(c)
        assert np.percentile(h, 95) > 0.7 * size[2]  # the object is not absorbed into the seabed
    assert model.sigma < 0.05 + 0.6 * rms


def test_align_offset_recovers_a_shift_between_views() -> None:
    rng = np.random.default_rng(1)
    a = box_points(rng, (0.0, 0.0), (1.0, 1.0, 0.8), 20.0, 3000)
    b = box_points(rng, (0.0, 0.0), (1.0, 1.0, 0.8), 20.0, 3000)
    b[:, :2] += [0.25, -0.15]
    shift = align_offset(a, b, FusionConfig())
    assert shift == pytest.approx([-0.25, 0.15], abs=0.07)
    far = b.copy()
    far[:, :2] += 5.0  # nothing pairs up: no shift rather than a wild one
    assert np.allclose(align_offset(a, far, FusionConfig()), 0.0)


def test_a_later_pass_is_fused_into_the_same_object() -> None:
    rng = np.random.default_rng(2)
    sc = StreamingClusterer(ClusterConfig(eps=0.5, min_cluster_points=25, quiet_s=1.0, margin=1.0))
    first = box_points(rng, (10.0, 0.0), (3.0, 0.6, 0.6), 20.0, 300)
    first = first[first[:, 0] < 10.4]  # pass 1 sees the southern part of a 3 m pipe
    sc.add(first, np.full(first.shape[0], 5.0))
    out1 = sc.poll(np.array([30.0, 0.0, 15.0]), 10.0)
    assert len(out1) == 1
    second = box_points(rng, (10.0, 0.0), (3.0, 0.6, 0.6), 20.0, 300)
    second = second[second[:, 0] > 10.7]  # pass 2, a minute later, its northern part (0.3 m apart)
    sc.add(second, np.full(second.shape[0], 65.0))
    out2 = sc.poll(np.array([-30.0, 0.0, 15.0]), 70.0)
    assert len(out2) == 1 and out2[0].id == out1[0].id
    assert out2[0].n_points == first.shape[0] + second.shape[0]
    assert len(out2[0].passes) == 2 and out2[0].extent[0] > 2.5
    assert sc.flush() == []


def test_objects_apart_stay_apart() -> None:
    store = ObjectStore(0.8)
    rng = np.random.default_rng(4)
    a = box_points(rng, (0.0, 0.0), (1.0, 1.0, 0.5), 20.0)
    store.add(0, a, np.zeros(a.shape[0]), np.zeros((a.shape[0], 0)))
    assert store.nearest(box_points(rng, (6.0, 0.0), (1.0, 1.0, 0.5), 20.0)) is None
    assert store.nearest(box_points(rng, (1.5, 0.0), (1.0, 1.0, 0.5), 20.0)) == 0
