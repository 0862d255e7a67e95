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
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.errors import NavigationError
from recon.frames import (
    Mounting,
    VelocityFrame,
    attitude,
    dvl_seabed_offsets,
    rdi_earth_to_ned,
    rdi_instrument_mounting,
    to_body,
)
from recon.trajectory import Trajectory

F64 = NDArray[np.float64]


def _arr(x: ArrayLike | None, n: int, name: str, fill: float = np.nan) -> F64:
    if x is None:
        return np.full(n, fill)
    a = np.asarray(x, dtype=np.float64)
    if a.shape[:1] != (n,):
        raise NavigationError(f"{name} has {a.shape[:1]} values for {n} times")
    return a


def _clean(t: ArrayLike, *cols: F64) -> tuple[F64, ...]:
    """Sort by time (stable), drop non-finite times and duplicate timestamps (keep the first)."""
    ta = np.asarray(t, dtype=np.float64)
    order = np.argsort(ta, kind="stable")
    order = order[np.isfinite(ta[order])]
    ts = ta[order]
    keep = np.r_[True, np.diff(ts) > 0] if ts.size else np.zeros(0, bool)
    return (ts[keep], *(c[order][keep] for c in cols))


@dataclass(frozen=True, eq=False)
class DvlSamples:
    """DVL ensembles: time (s), velocity (n, 3) in ``frame``, validity, altitude (m), attitude (rad).

    ``bottom_track=True`` means the PD0 convention (bottom moving relative to the instrument).
    """

    t: ArrayLike
    velocity: ArrayLike
    frame: VelocityFrame = "instrument"
    valid: ArrayLike | None = None
    altitude: ArrayLike | None = None
    pitch: ArrayLike | None = None
    roll: ArrayLike | None = None
    heading: ArrayLike | None = None
    bottom_track: bool = True


@dataclass(frozen=True, eq=False)
class GyroSamples:
    """Gyro samples: ``value`` is the body z rate (n,) or body rates (n, 3) in rad/s for
    ``kind='rate'``, or angle increments (rad) since the previous sample for ``kind='delta'``."""

    t: ArrayLike
    value: ArrayLike
    kind: Literal["rate", "delta"] = "rate"


