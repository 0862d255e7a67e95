"""Sonar geometry: bins, beams, the highlight ray (exact vs paper), seabed onset, numerical stability."""

from __future__ import annotations

import numpy as np
import pytest
from geometry_reference import beam_azimuth, highlight_point, paper_point, r_bs, row_range
from hypothesis import given, settings
from hypothesis import strategies as st

from recon.errors import GeometryError
from recon.frames import attitude
from recon.highlight import project
from recon.sonar_geometry import SonarGeometry, paper_minus_exact, points_sonar

D = np.deg2rad


def test_bins_and_beams() -> None:
    g = SonarGeometry()
    assert g.ranges[0] == pytest.approx(1.0 + 0.5 * 10.0 / 512)
    assert g.ranges[-1] == pytest.approx(11.0 - 0.5 * 10.0 / 512)
    assert np.allclose(g.range_to_row(g.ranges), np.arange(512))
    assert g.azimuths[0] == pytest.approx(D(-14.5)) and g.azimuths[-1] == pytest.approx(D(14.5))
    table = tuple(np.linspace(D(14), D(-14), 96))
    assert np.allclose(SonarGeometry(azimuth_table=table).azimuths, table)
    with pytest.raises(GeometryError):
        SonarGeometry(azimuth_table=(0.0, 0.1))
    with pytest.raises(GeometryError):
        SonarGeometry(spread=0.0)


def test_points_sonar_convention() -> None:
    assert np.allclose(points_sonar(2.0, 0.0, 0.0), [2, 0, 0])
    assert np.allclose(points_sonar(2.0, D(90), 0.0), [0, 2, 0])  # starboard
    assert np.allclose(points_sonar(2.0, 0.0, D(90)), [0, 0, 2])  # down
    g = SonarGeometry.from_degrees(30, 14)
    d = g.highlight_directions("exact", np.array([0.0]))[0]
    e = D(37)
    assert np.allclose(d, [np.cos(e), 0, np.sin(e)])


def test_paper_vs_exact_zero_on_axis_growing_off_axis() -> None:
    g = SonarGeometry.from_degrees(30, 14)
    th = D(np.linspace(0, 14.5, 30))
    diff = paper_minus_exact(g, 8.0, th)
    assert diff[0] == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.diff(diff) > 0)
    assert np.allclose(paper_minus_exact(g, 8.0, -th), diff)
    assert 0.3 < diff[-1] < 0.5  # about 0.41 m at the edge of the fan at 8 m (30 deg tilt, 14 deg spread)
    # the paper ray is the steeper one off axis
    down_paper = g.highlight_directions("paper", th[1:])[:, 2]
    assert np.all(down_paper > g.highlight_directions("exact", th[1:])[:, 2])
    with pytest.raises(GeometryError):
        g.highlight_directions("other")  # type: ignore[arg-type]


def test_onset_level_vehicle() -> None:
    g = SonarGeometry.from_degrees(30, 14, azimuth_table=tuple(D(np.linspace(-14.5, 14.5, 96))))
    on = g.flat_onset_ranges([[0, 0, 10.0]], attitude(0.7, 0, 0), [5.0])[0]
    # on axis h / sin(t + s/2); off axis the steepest ray goes down by sin t cos(s/2) cos th + cos t sin(s/2)
    th = g.azimuths
    expect = 5.0 / (np.sin(D(30)) * np.cos(D(7)) * np.cos(th) + np.cos(D(30)) * np.sin(D(7)))
    assert np.allclose(on, expect)
    assert np.all(np.isinf(g.flat_onset_ranges([[0, 0, 10.0]], attitude(0, 0, 0), [np.nan])))


@settings(max_examples=80, deadline=None)
@given(st.floats(0, 60), st.floats(-180, 180), st.floats(-20, 20), st.floats(-20, 20), st.floats(1, 30))
def test_onset_matches_brute_force_fan(tilt: float, yaw: float, pitch: float, roll: float, h: float) -> None:
    g = SonarGeometry.from_degrees(tilt, 14, n_beams=9, lever_arm=(0.5, 0.1, 0.2))
    rot = attitude(D(yaw), D(pitch), D(roll))
    on = g.flat_onset_ranges([[0, 0, 0.0]], rot, [h])[0]
    phi = np.linspace(-D(7), D(7), 2001)
    d = g.directions_body(phi[None, :], g.azimuths[:, None])  # (beams, elev, 3) in B
    d_w = rot.apply(d.reshape(-1, 3)).reshape(d.shape)
    origin_z = rot.apply(g.mounting.lever)[2]
    with np.errstate(divide="ignore"):
        r = np.where(d_w[..., 2] > 0, (h - origin_z) / d_w[..., 2], np.inf)
    brute = r.min(axis=1)
    finite = np.isfinite(brute)
    assert np.array_equal(finite, np.isfinite(on))
    assert np.allclose(on[finite], brute[finite], rtol=1e-4)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 95), st.floats(0, 60), st.floats(-1000, 1000), st.floats(-30, 30), st.floats(-30, 30),
       st.floats(-1e6, 1e6), st.floats(-1e6, 1e6), st.floats(0, 6000), st.integers(0, 511),
       st.sampled_from(["exact", "paper"]))
