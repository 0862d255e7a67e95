"""Dead reckoning from DVL bottom track, a heading gyro and a pressure sensor.

Inputs are plain arrays (one :class:`DvlSamples`, :class:`GyroSamples`, :class:`DepthSamples`),
SI units, angles in radians. The output is a :class:`recon.trajectory.Trajectory` on the union of
the gyro and DVL sample times (the span both cover).

- Streams are sorted by time (stable) and duplicate timestamps dropped (the first kept).
- Heading: the gyro's body rate is turned into a heading rate, psi' = (q sin(roll) + r cos(roll)) /
  cos(pitch) (q = 0 for a single-axis gyro), and integrated: trapezoid for instantaneous rates,
  a plain cumulative sum for delta angles (each the increment since the previous sample). The start
  value comes from the DVL compass: the circular mean, over the first ``heading_init_s``, of the DVL
  heading minus the gyro-integrated heading change (one noisy compass sample would tilt every line).
  Between gyro samples the rate is constant.
- Velocity: DVL velocity converted once to FRD (ship/instrument, through the mounting) or NED
  (earth); PD0 bottom track is negated (bottom relative to instrument -> vehicle over ground); the
  lever arm is removed, v_origin = v_dvl - omega x l. During a dropout (invalid samples or a time gap
  longer than ``max_interp_gap_s``) the last valid velocity is held; poses more than
  ``dropout_hold_s`` after the last valid velocity are flagged ``degraded``.
- Horizontal position: per interval, the level-frame velocity w = Ry(pitch) Rx(roll) v_B (mean of
  the two ends) is rotated by the heading integrated exactly over a constant-rate turn:
  dp = Rz(psi0) [[sinc, -cosc], [cosc, sinc]] w dt, sinc = sin(d)/d, cosc = (1 - cos d)/d, d = dpsi.
  Exact for straight lines and constant-rate turns at constant speed; np.cumsum, no Python loop.
- Depth from pressure (hydrostatic, constant density): z = (p - p_atm) / (rho g), rho = 1025 kg/m^3,
  g = 9.80665 m/s^2, p_atm = 101325 Pa by default. With a real water column (UNESCO 1983) the
  constant-density error stays below ~0.3 % in the upper 100 m; set ``seawater_density`` to the
  site's mean density for better.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.errors import NavigationError
from recon.frames import (
    Mounting,
    attitude,
    dvl_seabed_offsets,
    rdi_earth_to_ned,
    rdi_instrument_mounting,
    to_body,
)
from recon.nav_samples import (
    DepthSamples,
    DvlColumns,
    DvlSamples,
    GyroSamples,
    depth_columns,
    dvl_columns,
    gyro_columns,
)
from recon.trajectory import Trajectory

__all__ = ["DepthSamples", "DvlSamples", "GyroSamples", "NavConfig", "dead_reckon", "pressure_to_depth"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class NavConfig:
    dvl_mounting: Mounting = field(default_factory=rdi_instrument_mounting)
    depth_lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    seawater_density: float = 1025.0  # kg/m^3
    gravity: float = 9.80665  # m/s^2
    atmospheric_pa: float = 101325.0
    dropout_hold_s: float = 2.0  # hold the last DVL velocity this long, then flag degraded
    max_interp_gap_s: float = 1.0  # interpolate between valid DVL samples closer than this
    gyro_gap_s: float = 1.0  # gyro gaps longer than this flag the poses inside degraded
    depth_gap_s: float = 2.0
    initial_position: tuple[float, float] = (0.0, 0.0)  # north, east at the first pose (m)
    initial_heading: float | None = None  # rad; None = from the DVL headings (see heading_init_s)
    heading_init_s: float = 60.0  # s of DVL headings averaged (against the gyro) for the start heading


def pressure_to_depth(pressure_pa: ArrayLike, density: float = 1025.0, gravity: float = 9.80665,
                      atmospheric_pa: float = 101325.0) -> F64:
    """Depth (m) from absolute pressure: (p - p_atm) / (rho g), hydrostatic, constant density."""
    return (np.asarray(pressure_pa, dtype=np.float64) - atmospheric_pa) / (density * gravity)


def _gap_flag(grid: F64, t: F64, max_gap: float) -> NDArray[np.bool_]:
    """True for grid times inside a sample gap longer than ``max_gap`` (or outside coverage)."""
    if t.size == 0:
        return np.ones(grid.shape, bool)
    j = np.searchsorted(t, grid, side="left")
    outside = (grid < t[0]) | (grid > t[-1])
    jc = np.clip(j, 1, t.size - 1)
    gap = (t[jc] - t[jc - 1]) > max_gap
    on_sample = (j < t.size) & (t[np.minimum(j, t.size - 1)] == grid)
    return outside | (gap & ~on_sample)


def dead_reckon(dvl: DvlSamples, gyro: GyroSamples, depth: DepthSamples,
                config: NavConfig | None = None) -> Trajectory:
    """Integrate the navigation sensors into a :class:`Trajectory` (see the module docstring)."""
    cfg = config or NavConfig()
    d = dvl_columns(dvl)
    tg, g2 = gyro_columns(gyro)
    td, pres = depth_columns(depth)
    t0, t1 = max(tg[0], d.t[0]), min(tg[-1], d.t[-1])
    if not t1 > t0:
        raise NavigationError(f"gyro [{tg[0]}, {tg[-1]}] and DVL [{d.t[0]}, {d.t[-1]}] do not overlap")
    grid = np.union1d(tg, d.t)
    grid = grid[(grid >= t0) & (grid <= t1)]
    # attitude from the DVL (pitch, roll), heading from the gyro
    psi = _heading(grid, d, tg, g2, gyro.kind, cfg)
    ta = d.t[d.att_ok]
    pitch_w = np.interp(grid, ta, d.pitch[d.att_ok])
    roll_w = np.interp(grid, ta, d.roll[d.att_ok])
    rot = attitude(psi, pitch_w, roll_w)
    earth = dvl.frame in ("earth", "ned")
    v_grid, degraded = _velocity_on_grid(grid, psi, d, dvl, tg, g2, gyro.kind, cfg)
    pos = np.zeros((grid.size, 3))
    pos[:, :2] = np.asarray(cfg.initial_position, dtype=np.float64)
    pos[1:, :2] += np.cumsum(_displacements(grid, v_grid, psi, pitch_w, roll_w, earth), axis=0)
    z = pressure_to_depth(np.interp(grid, td, pres), cfg.seawater_density, cfg.gravity, cfg.atmospheric_pa)
    dlever = np.asarray(cfg.depth_lever_arm, dtype=np.float64)
    pos[:, 2] = z - (rot.apply(dlever)[:, 2] if np.any(dlever) else 0.0)
    degraded |= _gap_flag(grid, tg, cfg.gyro_gap_s) | _gap_flag(grid, td, cfg.depth_gap_s)
    altitude, offsets = _altitude(grid, rot, d, cfg)
    return Trajectory(grid, pos, rot, degraded=degraded, altitude=altitude, seabed_offsets=offsets)


def _heading(grid: F64, d: DvlColumns, tg: F64, g2: F64, kind: str, cfg: NavConfig) -> F64:
    """Heading (rad) on ``grid``: the gyro integrated, offset to the compass (or ``initial_heading``)."""
    ta = d.t[d.att_ok]
    pitch_g = np.interp(tg, ta, d.pitch[d.att_ok])
    roll_g = np.interp(tg, ta, d.roll[d.att_ok])
    factor = np.cos(roll_g) / np.cos(pitch_g)
    if g2.shape[1] == 3:
        rate_like = (g2[:, 1] * np.sin(roll_g) + g2[:, 2] * np.cos(roll_g)) / np.cos(pitch_g)
    else:
        rate_like = g2[:, 0] * factor
    if kind == "rate":
        psi_g = np.r_[0.0, np.cumsum(0.5 * (rate_like[1:] + rate_like[:-1]) * np.diff(tg))]
    else:
        psi_g = np.r_[0.0, np.cumsum(rate_like[1:])]
    psi = np.interp(grid, tg, psi_g)
    if cfg.initial_heading is not None:
        psi0 = float(cfg.initial_heading)
    else:
        hok = np.isfinite(d.heading) & (d.t >= grid[0]) & (d.t <= grid[0] + cfg.heading_init_s)
        if not hok.any():
            hok = np.isfinite(d.heading)
        if not hok.any():
            raise NavigationError("no DVL heading to initialise the gyro heading (set initial_heading)")
        # the compass is noisy (~0.5 deg), the gyro is not: estimate the constant offset between the
        # two as the circular mean over the first ``heading_init_s`` of DVL headings
        offset = d.heading[hok] - (np.interp(d.t[hok], grid, psi) - psi[0])
        psi0 = float(np.angle(np.mean(np.exp(1j * offset))))
    return np.asarray(psi + (psi0 - psi[0]), dtype=np.float64)


def _velocity_on_grid(grid: F64, psi: F64, d: DvlColumns, dvl: DvlSamples, tg: F64, g2: F64, kind: str,
                      cfg: NavConfig) -> tuple[F64, NDArray[np.bool_]]:
    """The velocity of the vehicle origin on ``grid`` (body FRD, or NED for earth frames), interpolated between
    consecutive valid ensembles and held through dropouts; and where it was held longer than ``dropout_hold_s``."""
    v_meas = -d.vel if dvl.bottom_track else d.vel
    earth = dvl.frame in ("earth", "ned")
    vsel = v_meas[d.ok]
    if earth:
        v_at = rdi_earth_to_ned(vsel) if dvl.frame == "earth" else vsel
    else:
        v_at = to_body(vsel, dvl.frame, cfg.dvl_mounting)
    tok = d.t[d.ok]
    raw_idx = np.flatnonzero(d.ok)
    lever = cfg.dvl_mounting.lever
    if np.any(lever):  # v_origin = v_dvl - omega x l, at the DVL sample times
        cross = np.cross(_body_rate(tok, tg, g2, kind), lever)
        if earth:
            ta = d.t[d.att_ok]
            rot_v = attitude(np.interp(tok, grid, psi), np.interp(tok, ta, d.pitch[d.att_ok]),
                             np.interp(tok, ta, d.roll[d.att_ok]))
            cross = rot_v.apply(cross)
        v_at = v_at - cross
    i = np.searchsorted(tok, grid, side="right") - 1
    ic = np.clip(i, 0, tok.size - 1)
    jn = np.clip(i + 1, 0, tok.size - 1)
    consecutive = (raw_idx[jn] == raw_idx[ic] + 1) & (tok[jn] - tok[ic] <= cfg.max_interp_gap_s) & (i >= 0)
    consecutive &= i + 1 < tok.size
    span = np.where(consecutive, tok[jn] - tok[ic], 1.0)
    w = np.where(consecutive, (grid - tok[ic]) / span, 0.0)
    v_grid = (1.0 - w)[:, None] * v_at[ic] + w[:, None] * v_at[jn]
    since = np.where(i >= 0, grid - tok[ic], np.inf)
    since = np.where(consecutive, 0.0, since)
    return v_grid, since > cfg.dropout_hold_s


def _displacements(grid: F64, v_grid: F64, psi: F64, pitch: F64, roll: F64, earth: bool) -> F64:
    """Horizontal NED displacement (m) over each grid step: trapezoid for earth-frame velocities, else the
    level-frame velocity integrated exactly over a constant-rate turn."""
    dt = np.diff(grid)
    if earth:
        return np.asarray(0.5 * (v_grid[1:, :2] + v_grid[:-1, :2]) * dt[:, None], dtype=np.float64)
    lvl = attitude(np.zeros_like(grid), pitch, roll).apply(v_grid)
    wbar = 0.5 * (lvl[1:, :2] + lvl[:-1, :2])
    dpsi = np.diff(psi)
    sinc = np.sinc(dpsi / np.pi)
    cosc = np.sin(0.5 * dpsi) * np.sinc(0.5 * dpsi / np.pi)
    lx = sinc * wbar[:, 0] - cosc * wbar[:, 1]
    ly = cosc * wbar[:, 0] + sinc * wbar[:, 1]
    c, s = np.cos(psi[:-1]), np.sin(psi[:-1])
    return np.stack([c * lx - s * ly, s * lx + c * ly], axis=1) * dt[:, None]


def _altitude(grid: F64, rot: Rotation, d: DvlColumns, cfg: NavConfig) -> tuple[F64, F64]:
    """Altitude (m, vehicle origin) on ``grid`` while the bottom lock is fresh (NaN otherwise), and the DVL's
    seabed offsets (:func:`recon.frames.dvl_seabed_offsets`)."""
    aok = np.isfinite(d.alt) & (d.alt > 0) & d.ok  # bottom lock: the same validity as the velocity
    altitude = np.full(grid.size, np.nan)
    if aok.any():
        taa = d.t[aok]
        k = np.searchsorted(taa, grid, side="right") - 1
        fresh = (k >= 0) & (grid - taa[np.clip(k, 0, None)] <= cfg.dropout_hold_s)
        altitude = np.where(fresh, np.interp(grid, taa, d.alt[aok]), np.nan)
    offsets = dvl_seabed_offsets(rot, altitude, cfg.dvl_mounting)  # the altitude as the DVL measured it (NaN: none)
    lever = cfg.dvl_mounting.lever
    if np.any(lever):
        altitude = altitude + rot.apply(lever)[:, 2]
    return altitude, offsets


def _body_rate(t: F64, tg: F64, g2: F64, kind: str) -> F64:
    """Body angular rate (n, 3) at times ``t``: linear between rate samples, or the piecewise-constant
    mean rate of delta-angle samples (a delta covers (t_{i-1}, t_i]). A single-axis gyro gives z only."""
    if kind == "rate":
        w = np.stack([np.interp(t, tg, g2[:, k]) for k in range(g2.shape[1])], axis=1)
    else:
        rates = g2[1:] / np.diff(tg)[:, None]
        k = np.clip(np.searchsorted(tg, t, side="left"), 1, tg.size - 1)
        w = rates[k - 1]
    if w.shape[1] == 3:
        return w
    out = np.zeros((t.size, 3))
    out[:, 2] = w[:, 0]
    return out