@dataclass(frozen=True, eq=False)
class DepthSamples:
    """Absolute pressure (Pa) at the pressure sensor."""

    t: ArrayLike
    pressure_pa: ArrayLike


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
    # --- DVL -------------------------------------------------------------------------------
    dt_raw = np.asarray(dvl.t, dtype=np.float64)
    n = dt_raw.shape[0]
    vel = np.asarray(dvl.velocity, dtype=np.float64)
    if vel.shape != (n, 3):
        raise NavigationError(f"DVL velocity must be ({n}, 3), got {vel.shape}")
    valid = np.ones(n, bool) if dvl.valid is None else np.asarray(dvl.valid, dtype=bool)
    cols = (vel, valid.astype(np.float64), _arr(dvl.altitude, n, "altitude"),
            _arr(dvl.pitch, n, "pitch", 0.0), _arr(dvl.roll, n, "roll", 0.0), _arr(dvl.heading, n, "heading"))
    tv, vel, vvalid, alt, pitch, roll, heading = _clean(dt_raw, *cols)
    ok = (vvalid > 0.5) & np.all(np.isfinite(vel), axis=1)
    att_ok = np.isfinite(pitch) & np.isfinite(roll)
    if tv.size < 2 or not ok.any() or att_ok.sum() < 1:
        raise NavigationError("need at least 2 DVL samples with one valid velocity and attitude")
    # --- gyro ------------------------------------------------------------------------------
    graw = np.asarray(gyro.value, dtype=np.float64)
    g2 = graw.reshape(graw.shape[0], -1)
    if g2.shape[1] not in (1, 3):
        raise NavigationError(f"gyro values must be (n,) or (n, 3), got {graw.shape}")
    tg, g2 = _clean(gyro.t, g2)
    fin = np.all(np.isfinite(g2), axis=1)
    tg, g2 = tg[fin], g2[fin]
    if tg.size < 2:
        raise NavigationError("need at least 2 finite gyro samples")
    # --- depth -----------------------------------------------------------------------------
    td, pres = _clean(depth.t, np.asarray(depth.pressure_pa, dtype=np.float64))
    fin = np.isfinite(pres)
    td, pres = td[fin], pres[fin]
    if td.size < 1:
        raise NavigationError("need at least 1 finite pressure sample")
    # --- time grid ---------------------------------------------------------------------------
    t0, t1 = max(tg[0], tv[0]), min(tg[-1], tv[-1])
    if not t1 > t0:
        raise NavigationError(f"gyro [{tg[0]}, {tg[-1]}] and DVL [{tv[0]}, {tv[-1]}] do not overlap")
    grid = np.union1d(tg, tv)
    grid = grid[(grid >= t0) & (grid <= t1)]
    # attitude from the DVL (pitch, roll), heading from the gyro
    ta = tv[att_ok]
    pitch_g = np.interp(tg, ta, pitch[att_ok])
    roll_g = np.interp(tg, ta, roll[att_ok])
    factor = np.cos(roll_g) / np.cos(pitch_g)
    if g2.shape[1] == 3:
        rate_like = (g2[:, 1] * np.sin(roll_g) + g2[:, 2] * np.cos(roll_g)) / np.cos(pitch_g)
    else:
        rate_like = g2[:, 0] * factor
    if gyro.kind == "rate":
        psi_g = np.r_[0.0, np.cumsum(0.5 * (rate_like[1:] + rate_like[:-1]) * np.diff(tg))]
    else:
        psi_g = np.r_[0.0, np.cumsum(rate_like[1:])]
    psi = np.interp(grid, tg, psi_g)
    if cfg.initial_heading is not None:
        psi0 = float(cfg.initial_heading)
    else:
        hok = np.isfinite(heading) & (tv >= grid[0]) & (tv <= grid[0] + cfg.heading_init_s)
        if not hok.any():
            hok = np.isfinite(heading)
        if not hok.any():
            raise NavigationError("no DVL heading to initialise the gyro heading (set initial_heading)")
        # the compass is noisy (~0.5 deg), the gyro is not: estimate the constant offset between the
        # two as the circular mean over the first ``heading_init_s`` of DVL headings
        offset = heading[hok] - (np.interp(tv[hok], grid, psi) - psi[0])
        psi0 = float(np.angle(np.mean(np.exp(1j * offset))))
    psi = psi + (psi0 - psi[0])
    pitch_w = np.interp(grid, ta, pitch[att_ok])
    roll_w = np.interp(grid, ta, roll[att_ok])
    rot = attitude(psi, pitch_w, roll_w)
    # --- velocity on the grid (hold through dropouts) ------------------------------------------
    v_meas = -vel if dvl.bottom_track else vel
    earth = dvl.frame in ("earth", "ned")
    vsel = v_meas[ok]
    if earth:
        v_at = rdi_earth_to_ned(vsel) if dvl.frame == "earth" else vsel
    else:
        v_at = to_body(vsel, dvl.frame, cfg.dvl_mounting)
    tok = tv[ok]
    raw_idx = np.flatnonzero(ok)
    lever = cfg.dvl_mounting.lever
    if np.any(lever):  # v_origin = v_dvl - omega x l, at the DVL sample times
        cross = np.cross(_body_rate(tok, tg, g2, gyro.kind), lever)
        if earth:
            rot_v = attitude(np.interp(tok, grid, psi), np.interp(tok, ta, pitch[att_ok]),
                             np.interp(tok, ta, roll[att_ok]))
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
    degraded = since > cfg.dropout_hold_s
    # --- integrate -------------------------------------------------------------------------------
    dt = np.diff(grid)
    if earth:
        d_n = 0.5 * (v_grid[1:, :2] + v_grid[:-1, :2]) * dt[:, None]
    else:
        lvl = attitude(np.zeros_like(grid), pitch_w, roll_w).apply(v_grid)
        wbar = 0.5 * (lvl[1:, :2] + lvl[:-1, :2])
        dpsi = np.diff(psi)
        sinc = np.sinc(dpsi / np.pi)
        cosc = np.sin(0.5 * dpsi) * np.sinc(0.5 * dpsi / np.pi)
        lx = sinc * wbar[:, 0] - cosc * wbar[:, 1]
        ly = cosc * wbar[:, 0] + sinc * wbar[:, 1]
        c, s = np.cos(psi[:-1]), np.sin(psi[:-1])
        d_n = np.stack([c * lx - s * ly, s * lx + c * ly], axis=1) * dt[:, None]
    pos = np.zeros((grid.size, 3))
    pos[:, :2] = np.asarray(cfg.initial_position, dtype=np.float64)
    pos[1:, :2] += np.cumsum(d_n, axis=0)
    z = pressure_to_depth(np.interp(grid, td, pres), cfg.seawater_density, cfg.gravity, cfg.atmospheric_pa)
    dlever = np.asarray(cfg.depth_lever_arm, dtype=np.float64)
    pos[:, 2] = z - (rot.apply(dlever)[:, 2] if np.any(dlever) else 0.0)
    # --- flags and altitude ------------------------------------------------------------------------
    degraded |= _gap_flag(grid, tg, cfg.gyro_gap_s) | _gap_flag(grid, td, cfg.depth_gap_s)
    aok = np.isfinite(alt) & (alt > 0) & ok  # bottom lock: the same validity as the velocity
    altitude = np.full(grid.size, np.nan)
    if aok.any():
        taa = tv[aok]
        k = np.searchsorted(taa, grid, side="right") - 1
        fresh = (k >= 0) & (grid - taa[np.clip(k, 0, None)] <= cfg.dropout_hold_s)
        altitude = np.where(fresh, np.interp(grid, taa, alt[aok]), np.nan)
    offsets = dvl_seabed_offsets(rot, altitude, cfg.dvl_mounting)  # the altitude as the DVL measured it (NaN: none)
    if np.any(lever):
        altitude = altitude + rot.apply(lever)[:, 2]
    return Trajectory(grid, pos, rot, degraded=degraded, altitude=altitude, seabed_offsets=offsets)


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