def test_projection_stable_far_from_origin(beam: int, tilt: float, yaw: float, pitch: float, roll: float,
                                           north: float, east: float, depth: float, row: int,
                                           mode: str) -> None:
    g = SonarGeometry.from_degrees(tilt, 14, lever_arm=(1.2, -0.1, 0.3))
    rot = attitude(D([yaw]), D([pitch]), D([roll]))
    i = np.array([0])
    far = project(g, i, np.array([beam]), np.array([row]), np.array([[north, east, depth]]), rot, mode)  # type: ignore[arg-type]
    near = project(g, i, np.array([beam]), np.array([row]), np.array([[0.0, 0.0, depth]]), rot, mode)  # type: ignore[arg-type]
    assert np.all(np.isfinite(far))
    assert np.abs(far - [north, east, 0.0] - near).max() < 1e-3
    on = g.flat_onset_ranges([[north, east, depth]], rot, [5.0])
    assert not np.any(np.isnan(on))


@settings(max_examples=100, deadline=None)
@given(st.floats(0, 60), st.floats(2, 30), st.integers(0, 95), st.floats(-2, 2), st.floats(-2, 2),
       st.floats(-10, 10))
def test_highlight_directions_match_independent_geometry(tilt: float, spread: float, beam: int, m_roll: float,
                                                        m_pitch: float, m_yaw: float) -> None:
    """Each beam's highlight ray in B: r_bs(t, rpy) [cos(s/2) cos th, cos(s/2) sin th, sin(s/2)]; the paper's ray."""
    mount = (D(m_roll), D(m_pitch), D(m_yaw))
    g = SonarGeometry.from_degrees(tilt, spread, mount_rpy=mount)
    th = beam_azimuth(beam, D(29.0), 96)
    assert g.azimuths[beam] == pytest.approx(th, abs=1e-12)
    h = D(spread) / 2
    want = r_bs(D(tilt), mount).apply([np.cos(h) * np.cos(th), np.cos(h) * np.sin(th), np.sin(h)])
    assert np.allclose(g.highlight_directions("exact")[beam], want, atol=1e-12)
    assert np.allclose(g.highlight_directions("paper")[beam], paper_point(1.0, th, tilt=D(tilt), spread=D(spread)),
                       atol=1e-12)


@settings(max_examples=100, deadline=None)
@given(st.floats(0, 60), st.floats(4, 20), st.tuples(st.floats(-180, 180), st.floats(-30, 30), st.floats(-30, 30)),
       st.tuples(st.floats(-2, 2), st.floats(-1, 1), st.floats(-1, 1)), st.tuples(st.floats(-1e5, 1e5),
       st.floats(-1e5, 1e5), st.floats(0, 3000)), st.integers(0, 95), st.integers(0, 511), st.floats(0.5, 5),
       st.floats(1, 40))
def test_project_matches_independent_geometry(tilt: float, spread: float, ypr: tuple[float, float, float],
                                              lever: tuple[float, float, float], pos: tuple[float, float, float],
                                              beam: int, row: int, start: float, length: float) -> None:
    """World point of (row, beam) for a random pose, mounting and range window, against the reference."""
    g = SonarGeometry.from_degrees(tilt, spread, lever_arm=lever, window_start=start, window_length=length)
    yaw, pitch, roll = D(ypr)
    got = project(g, np.array([0]), np.array([beam]), np.array([row]), np.array([pos]),
                  attitude([yaw], [pitch], [roll]))[0]
    want = highlight_point(row_range(row, start, length, 512), beam_azimuth(beam, D(29.0), 96), tilt=D(tilt),
                           spread=D(spread), position=np.array(pos), ypr=(yaw, pitch, roll), lever=np.array(lever))
    assert np.abs(got - want).max() < 1e-7, (got, want)
