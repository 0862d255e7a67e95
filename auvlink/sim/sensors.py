"""The simulated vehicle's sensors: every measurement of a run, vectorized over time, with its noise.

:func:`measure` samples the true motion (:mod:`auvlink.sim.trajectory`) on each sensor's own time
grid ``t_k = k / rate`` (mission time, s) and adds the noise of :mod:`auvlink.sim.noise`; the wire
encoding of these values is :mod:`auvlink.sim.emit`. Models:

- **DVL** (PD0, ``dvl_hz``): :mod:`auvlink.sim.dvl`.
- **Gyro** (KVH DSP-1760, ``gyro_hz``, rate mode, mounted aligned with the body): body angular
  rates (p, q, r), each sample the *mean* rate over its interval ``(t_k - 1/gyro_hz, t_k]`` (a FOG
  integrates the rate and reports the angle increment over the sample, divided by the period in rate
  mode): the exact differences of the true Euler angles over the interval, divided by its length,
  turned into body rates with the attitude at the interval's middle (:func:`mean_body_rate`). A point
  sample of the rate would be wrong where the rate steps (the start and end of a turn): the sum of the
  samples would miss up to rate x period of heading at each step (0.25 deg per turn on the default
  survey), which dead reckoning cannot tell from a true heading change. Plus white rate noise of
  the angle random walk N (sigma = N sqrt(rate)) and a first-order Gauss-Markov bias per axis
  (steady-state sigma = the bias instability, correlation time ``bias_correlation_s``, drawn at its
  steady state at t = 0). Accelerometers: specific force ``f_B = R_BW (a_W - g_W)``, g = 9.80665 m/s^2
  down, ``a_W`` by central differences of the true velocity, plus white noise. Temperature fixed.
- **Pressure** (``pressure_hz``): absolute pressure at the sensor (``pressure_lever_arm``),
  ``101325 + 1025 * 9.80665 * depth`` Pa (the constants of ``recon.nav``) plus white noise (a
  fraction of full scale). Sent as Paroscientific lines (psi) or Keller F73 pairs (bar).
- **AHRS** (``can_hz``): the attitude on the CAN bus, truth plus white noise.
- **GNSS** (a scene with ``[gnss]``, ``rate_hz``): :mod:`auvlink.sim.gnss`.
- **Sonar** (``fps`` of the scene): the body pose at each frame time, and the head's own attitude
  ``R_WS = R_WB Ry(-tilt)`` (what a DIDSON's compass and tilt sensor report in its header).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.signal import lfilter
from scipy.spatial.transform import Rotation

from auvlink.sim.dvl import DvlSeries, simulate_dvl
from auvlink.sim.gnss import GnssSeries, simulate_gnss
from auvlink.sim.noise import NoiseConfig, stream_rng
from auvlink.sim.scene import Scene
from auvlink.sim.seabed import SeabedSurface
from auvlink.sim.settings import SensorSettings, SimSettings
from auvlink.sim.trajectory import LawnmowerTrajectory, TruePose, euler_rates_to_body

F64 = NDArray[np.float64]

#: hydrostatics, the same constants as recon.nav (depth = (p - P_ATM) / (RHO * G))
RHO, G, P_ATM = 1025.0, 9.80665, 101325.0


def sample_times(rate_hz: float, duration: float) -> F64:
    """``k / rate`` for every k with ``k / rate < duration``."""
    return np.arange(max(0, math.ceil(duration * rate_hz - 1e-9))) / rate_hz


def pressure_to_depth(pressure_pa: F64 | float) -> F64:
    return np.asarray((np.asarray(pressure_pa, float) - P_ATM) / (RHO * G))


@dataclass(frozen=True)
class GyroSeries:
    t: F64
    rate: F64  # (n, 3) rad/s, body x, y, z
    accel: F64  # (n, 3) m/s^2 specific force, body
    temperature_c: float


@dataclass(frozen=True)
class PressureSeries:
    t: F64
    pressure_pa: F64  # absolute, measured
    depth_m: F64  # true depth of the sensor
    temperature_c: float


@dataclass(frozen=True)
class AhrsSeries:
    t: F64
    heading: F64  # [0, 2 pi)
    pitch: F64
    roll: F64


@dataclass(frozen=True)
class SonarPoses:
    t: F64
    position: F64  # (n, 3) body origin, NED
    r_wb: F64  # (n, 3, 3)
    heading: F64  # the head's own attitude (rad)
    pitch: F64
    roll: F64


@dataclass(frozen=True)
class Measurements:
    """Everything the sensors of one run report (before the wire), and what the run is."""

    seed: int
    duration: float
    settings: SimSettings
    dvl: DvlSeries
    gyro: GyroSeries
    pressure: PressureSeries
    ahrs: AhrsSeries
    sonar: SonarPoses
    gnss: GnssSeries | None = None  # a scene with [gnss]

    @property
    def sensors(self) -> SensorSettings:
        return self.settings.sensors

    @property
    def noise(self) -> NoiseConfig:
        return self.settings.noise


def _white(seed: int, sensor: str, quantity: str, shape: tuple[int, ...], sigma: float) -> F64:
    if sigma == 0.0:
        return np.zeros(shape)
    return np.asarray(stream_rng(seed, sensor, quantity).normal(0.0, sigma, shape))


def mean_body_rate(traj: LawnmowerTrajectory, t: F64, period: float, pose: TruePose | None = None) -> F64:
    """Body rates (n, 3) rad/s averaged over ``(t - period, t]``: the true Euler angles' differences over
    the interval / ``period`` (exact however the rate steps inside it), through the ZYX kinematics with
    the roll and pitch at the interval's middle (error second order in ``period``)."""
    end = traj.true_pose(t) if pose is None else pose
    start, mid = traj.true_pose(t - period), traj.true_pose(t - 0.5 * period)
    yaw_d = np.angle(np.exp(1j * (end.yaw - start.yaw))) / period
    return euler_rates_to_body(mid.roll, mid.pitch, (end.roll - start.roll) / period,
                               (end.pitch - start.pitch) / period, yaw_d)


