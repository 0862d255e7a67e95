"""Synthesis mode ``scan``: recon's highlight extension emulated from a mesh (classify.training.scan_synth)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import open3d as o3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from classify.errors import SynthesisError
from classify.training.scan_synth import N_BEAMS, scan_points, sonar_rays
from classify.training.synthesis import MeshSynthesizer, SynthesisSettings
from classify.training.views import scan_view

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
    from classify.training.scan_synth import arc_vectors

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


def test_energy_first_return_sums_rays_per_bin() -> None:
    from classify.training.scan_synth import energy_first_return

    bin_m = 0.02
    # one position, one beam, 4 rays: two strike a face at 5.00-5.01 m (one bin), one grazes a top at 4.50 m
    t = np.array([[[4.50], [5.005], [5.015], [np.inf]]])
    cos = np.array([[[0.2], [1.0], [1.0], [0.0]]])
    hit = np.isfinite(t)
    # min_run 1: the grazing hit alone (0.2^2 (6/4.5)^2 / 4 = 0.018) passes a low threshold only
    low = energy_first_return(t, cos, hit, 0.01, bin_m, 1, r0=6.0)
    assert low[0, 0] == pytest.approx(4.51, abs=1e-9)  # bin 225, its centre
    high = energy_first_return(t, cos, hit, 0.05, bin_m, 1, r0=6.0)
    assert high[0, 0] == pytest.approx(5.01, abs=1e-9)  # the face: 2 x (6/5)^2 / 4 = 0.72 in bin 250
    # min_run 2: the face's bin is followed by an empty one -> nothing passes
    assert np.isinf(energy_first_return(t, cos, hit, 0.05, bin_m, 2, r0=6.0)[0, 0])
    none = energy_first_return(t, cos, np.zeros_like(hit), 0.0, bin_m, 1)
    assert np.isinf(none).all()


def test_energy_detection_lowers_rounded_tops_more_at_low_tilt() -> None:
    """A sphere's grazing top is too weak alone: its highlight lid sits lower, more so at a low tilt
    (what recon makes of rendered frames)."""
    sphere = o3d.geometry.TriangleMesh.create_sphere(0.5, resolution=24)
    synth = MeshSynthesizer(np.asarray(sphere.vertices) - [0.0, 0.0, 0.5], np.asarray(sphere.triangles))
    s = replace(SETTINGS, detect="energy", energy_threshold=(0.004, 0.004), correction="arc",
                min_height_m=(0.05, 0.05), altitude_m=(4.5, 4.5), rays_per_beam=16)
    h = {}
    for tilt in (22.0, 40.0):
        pts = scan_points(synth.scene, synth.vertices, 0.0, math.radians(tilt), s, np.random.default_rng(3))
        h[tilt] = float(np.percentile(-pts[:, 2], 95))
    assert h[22.0] < h[40.0] - 0.05 and 0.6 < h[22.0] < 0.95 and h[40.0] <= 1.01
    box = scan_points(_box().scene, _box().vertices, 0.0, math.radians(30.0), s, np.random.default_rng(3))
    assert 0.35 < float(np.percentile(-box[:, 2], 95)) <= H + 0.01  # 0.44: recon's lids of the box, 0.43-0.53


def test_fused_and_partial_views() -> None:
    """A fused view is the union of 2-3 passes (an adjacent line looks from the other side: the far side shows),
    shifted by the misalignment drawn; a partial pass sees less of a long object than a whole one."""
    synth = _box()
    tilt = math.radians(30.0)
    fused = replace(SETTINGS, fused_prob=1.0, fused_passes=(2.0, 2.0), misalign_m=(0.0, 0.0))
    far_side = 0
    for seed in range(8):
        single = scan_view(synth.scene, synth.vertices, 0.0, tilt, SETTINGS, np.random.default_rng(seed))
        both = scan_view(synth.scene, synth.vertices, 0.0, tilt, fused, np.random.default_rng(seed))
        assert len(both) > len(single) and single[:, 0].max() < 0.62
        far_side += both[:, 0].max() > 0.62  # the north face, seen from a pass heading south
    assert far_side >= 3  # 7 in 10 later passes fly the adjacent line back (measured 7 of 8)
    shifted = scan_view(synth.scene, synth.vertices, 0.0, tilt, replace(fused, misalign_m=(2.0, 2.0)),
                        np.random.default_rng(0))
    assert np.ptp(shifted[:, :2], axis=0).max() > 2.5  # two box views 2 m apart
    m = o3d.geometry.TriangleMesh.create_box(3.0, 0.6, 0.6)  # a pipe-like 3 m bar along north
    bar = MeshSynthesizer(np.asarray(m.vertices) - [1.5, 0.3, 0.6], np.asarray(m.triangles))
    whole, part = [], []
    for seed in range(8):
        whole.append(np.ptp(scan_view(bar.scene, bar.vertices, math.pi / 2, tilt, SETTINGS,
                                      np.random.default_rng(seed))[:, 0]))
        p = scan_view(bar.scene, bar.vertices, math.pi / 2, tilt, replace(SETTINGS, partial_prob=1.0),
                      np.random.default_rng(seed))
        part.append(np.ptp(p[:, 0]) if len(p) else 0.0)
    # measured: whole views 2.98-3.00 m along the bar, partial ones 1.0-3.0 m (median 2.1)
    assert np.median(whole) > 2.8 and np.median(part) < 0.8 * np.median(whole), (whole, part)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 3), st.integers(0, 8))
def test_energy_first_return_span_rule_dense_equals_sparse(seed: int, run: int, span: int) -> None:
    """``min_run`` bins within ``span``: a comb of single-ray bins passes once the span holds two teeth, and the
    sparse search (long ranges) finds exactly what the dense one does."""
    from classify.training import scan_synth

    rng = np.random.default_rng(seed)
    t = rng.uniform(4.0, 4.4, (3, 6, 5))
    t[rng.random(t.shape) < 0.3] = np.inf
    cos = rng.uniform(0.0, 1.0, t.shape)
    hit = np.isfinite(t)
    dense = scan_synth.energy_first_return(t, cos, hit, 0.02, 0.02, run, span=span)
    old = scan_synth.DENSE_MAX
    try:
        scan_synth.DENSE_MAX = 0
        sparse = scan_synth.energy_first_return(t, cos, hit, 0.02, 0.02, run, span=span)
    finally:
        scan_synth.DENSE_MAX = old
    assert np.array_equal(dense, sparse)


def test_energy_first_return_finds_a_comb_within_the_span() -> None:
    from classify.training.scan_synth import energy_first_return

    # one beam, three rays striking a level top 4 bins apart (a comb): no two bins in a row
    t = np.array([[[4.005], [4.085], [4.165]]])
    cos = np.ones_like(t)
    hit = np.isfinite(t)
    assert np.isinf(energy_first_return(t, cos, hit, 0.1, 0.02, 2)[0, 0])  # consecutive bins: nothing
    assert energy_first_return(t, cos, hit, 0.1, 0.02, 2, span=5)[0, 0] == pytest.approx(4.01)  # the first tooth
    assert np.isinf(energy_first_return(t[:, :1], cos[:, :1], hit[:, :1], 0.1, 0.02, 2, span=5)[0, 0])  # alone
