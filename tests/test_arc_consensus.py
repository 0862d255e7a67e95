"""Elevation from the sonar's motion (recon.arc_consensus): arcs of successive frames meet at a fixed reflector."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from recon.arc_consensus import consensus_elevations, consensus_points
from recon.range_arcs import arc_elevations, arc_record, points_at

SPREAD = math.radians(14.0)  # the DIDSON's vertical spread (data sheet)


def fan(tilt_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The look direction at elevation 0 and the fan's down axis (NED) of a sonar pitched down by ``tilt_deg``,
    looking north."""
    t = math.radians(tilt_deg)
    return np.array([math.cos(t), 0.0, math.sin(t)]), np.array([-math.sin(t), 0.0, math.cos(t)])


def passes_over(target: np.ndarray, xs: np.ndarray, tilt_deg: float, edge_deg: float) -> tuple[np.ndarray, ...]:
    """The returns of a fixed reflector ``target`` seen from sonar positions ``(x, 0, 0)``, one per frame, placed on
    the ray ``edge_deg`` below the axis: points (N, 3), arcs (N, 10), times (N,)."""
    u, w = fan(tilt_deg)
    o = np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)])
    r = np.linalg.norm(target - o, axis=1)
    arcs = arc_record(o, np.tile(u, (xs.size, 1)), np.tile(w, (xs.size, 1)), r)
    return points_at(arcs, math.radians(edge_deg)), arcs, 0.1 * np.arange(xs.size)


@settings(max_examples=25, deadline=None)
@given(depth=st.floats(3.0, 6.0), ahead=st.floats(4.0, 7.0), tilt=st.floats(15.0, 30.0))
def test_a_reflector_seen_below_the_edge_is_placed_where_it_is(depth: float, ahead: float, tilt: float) -> None:
    target = np.array([ahead, 0.0, depth])
    # the frames that see it between 8 and 18 deg below the 7 deg edge (beyond the edge, inside the search)
    d = np.radians(np.linspace(tilt + 15.0, tilt + 25.0, 12))
    xs = ahead - depth / np.tan(d)
    pts, arcs, times = passes_over(target, xs, tilt, 7.0)
    assert np.all(pts[:, 2] < depth - 0.1)  # on the edge ray they stand too high
    placed, phi = consensus_points(pts, arcs, times, SPREAD, seabed_depth=depth + 0.5)
    assert phi is not None and np.all(phi >= arc_elevations(pts, arcs) - 1e-12)
    err = np.median(np.linalg.norm(placed - target, axis=1))
    on_edge = np.median(np.linalg.norm(pts - target, axis=1))
    arc = 0.03 * float(np.median(arcs[:, 9]))  # 1.7 deg of arc: frames a few degrees apart meet over that much
    assert err < arc and err < 0.25 * on_edge


def test_an_edge_ray_sweeping_a_face_stays_where_it_was_placed() -> None:
    # a vertical face 0.5 m high at 5 m north, its foot on a seabed 4 m below the sonar: the edge ray (27 deg down)
    # meets it lower and lower as the sonar approaches; successive arcs are nested and never meet
    u, w = fan(20.0)
    edge = math.radians(27.0)
    xs = 5.0 - np.linspace(3.6, 4.0, 10) / math.tan(edge)
    o = np.column_stack([xs, np.zeros_like(xs), np.zeros_like(xs)])
    arcs = arc_record(o, np.tile(u, (10, 1)), np.tile(w, (10, 1)), (5.0 - xs) / math.cos(edge))
    pts = points_at(arcs, math.radians(7.0))
    phi = consensus_elevations(pts, arcs, 0.1 * np.arange(10), SPREAD, seabed_depth=4.0)
    np.testing.assert_allclose(phi, math.radians(7.0), atol=1e-9)


def test_candidates_below_the_seabed_do_not_count() -> None:
    target = np.array([5.0, 0.0, 4.0])  # a reflector on the seabed at 4 m, seen below the edge
    xs = 5.0 - 4.0 / np.tan(np.radians(np.linspace(35.0, 45.0, 12)))
    pts, arcs, times = passes_over(target, xs, 20.0, 7.0)
    free = consensus_elevations(pts, arcs, times, SPREAD)
    held = consensus_elevations(pts, arcs, times, SPREAD, seabed_depth=3.5)  # a seabed fitted 0.5 m above it
    assert np.median(free) > math.radians(12.0)
    assert np.all(points_at(arcs, held)[:, 2] <= 3.5 + 0.05 + 1e-9)


def test_too_few_frames_or_no_arcs_change_nothing() -> None:
    pts, arcs, times = passes_over(np.array([5.0, 0.0, 4.0]), np.array([0.0, 0.1]), 20.0, 7.0)
    np.testing.assert_allclose(consensus_elevations(pts, arcs, times, SPREAD), math.radians(7.0))
    same, phi = consensus_points(pts, np.zeros((2, 0)), times, SPREAD)
    assert phi is None and np.array_equal(same, pts)
