"""Training-cloud synthesis: determinism, culling, occlusion, front slope, noise, scaling."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import open3d as o3d
import pytest

from classify.errors import SynthesisError
from classify.training.dataset import heldout_settings, synthesize_set
from classify.training.synthesis import (
    MeshSynthesizer,
    SynthesisSettings,
    front_faces,
    normalize_unit_sphere,
    scan_direction,
    slope_offset,
)


def _box(lx: float = 1.2, ly: float = 0.8, h: float = 0.6) -> tuple[np.ndarray, np.ndarray]:
    m = o3d.geometry.TriangleMesh.create_box(lx, ly, h)
    v = np.asarray(m.vertices) - [lx / 2, ly / 2, h]  # footprint centred, z in [-h, 0]
    return v, np.asarray(m.triangles).astype(np.int32)


def _sphere(r: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    m = o3d.geometry.TriangleMesh.create_sphere(r, 20)
    return np.asarray(m.vertices) - [0, 0, r], np.asarray(m.triangles).astype(np.int32)


def _cylinder() -> tuple[np.ndarray, np.ndarray]:
    m = o3d.geometry.TriangleMesh.create_cylinder(0.3, 3.0, 20)
    v = np.asarray(m.vertices)[:, [2, 0, 1]] - [0, 0, 0.3]  # axis along x, lying on the seabed
    return v, np.asarray(m.triangles).astype(np.int32)


MESHES: dict[str, Callable[[], tuple[np.ndarray, np.ndarray]]] = {"box": _box, "sphere": _sphere, "pipe": _cylinder}
FAST = SynthesisSettings(headings_deg=(0.0, 90.0), tilts_deg=(30.0,), candidates=1500, n_points=256)


def test_scan_direction_points_down_in_ned() -> None:
    v = scan_direction(0.0, math.radians(30), math.radians(14))
    assert v[0] == pytest.approx(1.0) and v[1] == pytest.approx(0.0, abs=1e-12)
    assert v[2] == pytest.approx(math.tan(math.radians(37)))


def test_culling_keeps_top_and_front_faces_only() -> None:
    v, t = _box()
    keep = front_faces(v, t, scan_direction(0.0, math.radians(30), math.radians(14)))
    normals = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    kept = {tuple(np.round(n).astype(int)) for n in normals[keep]}
    assert kept == {(0, 0, -1), (-1, 0, 0)}  # top (up is -z) and the face towards the sonar


def test_box_seen_from_one_side_has_no_far_side_points() -> None:
    v, t = _box()
    settings = SynthesisSettings(front_slope=False, candidates=3000)
    pts = MeshSynthesizer(v, t).visible_points(0.0, math.radians(30), settings, np.random.default_rng(0))
    assert len(pts) == 3000
    assert not np.any(np.isclose(pts[:, 0], 0.6) & (pts[:, 2] > -0.59))  # far (x = +0.6) face
    assert not np.any(np.isclose(np.abs(pts[:, 1]), 0.4) & (pts[:, 2] > -0.59))  # side faces
    assert not np.any(pts[:, 2] > -1e-9)  # bottom
    front = np.isclose(pts[:, 0], -0.6)
    assert front.sum() > 0.2 * len(pts)


def test_occluded_surface_removed() -> None:
    """A small box hidden behind a tall wall (along the scan) gets no points."""
    wall_v, wall_t = _box(0.1, 2.0, 2.0)
    small_v, small_t = _box(0.3, 0.3, 0.3)
    small_v = small_v + [1.0, 0, 0]
    v = np.vstack([wall_v, small_v])
    t = np.vstack([wall_t, small_t + len(wall_v)])
    settings = SynthesisSettings(front_slope=False, candidates=4000)
    pts = MeshSynthesizer(v, t).visible_points(0.0, math.radians(20), settings, np.random.default_rng(1))
    assert len(pts) > 0
    assert not np.any(pts[:, 0] > 0.5)


def test_front_slope_shears_the_front_face() -> None:
    v, t = _box()
    settings = SynthesisSettings(altitude_m=(5.0, 5.0), candidates=3000)
    pts = MeshSynthesizer(v, t).visible_points(0.0, math.radians(30), settings, np.random.default_rng(0))
    e = math.radians(37)
    delta0 = float(slope_offset(np.array([0.0]), np.array([0.6]), 5.0, e)[0])
    assert delta0 == pytest.approx(math.sqrt(25 / math.sin(e) ** 2 - 4.4**2) - 5 / math.tan(e))
    assert 0.3 < delta0 < 0.6 * math.tan(e) + 1e-9
    assert pts[:, 0].min() == pytest.approx(-0.6 - delta0, abs=0.02)
    top = np.isclose(pts[:, 2], -0.6, rtol=0, atol=1e-9)
    assert top.sum() > 1000
    assert np.all(pts[top, 0] >= -0.6 - 1e-6)  # the top is not moved
    low = pts[:, 2] > -0.05
    assert np.all(pts[low, 0] < -0.6 - 0.8 * delta0)


def test_same_seed_same_points_other_seed_other_points() -> None:
    v, t = _sphere()
    s = MeshSynthesizer(v, t)
    a, na = s.view(0.3, 0.5, FAST, np.random.default_rng(7))
    b, nb = s.view(0.3, 0.5, FAST, np.random.default_rng(7))
    c, _ = s.view(0.3, 0.5, FAST, np.random.default_rng(8))
    assert a.tobytes() == b.tobytes() and np.array_equal(na, nb)
    assert not np.array_equal(a, c)


def test_unit_sphere_scaling() -> None:
    v, t = _cylinder()
    cloud, _ = MeshSynthesizer(v, t).view(0.0, 0.5, FAST, np.random.default_rng(0))
    assert cloud.shape == (256, 3) and cloud.dtype == np.float32
    assert np.abs(cloud.mean(axis=0)).max() < 1e-5
    assert np.linalg.norm(cloud, axis=1).max() == pytest.approx(1.0, abs=1e-5)
    p = normalize_unit_sphere(np.array([[1.0, 2.0, 3.0], [3.0, 2.0, 1.0]]))
    assert np.allclose(np.linalg.norm(p, axis=1), 1.0)


@pytest.mark.parametrize("frac", [(0.0, 0.0), (0.05, 0.05), (0.15, 0.15), (0.3, 0.3)])
def test_noise_fraction_respected(frac: tuple[float, float]) -> None:
    v, t = _box()
    settings = SynthesisSettings(noise_fraction=frac, n_points=1000, candidates=1500)
    _, noise = MeshSynthesizer(v, t).view(1.0, 0.5, settings, np.random.default_rng(0))
    assert noise.sum() == round(frac[0] * 1000)


def test_noise_fraction_drawn_in_range() -> None:
    v, t = _box()
    settings = SynthesisSettings(n_points=1000, candidates=1500)
    s = MeshSynthesizer(v, t)
    rng = np.random.default_rng(3)
    counts = [s.view(0.0, 0.5, settings, rng)[1].sum() for _ in range(12)]
    assert all(50 <= c <= 150 for c in counts)
    assert len(set(counts)) > 3


def test_set_is_cached_and_reproducible(tmp_path: Path) -> None:
    names = tuple(MESHES)

    def mesh_for(name: str) -> tuple[np.ndarray, np.ndarray]:
        return MESHES[name]()

    a = synthesize_set(names, mesh_for, FAST, tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 3
    b = synthesize_set(names, mesh_for, FAST, tmp_path)
    c = synthesize_set(names, mesh_for, FAST, None)
    assert a.points.shape == (6, 256, 3)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.points, c.points)
    assert list(a.labels) == [0, 0, 1, 1, 2, 2]
    held = heldout_settings(FAST)
    assert set(held.headings_deg).isdisjoint(FAST.headings_deg)
    assert set(held.tilts_deg).isdisjoint(FAST.tilts_deg) and held.seed != FAST.seed


def test_bad_mesh_rejected() -> None:
    with pytest.raises(SynthesisError):
        MeshSynthesizer(np.zeros((3, 2)), np.zeros((1, 3), int))


def test_incidence_options_weight_and_drop_grazing_faces() -> None:
    v, t = _box()
    s = MeshSynthesizer(v, t)
    base = SynthesisSettings(front_slope=False, candidates=4000)
    # e = 37 deg: cos(a) is 0.80 on the front face and 0.60 on the top
    only_front = s.visible_points(0.0, math.radians(30), replace(base, min_incidence_cos=0.7), np.random.default_rng(0))
    assert np.allclose(only_front[:, 0], -0.6)
    uniform = s.visible_points(0.0, math.radians(30), base, np.random.default_rng(0))
    weighted = s.visible_points(0.0, math.radians(30), replace(base, incidence_power=4.0), np.random.default_rng(0))
    share = [np.isclose(p[:, 0], -0.6).mean() for p in (uniform, weighted)]
    assert share[1] > share[0] + 0.1


def test_slope_only_and_seabed_cut() -> None:
    v, t = _box()
    s = MeshSynthesizer(v, t)
    base = SynthesisSettings(candidates=3000, altitude_m=(5.0, 5.0))
    slope = s.visible_points(0.0, math.radians(30), replace(base, slope_only=True), np.random.default_rng(0))
    assert len(slope) > 100 and np.all(slope[:, 0] < -0.6)  # only the sheared front face
    cut = s.visible_points(0.0, math.radians(30), replace(base, seabed_cut_m=(0.2, 0.2)), np.random.default_rng(0))
    assert cut[:, 2].max() <= -0.2
