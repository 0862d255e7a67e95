"""Numerical stability of the front-slope correction and the whole reconstruction far from the origin."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from recon.errors import GeometryError
from recon.frames import attitude
from recon.front_slope import arc_columns, replace_on_arcs, steepest_points
from recon.highlight import project
from recon.reconstructor import Reconstructor
from recon.sonar_geometry import SonarGeometry
from recon.synthetic import Box, Scene, Sphere, render
from recon.trajectory import Trajectory

D = np.deg2rad


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 60), st.floats(-180, 180), st.floats(-20, 20), st.floats(-20, 20),
       st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.floats(0.5, 4.0))
def test_arc_correction_finite_and_translation_invariant(tilt: float, yaw: float, pitch: float, roll: float,
                                                         north: float, east: float, top: float) -> None:
    g = SonarGeometry.from_degrees(tilt, 14, lever_arm=(0.6, 0.0, 0.2))
    rot = attitude(D([yaw]), D([pitch]), D([roll]))
    rng = np.random.default_rng(1)
    n = 200
    beam, row = rng.integers(0, 96, n), rng.integers(0, 512, n)
    frame = np.zeros(n, np.int64)
    out = {}
    for off in ((0.0, 0.0), (north, east)):
        pos = np.array([[off[0], off[1], 30.0]])
        arcs = arc_columns(g, frame, beam, row, pos, rot)
        p = steepest_points(arcs, g.spread)
        assert np.allclose(p, project(g, frame, beam, row, pos, rot, "exact"), atol=1e-6)
        p[: n // 4, 2] -= top  # a "top" above some of the points
        q = replace_on_arcs(p, arcs, g.spread, length=50.0, width=50.0)
        assert np.all(np.isfinite(q))
        # stays on its arc: same range from the sonar origin
        moved = np.any(q != p, axis=1)
        assert np.allclose(np.linalg.norm(q[moved] - arcs[moved, :3], axis=1), arcs[moved, 9], atol=1e-6)
        out[off] = q - [off[0], off[1], 0.0]
    assert np.abs(out[(0.0, 0.0)] - out[(north, east)]).max() < 1e-3


def _run(offset: tuple[float, float], heading: float) -> list:
    g = SonarGeometry.from_degrees(30, 14, lever_arm=(0.8, 0.0, 0.2))
    c, s = np.cos(heading), np.sin(heading)
    o = np.asarray(offset)
    sc = Scene(seabed_point=(o[0], o[1], 20.0), spheres=(Sphere((*(o + [9 * c, 9 * s]), 19.5), 0.5),),
               boxes=(Box((*(o + [17 * c - 0.3 * s, 17 * s + 0.3 * c]), 19.7), (1.2, 0.8, 0.6), heading),))
    t = np.arange(0.0, 20.0, 0.1)
    pos = np.column_stack([o[0] + t * c, o[1] + t * s, np.full(t.size, 15.0)])
    z = np.zeros(t.size)
    traj = Trajectory.from_euler(t, pos, np.full(t.size, heading), z, z, altitude=np.full(t.size, 5.0))
    rng = np.random.default_rng(3)
    imgs = np.stack([render(g, pos[i], traj.rotations[i], sc, rng)[0] for i in range(t.size)])
    rc = Reconstructor(g, traj)
    rc.add_frames(t, imgs)
    return rc.finish()


@pytest.mark.slow
@pytest.mark.parametrize("heading", [D(179.9), D(-179.9), D(63.0)])
def test_reconstruction_far_from_origin_matches_near(heading: float) -> None:
    # offsets are multiples of the 6 m seabed tile, whose grid is anchored at the world origin
    near, far = _run((0.0, 0.0), heading), _run((600_000.0, -999_996.0), heading)
    assert len(near) == len(far) == 2
    for a, b in zip(near, far, strict=True):
        assert a.n_points == b.n_points
        assert np.abs(b.points - [600_000.0, -999_996.0, 0.0] - a.points).max() < 1e-3


@pytest.mark.parametrize("pitch", [88.0, 89.999, -89.999, 90.0, -90.0])
def test_gimbal_lock_rejected_by_reconstructor(pitch: float) -> None:
    g = SonarGeometry.from_degrees(30, 14)
    t = np.array([0.0, 1.0])
    traj = Trajectory.from_euler(t, np.zeros((2, 3)), [0.0, 0.0], [D(pitch), D(pitch)], [0.0, 0.0],
                                 altitude=[5.0, 5.0])
    with pytest.raises(GeometryError, match="pitch"):
        Reconstructor(g, traj).add_frame(0.5, np.zeros((512, 96), np.uint8))


@settings(max_examples=60, deadline=None)
@given(st.floats(-14.5, 14.5), st.floats(0, 60), st.floats(-180, 180), st.floats(-30, 30), st.floats(-30, 30),
       st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.integers(0, 511))
def test_any_azimuth_in_the_fan(az: float, tilt: float, yaw: float, pitch: float, roll: float, north: float,
                                east: float, row: int) -> None:
    """A beam at any azimuth of the fan: its highlight point 1e6 m out is the near-origin one within 1 mm,
    and (level) the exact highlight ray at the seabed onset range lies on the seabed."""
    g = SonarGeometry.from_degrees(tilt, 14, n_beams=1, azimuth_table=(D(az),), lever_arm=(0.6, -0.1, 0.2))
    rot = attitude(D([yaw]), D([pitch]), D([roll]))
    one = np.zeros(1, np.int64)
    far = project(g, one, one, np.array([row]), np.array([[north, east, 20.0]]), rot)
    near = project(g, one, one, np.array([row]), np.array([[0.0, 0.0, 20.0]]), rot)
    assert np.all(np.isfinite(far)) and np.abs(far - [north, east, 0.0] - near).max() < 1e-3
    level = attitude(D([yaw]), [0.0], [0.0])
    pos = np.array([[north, east, 20.0]])
    r = g.flat_onset_ranges(pos, level, [5.0])[0, 0]
    p = pos[0] + level[0].apply(g.mounting.lever) + r * level[0].apply(g.highlight_directions("exact")[0])
    assert abs(p[2] - 25.0) < 1e-9


def _top_brute(p: np.ndarray, arcs: np.ndarray, length: float, width: float) -> np.ndarray:
    """The arc correction's per-point top from every pair of points (O(n^2), small clouds only)."""
    look = arcs[:, 3:5] / np.linalg.norm(arcs[:, 3:5], axis=1, keepdims=True)
    d = p[None, :, :2] - p[:, None, :2]  # [i, j] = p_j - p_i
    along = np.einsum("ijk,ik->ij", d, look)
    across = np.abs(d[..., 0] * look[:, None, 1] - d[..., 1] * look[:, None, 0])
    near = np.hypot(d[..., 0], d[..., 1]) <= np.hypot(length, width)
    ok = (along >= 0) & (along <= length) & (across <= width) & near
    return np.asarray(np.where(ok, p[None, :, 2], np.inf).min(axis=1), dtype=np.float64)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 700), st.sampled_from([1, 7, 128, 4096]))
def test_arc_correction_chunked_pairs_same_answer(seed: int, n: int, chunk: int) -> None:
    g = SonarGeometry.from_degrees(30, 14)
    rng = np.random.default_rng(seed)
    rot = attitude(D(rng.uniform(-180, 180, 4)), np.zeros(4), np.zeros(4))
    pos = np.column_stack([rng.uniform(-3, 3, (4, 2)), np.full(4, 15.0)])
    frame, beam, row = rng.integers(0, 4, n), rng.integers(0, 96, n), rng.integers(150, 400, n)
    arcs = arc_columns(g, frame, beam, row, pos, rot)
    p = steepest_points(arcs, g.spread)
    p[: n // 3, 2] -= rng.uniform(0, 1, n // 3)
    p[n // 2 :: 5] = p[n // 2 - 1]  # duplicated points (zero distance pairs)
    a = replace_on_arcs(p, arcs, g.spread, chunk=chunk)
    b = replace_on_arcs(p, arcs, g.spread, chunk=n)
    assert np.array_equal(a, b)
    top = _top_brute(p, arcs, 1.0, 0.25)
    moved = np.any(a != p, axis=1)
    assert np.array_equal(moved, top < p[:, 2])  # moved exactly where a higher point lies behind it
