"""Synthesis mode ``scan``: recon's highlight extension emulated from a mesh (classify.scan_synth)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import open3d as o3d
import pytest

from classify.errors import SynthesisError
from classify.scan_synth import N_BEAMS, scan_points, sonar_rays
from classify.synthesis import MeshSynthesizer, SynthesisSettings

H = 0.6  # box height
SETTINGS = SynthesisSettings(mode="scan", altitude_m=(4.5, 4.5), lateral_m=(0.0, 0.0), min_cos=(0.0, 0.0),
                             min_height_m=(0.15, 0.15), range_sigma_m=0.0, n_points=256)


def _box() -> MeshSynthesizer:
    m = o3d.geometry.TriangleMesh.create_box(1.2, 0.8, H)
    v = np.asarray(m.vertices) - [0.6, 0.4, H]  # NED: resting on z = 0, top at z = -H
    return MeshSynthesizer(v, np.asarray(m.triangles))


def test_sonar_rays_geometry() -> None:
    tilt, spread = math.radians(30.0), math.radians(14.0)
    d, steep = sonar_rays(math.radians(90.0), tilt, spread, 8)
    assert d.shape == (8, N_BEAMS, 3) and steep.shape == (N_BEAMS, 3)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
    centre = steep[N_BEAMS // 2 - 1: N_BEAMS // 2 + 1].mean(axis=0)  # between the two middle beams
    assert math.degrees(math.asin(centre[2] / np.linalg.norm(centre))) == pytest.approx(37.0, abs=0.01)
    assert centre[1] > 0.75 and abs(centre[0]) < 1e-9  # heading 90 deg: looking east
    # the shallowest ray of the centre is t - s/2 below the horizontal
    shallow = d[0, N_BEAMS // 2 - 1: N_BEAMS // 2 + 1].mean(axis=0)
    assert math.degrees(math.asin(shallow[2] / np.linalg.norm(shallow))) == pytest.approx(23.0, abs=0.01)


def test_box_front_slope_and_heights() -> None:
    synth = _box()
    pts = scan_points(synth.scene, synth.vertices, 0.0, math.radians(30.0), SETTINGS, np.random.default_rng(1))
    assert 100 < len(pts) < 5000
    height = -pts[:, 2]
    assert height.min() >= 0.15 and height.max() <= H + 0.01
    assert height.max() > H - 0.03  # the top edge itself is reached
    # the pass runs north (+x): the front face x = -0.6 is drawn as a slope ahead of it, rising towards it
    ahead = pts[:, 0] < -0.62
    assert ahead.sum() > 20
    assert pts[ahead, 0].min() > -0.6 - H / math.tan(math.radians(37.0)) - 0.05  # no further than delta(0)
    assert np.corrcoef(pts[ahead, 0], height[ahead])[0, 1] > 0.6  # 0.73 (off-axis beams lean)
    # nothing of the far side (hidden behind the box)
    assert pts[:, 0].max() < 0.62


def test_scan_is_seeded_and_threshold_thins() -> None:
    synth = _box()
    a = scan_points(synth.scene, synth.vertices, 0.3, math.radians(35.0), SETTINGS, np.random.default_rng(5))
    b = scan_points(synth.scene, synth.vertices, 0.3, math.radians(35.0), SETTINGS, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)
    strict = replace(SETTINGS, min_cos=(0.75, 0.75))
    c = scan_points(synth.scene, synth.vertices, 0.3, math.radians(35.0), strict, np.random.default_rng(5))
    assert 0 < len(c) < 0.8 * len(a)


def test_scan_view_is_a_training_cloud() -> None:
    synth = _box()
    cloud, noise = synth.view(math.radians(200.0), math.radians(25.0), replace(SETTINGS, noise_fraction=(0.1, 0.1)),
                              np.random.default_rng(2))
    assert cloud.shape == (256, 3) and cloud.dtype == np.float32 and np.isfinite(cloud).all()
    assert np.linalg.norm(cloud, axis=1).max() == pytest.approx(1.0, abs=1e-5)
    assert 0 < noise.sum() <= 26


def test_scan_without_highlight_raises() -> None:
    flat = o3d.geometry.TriangleMesh.create_box(1.0, 1.0, 0.05)
    synth = MeshSynthesizer(np.asarray(flat.vertices) - [0.5, 0.5, 0.05], np.asarray(flat.triangles))
    with pytest.raises(SynthesisError, match="no highlight"):
        synth.view(0.0, math.radians(30.0), SETTINGS, np.random.default_rng(0))


def test_arc_correction_raises_the_front_slope() -> None:
    from classify.scan_synth import arc_vectors

    tilt, spread = math.radians(30.0), math.radians(14.0)
    u, w = arc_vectors(0.4, tilt)
    _, steep = sonar_rays(0.4, tilt, spread, 8)
    h = spread / 2
    np.testing.assert_allclose(math.cos(h) * u + math.sin(h) * w, steep, atol=1e-12)  # the arc's top end
    synth = _box()
    raw = scan_points(synth.scene, synth.vertices, 0.0, tilt, SETTINGS, np.random.default_rng(1))
    fixed = scan_points(synth.scene, synth.vertices, 0.0, tilt, replace(SETTINGS, correction="arc"),
                        np.random.default_rng(1))
    assert fixed.shape == raw.shape
    assert np.all(-fixed[:, 2] >= -raw[:, 2] - 1e-9)  # never lowered
    low_raw, low_fixed = (-raw[:, 2] < H - 0.05).sum(), (-fixed[:, 2] < H - 0.05).sum()
    assert low_raw > 50 and low_fixed < 0.5 * low_raw  # the slope's points land on the top
    assert fixed[:, 0].min() > raw[:, 0].min() + 0.2  # and no longer reaches far ahead of the front face
