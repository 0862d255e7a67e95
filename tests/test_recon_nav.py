"""Dead reckoning exact on noise-free synthetic paths; dropouts, disorder, depth, interpolation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from recon.errors import NavigationError
from recon.frames import Mounting, attitude, euler, rdi_instrument_mounting
from recon.nav import DepthSamples, DvlSamples, GyroSamples, NavConfig, dead_reckon, pressure_to_depth
from recon.trajectory import Trajectory

D = np.deg2rad
RHO_G = 1025.0 * 9.80665


class Path:
    """Constant speed v, heading piecewise linear: segments of (duration, yaw rate)."""

    def __init__(self, v: float, psi0: float, segments: list[tuple[float, float]]) -> None:
        self.v, self.psi0 = v, psi0
        self.t = np.r_[0.0, np.cumsum([d for d, _ in segments])]
        self.rate = np.array([w for _, w in segments])
        psi, p = [psi0], [np.zeros(2)]
        for (d, w) in segments:
            psi.append(psi[-1] + w * d)
            p.append(p[-1] + self._disp(psi[-2], w, d))
        self.psi_k, self.p_k = np.array(psi), np.array(p)

    def _disp(self, psi: np.ndarray | float, w: np.ndarray | float, d: np.ndarray | float) -> np.ndarray:
        psi, w, d = np.broadcast_arrays(np.asarray(psi, float), np.asarray(w, float), np.asarray(d, float))
        safe = np.where(w == 0, 1.0, w)
        turn = np.stack([np.sin(psi + w * d) - np.sin(psi), np.cos(psi) - np.cos(psi + w * d)], -1)
        turn = turn / safe[..., None]
        line = np.stack([np.cos(psi), np.sin(psi)], -1) * d[..., None]
        return self.v * np.where((w == 0)[..., None], line, turn)

    def at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, self.rate.size - 1)
        d = t - self.t[k]
        pos = self.p_k[k] + self._disp(self.psi_k[k], self.rate[k], d)
        return pos, self.psi_k[k] + self.rate[k] * d, self.rate[k]


def _sensors(path: Path, lever: tuple[float, float, float] = (0.0, 0.0, 0.0), dvl_hz: float = 5.0,
             gyro_hz: float = 100.0, depth: float = 12.0, gyro_kind: str = "delta"
             ) -> tuple[DvlSamples, GyroSamples, DepthSamples, NavConfig]:
    t_end = path.t[-1]
    tg = np.arange(0.0, t_end + 1e-9, 1.0 / gyro_hz)
    _, psi_g, rate_g = path.at(tg)
    value = np.r_[0.0, np.diff(psi_g)] if gyro_kind == "delta" else rate_g
    tv = np.arange(0.05, t_end, 1.0 / dvl_hz)  # never on a rate switch
    _, psi_v, rate_v = path.at(tv)
    v_b = np.array([path.v, 0.0, 0.0]) + np.cross(np.stack([0 * rate_v, 0 * rate_v, rate_v], 1), lever)
    mount = rdi_instrument_mounting(lever_arm=lever)
    bt_instr = -mount.rotation.inv().apply(v_b)  # PD0: bottom relative to the instrument
    dvl = DvlSamples(tv, bt_instr, "instrument", altitude=np.full(tv.size, 4.0), pitch=np.zeros(tv.size),
                     roll=np.zeros(tv.size), heading=psi_v)
    td = np.arange(0.0, t_end + 1e-9, 0.5)
    dep = DepthSamples(td, np.full(td.size, 101325.0 + RHO_G * depth))
    return dvl, GyroSamples(tg, value, gyro_kind), dep, NavConfig(dvl_mounting=mount)  # type: ignore[arg-type]


def _err(traj: Trajectory, path: Path) -> float:
    truth, _, _ = path.at(traj.times)  # the trajectory starts at (0, 0) at its first time
    return float(np.abs(traj.positions[:, :2] - (truth - truth[0])).max())


def test_pressure_to_depth() -> None:
    assert pressure_to_depth(101325.0 + RHO_G * 10.0) == pytest.approx(10.0, abs=1e-12)
    assert pressure_to_depth(101325.0) == 0.0
    assert pressure_to_depth(2e5, density=1000.0, gravity=10.0, atmospheric_pa=1e5) == pytest.approx(10.0)


def test_straight_line_1km_exact() -> None:
    path = Path(1.5, D(30), [(700.0, 0.0)])  # 1050 m
    dvl, gyro, dep, cfg = _sensors(path, gyro_kind="rate")
    traj = dead_reckon(dvl, gyro, dep, cfg)
    assert np.linalg.norm(traj.positions[-1, :2]) > 1000
    assert _err(traj, path) < 1e-3
    assert np.allclose(traj.positions[:, 2], 12.0)
    assert traj.degraded is not None and traj.altitude is not None
    assert not traj.degraded.any()
    assert np.allclose(traj.altitude, 4.0)


def test_turns_exact_with_lever_arm() -> None:
    segs = [(100.0, 0.0), (30.0, np.pi / 30), (200.0, 0.0), (60.0, -np.pi / 60), (150.0, 0.0),
            (45.0, 0.02), (300.0, 0.0), (90.0, -np.pi / 90), (100.0, 0.0)]
    path = Path(1.0, D(-170), segs)
    dvl, gyro, dep, cfg = _sensors(path, lever=(0.6, -0.2, 0.3))
    traj = dead_reckon(dvl, gyro, dep, cfg)
    assert path.t[-1] * path.v > 1000
    assert _err(traj, path) < 1e-3
    _, psi, _ = path.at(traj.times)
    yaw, _, _ = euler(traj.rotations)
    assert np.allclose(np.angle(np.exp(1j * (yaw - psi))), 0.0, atol=1e-9)


def test_constant_rate_circle_rate_gyro() -> None:
    path = Path(1.2, 0.0, [(900.0, 0.05)])
    dvl, gyro, dep, cfg = _sensors(path, gyro_kind="rate")
    assert _err(dead_reckon(dvl, gyro, dep, cfg), path) < 1e-3


def test_ship_and_earth_frames() -> None:
    path = Path(1.0, D(60), [(300.0, 0.0)])
    dvl, gyro, dep, _ = _sensors(path)
    truth_v = np.array([np.cos(D(60)), np.sin(D(60)), 0.0])
    n = np.asarray(dvl.t).size
    bt_earth = -np.tile([truth_v[1], truth_v[0], -truth_v[2]], (n, 1))  # east, north, up; bottom moving
    earth = DvlSamples(dvl.t, bt_earth, "earth", altitude=dvl.altitude, pitch=dvl.pitch, roll=dvl.roll,
                       heading=dvl.heading)
    assert _err(dead_reckon(earth, gyro, dep, NavConfig()), path) < 1e-6
    bt_ship = -np.tile([0.0, 1.0, 0.0], (n, 1))
    ship = DvlSamples(dvl.t, bt_ship, "ship", pitch=dvl.pitch, roll=dvl.roll, heading=dvl.heading)
    assert _err(dead_reckon(ship, gyro, dep, NavConfig()), path) < 1e-6
    vehicle = DvlSamples(dvl.t, -bt_ship, "ship", pitch=dvl.pitch, roll=dvl.roll, heading=dvl.heading,
                         bottom_track=False)
    assert _err(dead_reckon(vehicle, gyro, dep, NavConfig()), path) < 1e-6


def test_dropouts_hold_then_degrade() -> None:
    path = Path(1.0, D(10), [(120.0, 0.0)])
    dvl, gyro, dep, cfg = _sensors(path)
    t = np.asarray(dvl.t)
    valid = ~(((t > 20) & (t < 21.5)) | ((t > 50) & (t < 60)))  # 1.5 s and 10 s dropouts
    bad_vel = np.where(valid[:, None], np.asarray(dvl.velocity), 99.0)  # garbage where invalid
    drop = DvlSamples(t, bad_vel, "instrument", valid, dvl.altitude, dvl.pitch, dvl.roll, dvl.heading)
    traj = dead_reckon(drop, gyro, dep, cfg)
    assert _err(traj, path) < 1e-6  # constant velocity: holding it is exact
    deg = traj.degraded_at(np.array([20.9, 21.4, 51.0, 52.5, 59.0, 61.0]))
    assert deg.tolist() == [False, False, False, True, True, False]
    alt = traj.altitude_at([51.0, 55.0])
    assert alt[0] == 4.0 and np.isnan(alt[1])


def test_duplicates_and_disorder() -> None:
    path = Path(1.0, D(-45), [(60.0, 0.0), (30.0, 0.03), (60.0, 0.0)])
    dvl, gyro, dep, cfg = _sensors(path)
    ref = dead_reckon(dvl, gyro, dep, cfg)
    rng = np.random.default_rng(3)
    tv = np.asarray(dvl.t)
    order = rng.permutation(np.r_[np.arange(tv.size), rng.integers(0, tv.size, 40)])  # 40 duplicates
    messy = DvlSamples(tv[order], np.asarray(dvl.velocity)[order], "instrument", None,
                       np.asarray(dvl.altitude)[order], np.asarray(dvl.pitch)[order],
                       np.asarray(dvl.roll)[order], np.asarray(dvl.heading)[order])
    tg = np.asarray(gyro.t)
    go = rng.permutation(np.r_[np.arange(tg.size), rng.integers(0, tg.size, 100)])
    messy_g = GyroSamples(tg[go], np.asarray(gyro.value)[go], "delta")
    out = dead_reckon(messy, messy_g, dep, cfg)
    assert np.array_equal(out.times, ref.times)
    assert np.allclose(out.positions, ref.positions, atol=1e-9)


def test_gyro_gap_flagged_and_errors() -> None:
    path = Path(1.0, 0.0, [(60.0, 0.0)])
    dvl, gyro, dep, cfg = _sensors(path, gyro_kind="rate")
    tg = np.asarray(gyro.t)
    keep = (tg < 30) | (tg > 33)
    traj = dead_reckon(dvl, GyroSamples(tg[keep], np.asarray(gyro.value)[keep]), dep, cfg)
    assert traj.degraded_at([31.0])[0] and not traj.degraded_at([20.0])[0]
    with pytest.raises(NavigationError):
        dead_reckon(dvl, GyroSamples(tg[:1], np.asarray(gyro.value)[:1]), dep, cfg)
    with pytest.raises(NavigationError, match="outside"):
        traj.pose_at(1e6)


def test_pose_interpolation_slerp_and_linear() -> None:
    t = np.array([0.0, 1.0, 2.0])
    traj = Trajectory.from_euler(t, np.array([[0, 0, 5], [2, 0, 5], [2, 4, 7]]), D([179.0, -179.0, -170.0]),
                                 np.zeros(3), np.array([0, D(10), 0]))
    pos, rot = traj.pose_at([0.5, 1.5, 1.25])
    assert np.allclose(pos, np.array([[1, 0, 5], [2, 2, 6], [2, 1, 5.5]]))
    yaw, _, roll = euler(rot)
    assert np.isclose(abs(yaw[0]), np.pi)  # through the wrap, not through 0
    assert np.isclose(roll[0], D(5), atol=1e-3)
    # slerp, not nearest: a quarter of the way from 1 s to 2 s
    assert np.isclose(np.rad2deg(yaw[2]), -176.75, atol=0.05)


@settings(max_examples=60, deadline=None)
@given(st.floats(-720, 720), st.floats(-179, 179), st.floats(0, 1))
def test_heading_wrap_slerp_takes_short_way(y0: float, dy: float, f: float) -> None:
    traj = Trajectory.from_euler([0.0, 1.0], np.zeros((2, 3)), D([y0, y0 + dy]), [0, 0], [0, 0])
    _, rot = traj.pose_at(f)
    expect = attitude(D(y0 + f * dy), 0.0, 0.0)
    assert (rot * expect.inv()).magnitude()[0] < 1e-9


def test_mounting_default_is_rdi() -> None:
    assert isinstance(NavConfig().dvl_mounting, Mounting)
