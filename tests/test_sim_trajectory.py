"""Lawnmower trajectory: lines step to starboard, altitude and speed held, consistent derivatives."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from auvlink.sim.scene import Seabed, Survey, Vehicle, load_default_scene
from auvlink.sim.seabed import SeabedSurface
from auvlink.sim.trajectory import LawnmowerTrajectory

STILL = Vehicle(roll_amplitude_deg=0.0, pitch_amplitude_deg=0.0, yaw_amplitude_deg=0.0)


def _traj(heading: float = 0.0, slope: float = 0.0, rough: float = 0.0,
          vehicle: Vehicle = STILL, seed: int = 1) -> LawnmowerTrajectory:
    survey = Survey(line_length=60.0, line_spacing=4.0, lines=4, altitude=5.0, speed=1.5,
                    origin=(10.0, -5.0), heading_deg=heading)
    seabed = SeabedSurface(Seabed(depth=25.0, slope_deg=slope, slope_azimuth_deg=30.0, roughness=rough), seed)
    return LawnmowerTrajectory(survey, seabed, vehicle, seed)


def _line_times(tr: LawnmowerTrajectory, i: int, n: int = 50) -> np.ndarray:
    t0 = i * tr.period / tr.survey.speed
    return np.linspace(t0 + 1.0, t0 + tr.survey.line_length / tr.survey.speed - 1.0, n)


@pytest.mark.parametrize("heading", [0.0, 90.0, 215.0])
def test_lines_step_to_starboard(heading: float) -> None:
    tr = _traj(heading)
    psi = math.radians(heading)
    fwd, stb = np.array([math.cos(psi), math.sin(psi)]), np.array([-math.sin(psi), math.cos(psi)])
    for i in range(tr.survey.lines):
        p = tr.true_pose(_line_times(tr, i))
        assert (p.line == i).all()
        rel = p.position[:, :2] - np.asarray(tr.survey.origin)
        np.testing.assert_allclose(rel @ stb, i * tr.survey.line_spacing, atol=1e-9)
        along = rel @ fwd
        assert ((along >= 0) & (along <= tr.survey.line_length)).all()
        # even lines run along the heading, odd lines back
        direction = 1.0 if i % 2 == 0 else -1.0
        np.testing.assert_allclose(p.velocity_ned[:, :2] @ fwd, direction * tr.survey.speed, atol=1e-9)
        expected_yaw = psi if i % 2 == 0 else psi + math.pi
        np.testing.assert_allclose(np.angle(np.exp(1j * (p.yaw - expected_yaw))), 0.0, atol=1e-9)


def test_turns_are_semicircles_between_lines() -> None:
    tr = _traj()
    t = np.linspace(0.0, tr.duration, 4001)
    p = tr.true_pose(t)
    turning = p.line == -1
    assert turning.any() and (p.line[~turning] >= 0).all()
    speed = np.linalg.norm(p.velocity_ned[:, :2], axis=1)
    np.testing.assert_allclose(speed, tr.survey.speed, atol=1e-9)
    # position is continuous: steps match speed * dt
    steps = np.linalg.norm(np.diff(p.position[:, :2], axis=0), axis=1)
    assert steps.max() <= tr.survey.speed * (t[1] - t[0]) + 1e-9
    # the last point is the end of the last line
    end = tr.line_start(tr.survey.lines - 1) + tr.survey.line_length * np.array([-1.0, 0.0])
    np.testing.assert_allclose(p.position[-1, :2], end, atol=1e-9)
    assert tr.duration == pytest.approx((4 * 60.0 + 3 * math.pi * 2.0) / 1.5)


def test_altitude_held_on_sloped_rough_seabed() -> None:
    tr = _traj(slope=3.0, rough=0.02, vehicle=Vehicle())
    p = tr.true_pose(np.linspace(0, tr.duration, 2000))
    assert np.abs(p.altitude - tr.survey.altitude).max() < 4 * 0.02 * 2  # within the roughness band
    plane = tr.seabed.plane_depth(p.position[:, 0], p.position[:, 1])
    np.testing.assert_allclose(plane - p.depth, tr.survey.altitude, atol=1e-9)
    assert np.ptp(p.depth) > 1.0  # it follows the slope


def test_derivatives_match_finite_differences() -> None:
    tr = _traj(slope=2.0, vehicle=Vehicle(current=(0.2, -0.3)))
    t = np.linspace(0.5, tr.duration - 0.5, 700)
    h = 1e-4
    p, pm, pp = tr.true_pose(t), tr.true_pose(t - h), tr.true_pose(t + h)
    np.testing.assert_allclose((pp.position - pm.position) / (2 * h), p.velocity_ned, atol=1e-6)
    rate = (pm.rotation().inv() * pp.rotation()).as_rotvec() / (2 * h)
    np.testing.assert_allclose(rate, p.angular_rate_body, atol=1e-6)
    np.testing.assert_allclose(p.rotation().apply(p.velocity_body), p.velocity_ned, atol=1e-12)


def test_attitude_convention_is_zyx() -> None:
    tr = _traj(vehicle=Vehicle())
    p = tr.true_pose([3.0])
    expected = (Rotation.from_euler("z", p.yaw[0]) * Rotation.from_euler("y", p.pitch[0])
                * Rotation.from_euler("x", p.roll[0]))
    np.testing.assert_allclose(p.rotation().as_matrix()[0], expected.as_matrix(), atol=1e-12)


def test_current_makes_the_vehicle_crab() -> None:
    tr = _traj(vehicle=replace(STILL, current=(0.0, 0.3)))
    p = tr.true_pose(_line_times(tr, 0))
    # heading into the current: water-relative velocity along the body x axis
    np.testing.assert_allclose(p.water_velocity_body[:, 1:], 0.0, atol=1e-12)
    np.testing.assert_allclose(p.yaw, -math.atan2(0.3, 1.5), atol=1e-12)
    # over ground the bottom-tracking DVL sees the crab as a sideways (starboard) velocity
    assert (p.velocity_body[:, 1] > 0.25).all()


def test_oscillations_are_small_and_seeded() -> None:
    a, b, c = (_traj(vehicle=Vehicle(), seed=s) for s in (4, 4, 5))
    t = np.linspace(0, 100, 500)
    pa, pb, pc = a.true_pose(t), b.true_pose(t), c.true_pose(t)
    np.testing.assert_array_equal(pa.roll, pb.roll)
    assert not np.allclose(pa.roll, pc.roll)
    assert np.abs(pa.roll).max() <= math.radians(1.0) + 1e-12
    assert np.abs(pa.roll).max() > math.radians(0.9)


def test_from_default_scene() -> None:
    scene = load_default_scene()
    tr = LawnmowerTrajectory.from_scene(scene)
    assert 120 < tr.survey_duration < 300 and tr.surface is not None  # the shipped scene has [gnss]
    assert tr.duration == tr.surface.t_end > tr.survey_start + tr.survey_duration
    p = tr.true_pose(np.arange(0.0, tr.duration, 0.02))  # 50 Hz truth
    assert len(p) == p.position.shape[0] == p.angular_rate_body.shape[0]


@settings(max_examples=30, deadline=None)
@given(st.floats(0.0, 400.0), st.floats(-180.0, 180.0))
def test_pose_scalar_matches_vector(t: float, heading: float) -> None:
    tr = _traj(heading, slope=1.0, vehicle=Vehicle(current=(0.1, 0.1)))
    one = tr.true_pose(t)
    many = tr.true_pose(np.array([t, t + 1.0]))
    np.testing.assert_allclose(one.position[0], many.position[0])
    assert -math.pi <= one.yaw[0] <= math.pi
