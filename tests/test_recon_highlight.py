"""Highlight extraction on images built from known geometry; points checked against an independent
reference of the geometry (``tests/geometry_reference.py``, written from docs ARCHITECTURE.md)."""

from __future__ import annotations

import numpy as np
import pytest
from geometry_reference import beam_azimuth, highlight_point, row_range
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from recon.errors import GeometryError
from recon.frames import attitude
from recon.highlight import HighlightConfig, extract, first_returns, frame_thresholds, run_span_bins
from recon.sonar_geometry import SonarGeometry
from recon.synthetic import Box, Scene, render, surface_distance

D = np.deg2rad
G = SonarGeometry()


def _frame(rng: np.random.Generator, pos: np.ndarray, rot: Rotation, alt: float,
           blobs: list[tuple[int, float]], gain: float = 1.0) -> np.ndarray:
    """Speckle + a seabed band from the analytic onset + bright blobs (beam, range)."""
    img = rng.integers(0, 14, size=(512, 96)).astype(float)
    on = G.flat_onset_ranges(pos, rot, [alt])[0]
    start = np.ceil(G.range_to_row(on)).astype(int)
    rows = np.arange(512)[:, None]
    img = np.where(rows >= start[None], rng.uniform(80, 140, img.shape), img)
    for beam, r in blobs:
        m = int(np.floor(G.range_to_row(r) + 0.5))
        img[m : m + 4, beam] = 220
    return np.clip(img * gain, 0, 255).astype(np.uint8)


def test_blob_closer_than_onset_gives_point_at_known_location() -> None:
    rng = np.random.default_rng(1)
    pos = np.array([[120.0, -40.0, 14.0]])
    rot = attitude(D([-150.0]), D([3.0]), D([-2.0]))
    blobs = [(10, 6.0), (47, 7.2), (48, 7.25), (90, 5.5)]
    img = _frame(rng, pos, rot, 5.0, blobs)
    on = G.flat_onset_ranges(pos, rot, [5.0])
    hp = extract(img, pos, rot, on, G)
    assert sorted(hp.beam.tolist()) == [10, 47, 48, 90]
    for beam, r in blobs:
        k = int(np.flatnonzero(hp.beam == beam)[0])
        r_m = row_range(int(hp.row[k]), 1.0, 10.0, 512)
        assert abs(r_m - r) <= 0.5 * 10.0 / 512 + 1e-9  # the blob's first row
        truth = highlight_point(r_m, beam_azimuth(beam, D(29.0), 96), tilt=G.tilt, spread=G.spread,
                                position=pos[0], ypr=(D(-150.0), D(3.0), D(-2.0)), lever=np.zeros(3))
        assert np.linalg.norm(hp.points[k] - truth) < 1e-9


def test_seabed_only_gives_no_points_and_skip_equals_full_search() -> None:
    rng = np.random.default_rng(2)
    n = 40
    pos = np.column_stack([np.arange(n) * 0.1, np.zeros(n), np.full(n, 15.0)])
    rot = attitude(np.zeros(n), np.zeros(n), np.zeros(n))
    imgs = np.stack([_frame(rng, pos[i : i + 1], rot[i : i + 1], 5.0, [(30 + i, 6.5)] if i % 4 == 0 else [])
                     for i in range(n)])
    on = G.flat_onset_ranges(pos, rot, np.full(n, 5.0))
    a = extract(imgs, pos, rot, on, G, HighlightConfig(skip=True))
    b = extract(imgs, pos, rot, on, G, HighlightConfig(skip=False))
    assert sorted(np.unique(a.frame).tolist()) == list(range(0, n, 4))
    assert np.array_equal(a.frame, b.frame) and np.array_equal(a.beam, b.beam)
    assert np.allclose(a.points, b.points)
    single = [extract(imgs[i], pos[i : i + 1], rot[i : i + 1], on[i : i + 1], G) for i in range(n)]
    assert sum(len(s) for s in single) == len(a)


