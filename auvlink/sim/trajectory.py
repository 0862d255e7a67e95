"""The vehicle's true motion over a lawnmower survey (ground truth for every simulated sensor).

Path (horizontal, NED): line ``i`` starts at ``origin + i * spacing * s`` (``s`` = starboard of
the first line's heading ``f``), at its far end for odd lines, and runs along ``f`` for even lines,
``-f`` for odd ones. Between lines the vehicle turns on a semicircle of radius ``spacing / 2``
(to starboard after even lines, to port after odd ones). The path is flown at constant ground
speed; before the start and after the end it extends straight along the first / last line.

Vertical: the vehicle holds ``altitude`` above the *mean* seabed plane (an altitude controller does
not follow centimetre roughness), so the true altitude above the rough seabed is within a few
roughness rms of the set value. Pitch follows the flight-path angle along the slope.

Surface phases (a scene with ``[gnss]``, :mod:`auvlink.sim.gnss_config`): mission time 0 is then
the start of a wait on the surface (depth 0) at the start point P0 = first line's start + the
start offset; after ``wait_before_s`` the vehicle dives on its way to the line's start along a cubic
Hermite curve (leaving P0 towards the start, arriving along the line; both tangents ``speed x T``,
capped at twice the chord), its depth a smoothstep ``3u^2 - 2u^3`` down to the survey depth, in
``T = max(chord / speed, 1.5 depth / vertical_rate)``; then the survey; then it climbs straight on
along the last line (smoothstep to depth 0, ``T = 1.5 depth / vertical_rate``) and waits on the
surface for ``wait_after_s``. While waiting the heading is held at the one it has when it moves off
(or stops), so the heading never jumps.

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

from auvlink.sim.gnss_config import Gnss
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
                 seed: int = 0, gnss: Gnss | None = None) -> None:
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
        self.gnss = gnss
        self.surface = _SurfacePlan(self, gnss) if gnss is not None else None

    @classmethod
    def from_scene(cls, scene: Scene, seabed: SeabedSurface | None = None) -> LawnmowerTrajectory:
        if seabed is None:
            seabed = SeabedSurface(scene.seabed, scene.seed)
        return cls(scene.survey, seabed, scene.vehicle, scene.seed, scene.gnss)

    @property
    def survey_duration(self) -> float:
        """Seconds from the start of the first line to the end of the last."""
        return self.length / self.survey.speed

    @property
    def survey_start(self) -> float:
        """Mission time of the first line's start (0 without surface phases)."""
        return 0.0 if self.surface is None else self.surface.t_survey

    @property
    def duration(self) -> float:
        """Seconds of the whole mission: the survey, and the surface phases when there are some."""
        return self.survey_duration if self.surface is None else self.surface.t_end

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
        """True state at mission time(s) ``t`` (s; the first line starts at :attr:`survey_start`)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        sv, veh = self.survey, self.vehicle
        ne, vg, ag, line = self._horizontal(t - self.survey_start)
        g = self.seabed.grad_plane
        z = self.seabed.plane_depth(ne[:, 0], ne[:, 1]) - sv.altitude
        zd, zdd = vg @ g, ag @ g
        hold = np.full(t.shape, np.nan)  # heading held while waiting on the surface
        if self.surface is not None:
            ne, vg, ag, z, zd, zdd, line, hold = self.surface.apply(t, ne, vg, ag, z, zd, zdd, line)
        speed = np.hypot(vg[:, 0], vg[:, 1])
        # heading along the water-relative velocity (crab into a current)
        w = vg - np.asarray(veh.current)
        w2 = np.maximum((w * w).sum(axis=1), 1e-12)
        yaw_track = np.where(np.isnan(hold), np.arctan2(w[:, 1], w[:, 0]), hold)
        yaw_track_d = np.where(np.isnan(hold), (w[:, 0] * ag[:, 1] - w[:, 1] * ag[:, 0]) / w2, 0.0)
        gamma = -np.arctan2(zd, speed)  # flight path angle: nose down when depth increases
        speed_d = np.where(speed > 1e-9, (vg * ag).sum(axis=1) / np.maximum(speed, 1e-9), 0.0)
        den = speed * speed + zd * zd
        gamma_d = np.where(den > 1e-12, -(zdd * speed - zd * speed_d) / np.maximum(den, 1e-12), 0.0)
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
        rates = euler_rates_to_body(roll, pitch, roll_d, pitch_d, yaw_d)
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


def euler_rates_to_body(roll: F64, pitch: F64, roll_d: F64, pitch_d: F64, yaw_d: F64) -> F64:
    """Body rates (N, 3) rad/s (p, q, r) from ZYX Euler angles (rad) and their rates (rad/s)."""
    sphi, cphi, sth, cth = np.sin(roll), np.cos(roll), np.sin(pitch), np.cos(pitch)
    return np.stack([roll_d - yaw_d * sth, pitch_d * cphi + yaw_d * cth * sphi,
                     -pitch_d * sphi + yaw_d * cth * cphi], axis=1)


def _smoothstep(u: F64) -> tuple[F64, F64, F64]:
    """3u^2 - 2u^3 and its first two derivatives (u clipped to [0, 1])."""
    u = np.clip(u, 0.0, 1.0)
    return 3 * u**2 - 2 * u**3, 6 * u - 6 * u**2, 6 - 12 * u


class _SurfacePlan:
    """The surface phases around a survey (see the module docstring): times, the approach curve, the climb."""

    def __init__(self, traj: LawnmowerTrajectory, gnss: Gnss) -> None:
        sv = traj.survey
        self.speed = sv.speed
        f = traj.forward
        p1 = traj.line_start(0)
        z1 = float(traj.seabed.plane_depth(p1[0], p1[1])) - sv.altitude
        t_dive = 1.5 * z1 / gnss.vertical_rate
        if gnss.start_offset is None:  # on the line's extension, far enough back to dive on the way
            p0 = p1 - max(20.0, sv.speed * t_dive) * f
        else:
            p0 = p1 + np.asarray(gnss.start_offset, dtype=float)
        chord = p1 - p0
        length = float(np.hypot(*chord))
        self.p0, self.p1, self.z1 = p0, p1, z1
        self.t_wait0 = gnss.wait_before_s
        self.t_app = max(length / sv.speed, t_dive)
        # tangents of the curve: speed x T (a straight approach at constant speed), at most twice the chord
        # (no loop); a time warp u = phi(s) (cubic, phi'(0) = phi'(1) = r < 3: monotonic) makes the speed
        # at both ends exactly the survey speed, so neither the velocity nor the crab angle jumps
        m = max(min(sv.speed * self.t_app, 2.0 * length), sv.speed * self.t_app / 2.5)
        self.m0, self.m1 = m * chord / length, m * f
        self.r = sv.speed * self.t_app / m
        self.t_survey = self.t_wait0 + self.t_app
        end_t = np.array([traj.survey_duration])
        ne, vg, _, _ = traj._horizontal(end_t)
        self.p_end, self.u_end = ne[0], vg[0] / sv.speed
        self.z_end = float(traj.seabed.plane_depth(ne[0, 0], ne[0, 1])) - sv.altitude
        self.t_climb = 1.5 * self.z_end / gnss.vertical_rate
        self.t_climb0 = self.t_survey + traj.survey_duration
        self.t_surfaced = self.t_climb0 + self.t_climb
        self.t_end = self.t_surfaced + gnss.wait_after_s
        cur = np.asarray(traj.vehicle.current, dtype=float)
        w0, w1 = self.m0 * self.r / self.t_app - cur, sv.speed * self.u_end - cur
        self.yaw0, self.yaw1 = math.atan2(w0[1], w0[0]), math.atan2(w1[1], w1[0])

    def apply(self, t: F64, ne: F64, vg: F64, ag: F64, z: F64, zd: F64, zdd: F64, line: NDArray[np.int64]
              ) -> tuple[F64, F64, F64, F64, F64, F64, NDArray[np.int64], F64]:
        """Replace the survey's motion by the surface phases where ``t`` falls in them."""
        ne, vg, ag, z, zd, zdd, line = ne.copy(), vg.copy(), ag.copy(), z.copy(), zd.copy(), zdd.copy(), line.copy()
        hold = np.full(t.shape, np.nan)
        wait0 = t < self.t_wait0
        app = (t >= self.t_wait0) & (t < self.t_survey)
        climb = (t > self.t_climb0) & (t <= self.t_surfaced)
        wait1 = t > self.t_surfaced
        if wait0.any():
            ne[wait0], vg[wait0], ag[wait0] = self.p0, 0.0, 0.0
            z[wait0], zd[wait0], zdd[wait0], hold[wait0] = 0.0, 0.0, 0.0, self.yaw0
        if app.any():
            sig = ((t[app] - self.t_wait0) / self.t_app)[:, None]
            r = self.r
            u = -2 * sig**3 + 3 * sig**2 + r * (2 * sig**3 - 3 * sig**2 + sig)
            du = -6 * sig**2 + 6 * sig + r * (6 * sig**2 - 6 * sig + 1)
            ddu = -12 * sig + 6 + r * (12 * sig - 6)
            h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
            d00, d10, d01, d11 = 6 * u**2 - 6 * u, 3 * u**2 - 4 * u + 1, -6 * u**2 + 6 * u, 3 * u**2 - 2 * u
            e00, e10, e01, e11 = 12 * u - 6, 6 * u - 4, -12 * u + 6, 6 * u - 2
            h1 = d00 * self.p0 + d10 * self.m0 + d01 * self.p1 + d11 * self.m1
            h2 = e00 * self.p0 + e10 * self.m0 + e01 * self.p1 + e11 * self.m1
            ne[app] = h00 * self.p0 + h10 * self.m0 + h01 * self.p1 + h11 * self.m1
            vg[app] = h1 * du / self.t_app
            ag[app] = (h2 * du**2 + h1 * ddu) / self.t_app**2
            s, sd, sdd = _smoothstep(sig[:, 0])
            z[app], zd[app], zdd[app] = self.z1 * s, self.z1 * sd / self.t_app, self.z1 * sdd / self.t_app**2
        if climb.any():
            tau = t[climb] - self.t_climb0
            ne[climb] = self.p_end + self.speed * tau[:, None] * self.u_end
            vg[climb], ag[climb] = self.speed * self.u_end, 0.0
            s, sd, sdd = _smoothstep(tau / self.t_climb)
            z[climb] = self.z_end * (1.0 - s)
            zd[climb], zdd[climb] = -self.z_end * sd / self.t_climb, -self.z_end * sdd / self.t_climb**2
        if wait1.any():
            ne[wait1] = self.p_end + self.speed * self.t_climb * self.u_end
            vg[wait1], ag[wait1] = 0.0, 0.0
            z[wait1], zd[wait1], zdd[wait1], hold[wait1] = 0.0, 0.0, 0.0, self.yaw1
        line[wait0 | app | climb | wait1] = -1
        return ne, vg, ag, z, zd, zdd, line, hold
