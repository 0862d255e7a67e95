"""The vehicle's true motion over a lawnmower survey (ground truth for every simulated sensor).

Path (horizontal, NED): line ``i`` starts at ``origin + i * spacing * s`` (``s`` = starboard of
the first line's heading ``f``), at its far end for odd lines, and runs along ``f`` for even lines,
``-f`` for odd ones. Between lines the vehicle turns on a semicircle of radius ``spacing / 2``
(to starboard after even lines, to port after odd ones). The path is flown at constant ground
speed; before the start and after the end it extends straight along the first / last line.

Vertical: the vehicle holds ``altitude`` above the *mean* seabed plane (an altitude controller does
not follow centimetre roughness), so the true altitude above the rough seabed is within a few
roughness rms of the set value. Pitch follows the flight-path angle along the slope.

Attitude: heading points along the velocity through the water (ground velocity minus current, so
a cross-current makes the vehicle crab), plus small seeded sinusoidal oscillations in roll, pitch
and yaw. ``R_WB = Rz(yaw) Ry(pitch) Rx(roll)`` (scipy ``"ZYX"``). Body rates come from the
ZYX Euler-rate kinematics with analytic derivatives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from auvlink.sim.scene import Scene, Survey, Vehicle
from auvlink.sim.seabed import SeabedSurface

F64 = NDArray[np.float64]
TRAJECTORY_STREAM = 0x7EA7


@dataclass(frozen=True)
class TruePose:
    """True vehicle state at times ``t`` (every array has ``len(t)`` rows)."""

    t: F64  # s
    position: F64  # (N, 3) NED, m (body origin)
    yaw: F64  # rad, 0 = north, clockwise positive, wrapped to (-pi, pi]
    pitch: F64  # rad, nose up positive
    roll: F64  # rad, starboard down positive
    velocity_ned: F64  # (N, 3) m/s over ground
    velocity_body: F64  # (N, 3) m/s over ground in the body frame (bottom-track DVL)
    water_velocity_body: F64  # (N, 3) m/s through the water in the body frame
    angular_rate_body: F64  # (N, 3) rad/s (p, q, r) about body x, y, z
    altitude: F64  # m, vertical distance from the body origin down to the (rough) seabed
    line: NDArray[np.int64]  # survey line index, -1 while turning

    def __len__(self) -> int:
        return int(self.t.shape[0])

    @property
    def depth(self) -> F64:
        return self.position[:, 2]

    def rotation(self) -> Rotation:
        """``R_WB`` for every sample."""
        return Rotation.from_euler("ZYX", np.stack([self.yaw, self.pitch, self.roll], axis=1))


class LawnmowerTrajectory:
    """Lawnmower survey flown at constant ground speed and altitude; vectorized over time."""

    def __init__(self, survey: Survey, seabed: SeabedSurface, vehicle: Vehicle | None = None,
                 seed: int = 0) -> None:
        self.survey, self.seabed = survey, seabed
        self.vehicle = vehicle if vehicle is not None else Vehicle()
        psi = math.radians(survey.heading_deg)
        self.forward = np.array([math.cos(psi), math.sin(psi)])
        self.starboard = np.array([-math.sin(psi), math.cos(psi)])
        self.radius = survey.line_spacing / 2.0
        self.period = survey.line_length + math.pi * self.radius  # path length of line + turn
        self.length = survey.lines * survey.line_length + (survey.lines - 1) * math.pi * self.radius
        rng = np.random.default_rng(np.random.SeedSequence([seed, TRAJECTORY_STREAM]))
        self.phases = rng.uniform(0.0, 2.0 * math.pi, 3)  # roll, pitch, yaw oscillations

    @classmethod
    def from_scene(cls, scene: Scene, seabed: SeabedSurface | None = None) -> LawnmowerTrajectory:
        if seabed is None:
            seabed = SeabedSurface(scene.seabed, scene.seed)
        return cls(scene.survey, seabed, scene.vehicle, scene.seed)

    @property
    def duration(self) -> float:
        """Seconds from the start of the first line to the end of the last."""
        return self.length / self.survey.speed

    def line_start(self, i: int) -> F64:
        """Horizontal start point (north, east) of line ``i``."""
        sv = self.survey
        start = np.asarray(sv.origin) + i * sv.line_spacing * self.starboard
        return start + (sv.line_length * self.forward if i % 2 else 0.0)

    def _horizontal(self, t: F64) -> tuple[F64, F64, F64, NDArray[np.int64]]:
        """Ground position, velocity, acceleration (N, 2) and line index."""
        sv, v, rho = self.survey, self.survey.speed, self.radius
        sigma = v * t
        k = np.clip(np.floor(sigma / self.period), 0, sv.lines - 1).astype(np.int64)
        local = sigma - k * self.period
        in_turn = (local > sv.line_length) & (k < sv.lines - 1)
        sign = np.where(k % 2 == 0, 1.0, -1.0)[:, None]
        u = sign * self.forward  # line direction
        origin = np.asarray(sv.origin) + (k * sv.line_spacing)[:, None] * self.starboard
        start = origin + np.where(k % 2 == 1, sv.line_length, 0.0)[:, None] * self.forward
        pos = start + local[:, None] * u
        vel = v * u
        acc = np.zeros_like(pos)
        if np.any(in_turn):
            beta = ((local - sv.line_length) / rho)[:, None]
            centre = start + sv.line_length * u + rho * self.starboard
            cb, sb = np.cos(beta), np.sin(beta)
            t_pos = centre - rho * cb * self.starboard + rho * sb * u
            t_vel = v * (sb * self.starboard + cb * u)
            t_acc = (v * v / rho) * (cb * self.starboard - sb * u)
            m = in_turn[:, None]
            pos, vel, acc = np.where(m, t_pos, pos), np.where(m, t_vel, vel), np.where(m, t_acc, acc)
        return pos, vel, acc, np.where(in_turn, -1, k)

    def true_pose(self, t: ArrayLike) -> TruePose:
        """True state at time(s) ``t`` (s from the start of the first line)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        sv, veh = self.survey, self.vehicle
        ne, vg, ag, line = self._horizontal(t)
        g = self.seabed.grad_plane
        z = self.seabed.plane_depth(ne[:, 0], ne[:, 1]) - sv.altitude
        zd, zdd = vg @ g, ag @ g
        speed = sv.speed
        # heading along the water-relative velocity (crab into a current)
        w = vg - np.asarray(veh.current)
        w2 = (w * w).sum(axis=1)
        yaw_track = np.arctan2(w[:, 1], w[:, 0])
        yaw_track_d = (w[:, 0] * ag[:, 1] - w[:, 1] * ag[:, 0]) / w2
        gamma = -np.arctan2(zd, speed)  # flight path angle: nose down when depth increases
        gamma_d = -(zdd * speed) / (speed * speed + zd * zd)
        osc, osc_d = [], []
        for amp_deg, period, phase in zip(
            (veh.roll_amplitude_deg, veh.pitch_amplitude_deg, veh.yaw_amplitude_deg),
            (veh.roll_period_s, veh.pitch_period_s, veh.yaw_period_s), self.phases, strict=True,
        ):
            omega, amp = 2.0 * math.pi / period, math.radians(amp_deg)
            osc.append(amp * np.sin(omega * t + phase))
            osc_d.append(amp * omega * np.cos(omega * t + phase))
        roll, pitch = osc[0], gamma + osc[1]
        yaw = np.angle(np.exp(1j * (yaw_track + osc[2])))
        roll_d, pitch_d, yaw_d = osc_d[0], gamma_d + osc_d[1], yaw_track_d + osc_d[2]
        # ZYX Euler rates -> body rates
        sphi, cphi, sth, cth = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
        rates = np.stack([
            roll_d - yaw_d * sth,
            pitch_d * cphi + yaw_d * cth * sphi,
            -pitch_d * sphi + yaw_d * cth * cphi,
        ], axis=1)
        rot_inv = Rotation.from_euler("ZYX", np.stack([yaw, pitch, roll], axis=1)).inv()
        v_ned = np.column_stack([vg, zd])
        current = np.array([veh.current[0], veh.current[1], 0.0])
        position = np.column_stack([ne, z])
        altitude = self.seabed.depth(ne[:, 0], ne[:, 1]) - z
        return TruePose(
            t=t, position=position, yaw=yaw, pitch=pitch, roll=roll, velocity_ned=v_ned,
            velocity_body=rot_inv.apply(v_ned), water_velocity_body=rot_inv.apply(v_ned - current),
            angular_rate_body=rates, altitude=np.asarray(altitude, float), line=line,
        )