def simulate_gyro(traj: LawnmowerTrajectory, t: F64, settings: SimSettings, seed: int,
                  pose: TruePose | None = None) -> GyroSeries:
    noise, rate_hz = settings.noise.gyro, settings.sensors.gyro_hz
    pose = traj.true_pose(t) if pose is None else pose
    n = t.shape[0]
    rate = mean_body_rate(traj, t, 1.0 / rate_hz, pose) if n else np.zeros((0, 3))
    rate = rate + _white(seed, "gyro", "arw", (n, 3), noise.arw * math.sqrt(rate_hz))
    if noise.bias_sigma > 0.0 and n:
        phi = math.exp(-1.0 / (rate_hz * noise.bias_correlation_s))
        drive = stream_rng(seed, "gyro", "bias").normal(0.0, 1.0, (n, 3))
        drive[0] *= noise.bias_sigma  # the bias at switch-on, at its steady state
        drive[1:] *= noise.bias_sigma * math.sqrt(1.0 - phi * phi)
        rate += lfilter([1.0], [1.0, -phi], drive, axis=0)
    h = 1e-3
    acc = (traj.true_pose(t + h).velocity_ned - traj.true_pose(t - h).velocity_ned) / (2.0 * h)
    force = pose.rotation().inv().apply(acc - np.array([0.0, 0.0, G])) if n else np.zeros((0, 3))
    force = force + _white(seed, "gyro", "accel", (n, 3), noise.accel_noise_density * math.sqrt(rate_hz))
    return GyroSeries(t, rate, force, settings.sensors.gyro_temperature_c)


def simulate_pressure(traj: LawnmowerTrajectory, t: F64, settings: SimSettings, seed: int) -> PressureSeries:
    pose = traj.true_pose(t)
    lever = np.asarray(settings.sensors.pressure_lever_arm, float)
    depth = pose.position[:, 2] + pose.rotation().apply(lever)[:, 2] if len(t) else np.zeros(0)
    noise = _white(seed, "pressure", "pressure", t.shape, settings.noise.pressure.sigma_pa)
    return PressureSeries(t, P_ATM + RHO * G * depth + noise, depth, settings.sensors.water_temperature_c)


def simulate_ahrs(traj: LawnmowerTrajectory, t: F64, settings: SimSettings, seed: int) -> AhrsSeries:
    pose, noise, n = traj.true_pose(t), settings.noise.ahrs, t.shape[0]
    att = math.radians(noise.attitude_sigma_deg)
    heading = pose.yaw + _white(seed, "ahrs", "heading", (n,), math.radians(noise.heading_sigma_deg))
    return AhrsSeries(t, np.mod(heading, 2.0 * math.pi), pose.pitch + _white(seed, "ahrs", "pitch", (n,), att),
                      pose.roll + _white(seed, "ahrs", "roll", (n,), att))


def sonar_poses(traj: LawnmowerTrajectory, scene: Scene, t: F64) -> SonarPoses:
    pose = traj.true_pose(t)
    rot = pose.rotation()
    if len(t):
        head = (rot * Rotation.from_euler("y", -math.radians(scene.sonar.tilt_deg))).as_euler("ZYX")
        r_wb = rot.as_matrix().reshape(-1, 3, 3)
    else:
        head, r_wb = np.zeros((0, 3)), np.zeros((0, 3, 3))
    return SonarPoses(t, pose.position, r_wb, np.mod(head[:, 0], 2.0 * math.pi), head[:, 1], head[:, 2])


def measure(scene: Scene, settings: SimSettings, duration: float | None = None,
            trajectory: LawnmowerTrajectory | None = None) -> Measurements:
    """All sensor measurements of a run of ``duration`` s (default: the survey's duration).

    The run's seed is ``scene.seed`` (it also seeds the seabed and the trajectory's oscillations).
    """
    seabed = SeabedSurface(scene.seabed, scene.seed)
    traj = trajectory if trajectory is not None else LawnmowerTrajectory.from_scene(scene, seabed)
    dur = traj.duration if duration is None else float(duration)
    s, seed = settings.sensors, scene.seed
    t_dvl = sample_times(s.dvl_hz, dur)
    return Measurements(
        seed=seed, duration=dur, settings=settings,
        dvl=simulate_dvl(traj, traj.seabed, t_dvl, s, settings.noise.dvl, seed),
        gyro=simulate_gyro(traj, sample_times(s.gyro_hz, dur), settings, seed),
        pressure=simulate_pressure(traj, sample_times(s.pressure_hz, dur), settings, seed),
        ahrs=simulate_ahrs(traj, sample_times(s.can_hz, dur), settings, seed),
        sonar=sonar_poses(traj, scene, sample_times(scene.sonar.fps, dur)),
        gnss=None if scene.gnss is None else simulate_gnss(traj, sample_times(scene.gnss.rate_hz, dur), scene.gnss,
                                                           scene.datum, seed),
    )
