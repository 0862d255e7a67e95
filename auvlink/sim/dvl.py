"""The simulated DVL: a down-looking 4-beam Janus (20 deg beams) giving PD0 bottom track.

Geometry (Teledyne RDI "ADCP Coordinate Transformation", P/N 951-6079, convex down-looking unit,
beam 3 forward): beam 1 points to port, beam 2 to starboard, beam 3 forward, beam 4 aft, each
20 deg from the instrument's vertical; the beams turn with the mounting ``dvl_rpy_deg``. Each beam
from the transducer (at ``dvl_lever_arm`` in the body) is intersected analytically with the seabed
(:meth:`~auvlink.sim.seabed.SeabedSurface.intersect`); PD0 reports the *vertical* range of each
beam, slant x cos(20 deg), not compensated for pitch and roll (WorkHorse manual, bottom-track
range).

Velocity, exactly the inverse of :mod:`recon.frames`: the DVL reports in RDI **ship** coordinates
(starboard, forward, up: its heading alignment applied inside the instrument) the **bottom moving
relative to the instrument** (PD0 sign convention)::

    v_dvl = v_B + omega_B x lever              (the transducer's velocity over ground, FRD)
    v_meas = (1 + scale_error) v_dvl + white noise (velocity_sigma per axis)
    bt = -[v_meas_starboard, v_meas_forward, -v_meas_down, error]   (error: white, velocity_sigma)

so ``rdi_ship_to_body(bottom_track_to_vehicle(bt[:3]))`` gives ``v_meas`` back. A dropout (one
probability per ping) marks all four beams bad: velocity -32768 (NaN) and range 0 (NaN); so does a
beam whose vertical range is beyond :data:`MAX_BOTTOM_RANGE_M` (no bottom detection: a seabed too deep,
or a beam near the horizontal when the vehicle pitches steeply). The
DVL's own heading/pitch/roll are the truth plus white noise; temperature is the water's plus noise;
the leader's depth is the transducer's true depth. Ensemble numbers count from 1; the RTC is the
mission clock (hundredths of a second).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from auvlink.codecs import pd0, pd0_build
from auvlink.sim.noise import DvlNoise, stream_rng
from auvlink.sim.seabed import SeabedSurface
from auvlink.sim.settings import SensorSettings
from auvlink.sim.trajectory import LawnmowerTrajectory, TruePose

F64 = NDArray[np.float64]
BEAM_ANGLE_DEG = 20
DVL_FREQUENCY_KHZ = 600
#: the deepest vertical bottom-track range, m (Teledyne RDI Workhorse Navigator 600 kHz data sheet: 0.7-90 m)
MAX_BOTTOM_RANGE_M = 90.0


def beam_directions(rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> F64:
    """(4, 3) unit beam vectors in the body frame (FRD), beams 1-4 in rows."""
    s, c = math.sin(math.radians(BEAM_ANGLE_DEG)), math.cos(math.radians(BEAM_ANGLE_DEG))
    beams = np.array([[0.0, -s, c], [0.0, s, c], [s, 0.0, c], [-s, 0.0, c]])
    roll, pitch, yaw = rpy_deg
    return np.asarray(Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True).apply(beams))


def body_to_ship(v: F64) -> F64:
    """FRD (forward, starboard, down) -> RDI ship (starboard, forward, up); inverse of rdi_ship_to_body."""
    return np.stack([v[..., 1], v[..., 0], -v[..., 2]], axis=-1)


@dataclass(frozen=True)
class DvlSeries:
    """Every ping of a run (n rows). NaN marks bad values, as they decode from PD0."""

    t: F64  # s, mission time of each ping
    bt_velocity: F64  # (n, 4) PD0 bottom track, ship coordinates, bottom relative to instrument, m/s
    range_m: F64  # (n, 4) vertical range per beam, m
    velocity_body: F64  # (n, 3) measured transducer velocity over ground, FRD (NaN on dropout)
    altitude: F64  # (n,) mean of the four vertical ranges (NaN on dropout)
    valid: NDArray[np.bool_]
    heading: F64  # rad
    pitch: F64
    roll: F64
    temperature_c: F64
    depth_m: F64  # transducer depth

    def __len__(self) -> int:
        return int(self.t.shape[0])


def simulate_dvl(traj: LawnmowerTrajectory, seabed: SeabedSurface, t: F64, sensors: SensorSettings,
                 noise: DvlNoise, seed: int, pose: TruePose | None = None) -> DvlSeries:
    """Measurements of every ping at mission times ``t`` (vectorized except the beam intersection)."""
    n = t.shape[0]
    pose = traj.true_pose(t) if pose is None else pose
    lever = np.asarray(sensors.dvl_lever_arm, float)
    rot = pose.rotation()
    v_dvl = pose.velocity_body + np.cross(pose.angular_rate_body, lever)
    origin = pose.position + rot.apply(lever)
    beams = beam_directions(sensors.dvl_rpy_deg)  # body
    mats = rot.as_matrix()  # (n, 3, 3)
    dirs = np.einsum("nij,bj->nbi", mats, beams)  # (n, 4, 3) world
    slant = np.empty((n, 4))
    with np.errstate(invalid="ignore"):  # a beam above the horizontal (steep climb) misses: NaN, a dropout
        for k in range(n):
            slant[k], _ = seabed.intersect(origin[k], dirs[k])
    vertical = slant * math.cos(math.radians(BEAM_ANGLE_DEG))
    vertical[vertical > MAX_BOTTOM_RANGE_M] = np.nan  # no bottom detection

    def draw(quantity: str, shape: tuple[int, ...], sigma: float) -> F64:
        if sigma == 0.0:
            return np.zeros(shape)
        return np.asarray(stream_rng(seed, "dvl", quantity).normal(0.0, sigma, shape))

    v_meas = (1.0 + noise.scale_error) * v_dvl + draw("velocity", (n, 3), noise.velocity_sigma)
    error = draw("error_velocity", (n,), noise.velocity_sigma)
    bt = np.column_stack([-body_to_ship(v_meas), error])
    ranges = vertical + draw("range", (n, 4), noise.range_sigma)
    ranges = np.where(np.isfinite(ranges) & (ranges > 0.0), ranges, np.nan)
    drop: NDArray[np.bool_] = np.zeros(n, bool)
    if noise.dropout_probability > 0.0:
        drop = np.asarray(stream_rng(seed, "dvl", "dropout").random(n) < noise.dropout_probability, bool)
    valid: NDArray[np.bool_] = np.asarray(~drop & np.isfinite(ranges).all(axis=1), bool)
    bt[~valid] = np.nan
    ranges[drop] = np.nan
    v_meas[~valid] = np.nan
    altitude = np.where(valid, np.where(np.isfinite(ranges), ranges, 0.0).mean(axis=1), np.nan)
    heading = pose.yaw + draw("heading", (n,), math.radians(noise.heading_sigma_deg))
    return DvlSeries(
        t=t, bt_velocity=bt, range_m=ranges, velocity_body=v_meas, altitude=altitude, valid=valid,
        heading=np.mod(heading, 2.0 * math.pi),
        pitch=pose.pitch + draw("pitch", (n,), math.radians(noise.attitude_sigma_deg)),
        roll=pose.roll + draw("roll", (n,), math.radians(noise.attitude_sigma_deg)),
        temperature_c=sensors.water_temperature_c + draw("temperature", (n,), noise.temperature_sigma_c),
        depth_m=origin[:, 2],
    )


def pd0_ensemble(series: DvlSeries, k: int, start_s: float, sound_speed: float = 1500.0) -> pd0.Pd0Ensemble:
    """Ping ``k`` as the PD0 ensemble a receiver decodes (ship coordinates, bottom track only)."""
    return pd0_build.build(
        k + 1, start_s + float(series.t[k]),
        heading_rad=float(series.heading[k]), pitch_rad=float(series.pitch[k]),
        roll_rad=float(series.roll[k]), temperature_c=float(series.temperature_c[k]),
        depth_m=max(0.0, float(series.depth_m[k])), speed_of_sound_mps=round(sound_speed),
        bt_velocity_mps=series.bt_velocity[k], bt_range_m=series.range_m[k],
        coordinate_system="ship", n_cells=1, frequency_khz=DVL_FREQUENCY_KHZ, beam_angle_deg=BEAM_ANGLE_DEG,
        bottom_track=True, serial_number=1760,
    )