def test_gain_and_speckle_robust() -> None:
    rng = np.random.default_rng(3)
    pos, rot = np.array([[0.0, 0.0, 15.0]]), attitude(0.0, 0.0, 0.0)
    on = G.flat_onset_ranges(pos, rot, [5.0])
    for gain in (0.45, 1.0, 1.1):
        img = _frame(rng, pos, rot, 5.0, [(20, 6.0)], gain=gain)
        img[100, 5] = img[250, 60] = img[311, 70] = 255  # isolated speckle pixels
        hp = extract(img, pos, rot, on, G)
        assert hp.beam.tolist() == [20]
    # a threshold from robust statistics follows the gain
    img = _frame(rng, pos, rot, 5.0, [])
    t1 = frame_thresholds(img[None], 300, HighlightConfig())[0]
    t2 = frame_thresholds((img // 2)[None], 300, HighlightConfig())[0]
    assert 0.35 < t2 / t1 < 0.65


def test_box_top_reconstructed_on_its_surface() -> None:
    scene = Scene(boxes=(Box((8.0, 0.3, 19.6), (1.2, 0.8, 0.8), D(20)),), noise_level=10)
    rng = np.random.default_rng(4)
    rot = attitude(0.0, 0.0, 0.0)
    dists = []
    for x in np.arange(0.0, 4.0, 0.1):
        pos = np.array([[x, 0.0, 15.0]])
        img, _ = render(G, pos[0], rot, scene, rng)
        hp = extract(img, pos, rot, G.flat_onset_ranges(pos, rot, [5.0]), G)
        top = np.abs(hp.points[:, 2] - 19.2) < 0.02  # points on the top face (steepest ray hits it)
        dists.append(surface_distance(hp.points[top], scene))
    d = np.concatenate(dists)
    assert d.size > 100
    assert d.max() < 0.012  # half a range bin + the discretized fan of the renderer


def test_rejects_bad_frames_and_attitudes() -> None:
    pos, img = np.zeros((1, 3)), np.zeros((512, 96), np.uint8)
    on = np.full((1, 96), 8.0)
    with pytest.raises(GeometryError, match="pitch"):
        extract(img, pos, attitude([0.0], [D(89.5)], [0.0]), on, G)
    with pytest.raises(GeometryError):
        extract(np.zeros((96, 512), np.uint8), pos, attitude([0.0], [0.0], [0.0]), on, G)


@settings(max_examples=40, deadline=None)
@given(st.floats(0, 60), st.floats(-180, 180), st.floats(-25, 25), st.floats(-25, 25), st.floats(0.5, 12),
       st.sampled_from(["exact", "paper"]), st.sampled_from(["float64", "float32"]))
def test_no_nan_for_any_pose(tilt: float, yaw: float, pitch: float, roll: float, alt: float, mode: str,
                             dtype: str) -> None:
    g = SonarGeometry.from_degrees(tilt, 14)
    rng = np.random.default_rng(5)
    img = rng.integers(0, 255, size=(512, 96)).astype(np.uint8)
    pos = np.array([[3e5, -7e5, 40.0]])
    rot = attitude(D([yaw]), D([pitch]), D([roll]))
    on = g.flat_onset_ranges(pos, rot, [alt])
    assert not np.any(np.isnan(on))
    hp = extract(img, pos, rot, on, g, HighlightConfig(geometry=mode, dtype=dtype, min_run=1))  # type: ignore[arg-type]
    assert np.all(np.isfinite(hp.points))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 5), st.integers(1, 40), st.integers(1, 12), st.integers(1, 3),
       st.sampled_from(["random", "wide", "edges"]), st.integers(0, 9))
def test_skip_search_equals_full_search(seed: int, n_frames: int, n_bins: int, n_beams: int, run: int,
                                        limit_kind: str, span: int) -> None:
    """The per-column skip finds exactly the returns of the full search, for any limits, run and span."""
    rng = np.random.default_rng(seed)
    imgs = rng.integers(0, 256, (n_frames, n_bins, n_beams)).astype(np.uint8)
    imgs[rng.random(imgs.shape) < 0.7] //= 4  # mostly dim, some bright runs
    if limit_kind == "random":
        limits = rng.integers(0, n_bins + 1, (n_frames, n_beams))
    elif limit_kind == "wide":
        limits = rng.integers(n_bins // 2, n_bins + 1, (n_frames, n_beams))
    else:
        limits = rng.choice([0, 1, n_bins - 1, n_bins], (n_frames, n_beams))
    thr = rng.uniform(20, 120, n_frames)
    before = imgs.copy()
    a = first_returns(imgs, limits.astype(np.int64), thr, HighlightConfig(skip=True, min_run=run), span or None)
    b = first_returns(imgs, limits.astype(np.int64), thr, HighlightConfig(skip=False, min_run=run), span or None)
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert np.array_equal(imgs, before)  # the caller's frames are never written


@settings(max_examples=60, deadline=None)
@given(tilt=st.floats(0, 50), spread=st.floats(6, 20), ypr=st.tuples(st.floats(-180, 180), st.floats(-25, 25),
       st.floats(-25, 25)), mount=st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-10, 10)),
       lever=st.tuples(st.floats(-2, 2), st.floats(-1, 1), st.floats(-1, 1)),
       north_east=st.tuples(st.floats(-5e4, 5e4), st.floats(-5e4, 5e4)), depth=st.floats(0, 500),
       beam=st.integers(0, 95), row=st.integers(0, 500), mode=st.sampled_from(["exact", "paper"]))
def test_extracted_point_matches_independent_geometry(
        tilt: float, spread: float, ypr: tuple[float, float, float], mount: tuple[float, float, float],
        lever: tuple[float, float, float], north_east: tuple[float, float], depth: float, beam: int, row: int,
        mode: str) -> None:
    """One bright return at (row, beam) of a dark frame: extract() puts it where the reference says."""
    g = SonarGeometry.from_degrees(tilt, spread, lever_arm=lever, mount_rpy=tuple(D(mount)))
    img = np.full((512, 96), 5, np.uint8)
    img[row : row + 4, beam] = 220
    pos = np.array([[north_east[0], north_east[1], depth]])
    yaw, pitch, roll = D(ypr)
    rot = attitude([yaw], [pitch], [roll])  # the product's R_WB; the reference builds its own
    hp = extract(img, pos, rot, np.full((1, 96), np.inf), g, HighlightConfig(geometry=mode))  # type: ignore[arg-type]
    assert hp.beam.tolist() == [beam] and hp.row.tolist() == [row]
    r, theta = row_range(row, 1.0, 10.0, 512), beam_azimuth(beam, D(29.0), 96)
    if mode == "exact":
        truth = highlight_point(r, theta, tilt=D(tilt), spread=D(spread), position=pos[0], ypr=(yaw, pitch, roll),
                                lever=np.array(lever), mount_rpy=tuple(D(mount)))
    else:  # the paper's ray is defined in B itself (elevation t + s/2 below the body's horizontal)
        e = D(tilt) + D(spread) / 2
        p_b = np.array(lever) + r * np.array([np.cos(e) * np.cos(theta), np.cos(e) * np.sin(theta), np.sin(e)])
        truth = highlight_point(0.0, 0.0, tilt=0.0, spread=0.0, position=pos[0], ypr=(yaw, pitch, roll), lever=p_b)
    assert np.abs(hp.points[0] - truth).max() < 1e-6, (hp.points[0], truth)


def test_a_comb_of_returns_is_one_return_and_a_lone_pixel_is_none() -> None:
    """A level top seen by a fan of discrete rays returns single bright bins a few bins apart: with the span
    rule its first tooth is the return; consecutive bins (no span) miss it; one bright pixel alone is speckle."""
    img = np.full((1, 512, 96), 40, np.uint8)
    img[0, 200:240:4, 10] = 180  # a comb: every 4th bin (0.08 m at 0.02 m bins)
    img[0, 150, 20] = 200  # a lone pixel
    limits = np.full((1, 96), 300, np.int64)
    thr = np.array([100.0])
    cfg = HighlightConfig()
    span = run_span_bins(cfg, 0.02)  # 0.25 m in 0.02 m bins: 12
    _, bi, ri = first_returns(img, limits, thr, cfg, span)
    assert bi.tolist() == [10] and ri.tolist() == [200]
    assert first_returns(img, limits, thr, cfg)[0].size == 0  # consecutive bins only
    assert first_returns(img, np.full((1, 96), 200, np.int64), thr, cfg, span)[0].size == 0  # past the onset
