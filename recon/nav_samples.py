"""The navigation sensors' samples as recon takes them (:class:`DvlSamples`, :class:`GyroSamples`,
:class:`DepthSamples`), and the same samples checked and cleaned for dead reckoning (:func:`dvl_columns`,
:func:`gyro_columns`, :func:`depth_columns`): sorted by time, non-finite times and duplicate timestamps dropped,
a :class:`~recon.errors.NavigationError` naming what is missing when too few usable samples remain.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.errors import NavigationError
from recon.frames import VelocityFrame

F64 = NDArray[np.float64]


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


class DvlColumns(NamedTuple):
    """The DVL ensembles, cleaned and sorted: times (s), velocity (n, 3), validity, altitude, attitude, heading."""

    t: F64
    vel: F64
    alt: F64
    pitch: F64
    roll: F64
    heading: F64
    ok: NDArray[np.bool_]  # valid velocity
    att_ok: NDArray[np.bool_]  # finite pitch and roll


def dvl_columns(dvl: DvlSamples) -> DvlColumns:
    """The DVL ensembles checked (:class:`~recon.errors.NavigationError` naming what is missing) and cleaned."""
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
    return DvlColumns(tv, vel, alt, pitch, roll, heading, ok, att_ok)


def gyro_columns(gyro: GyroSamples) -> tuple[F64, F64]:
    """The gyro samples checked and cleaned: times (s) and values (n, 1) or (n, 3)."""
    graw = np.asarray(gyro.value, dtype=np.float64)
    g2 = graw.reshape(graw.shape[0], -1)
    if g2.shape[1] not in (1, 3):
        raise NavigationError(f"gyro values must be (n,) or (n, 3), got {graw.shape}")
    tg, g2 = _clean(gyro.t, g2)
    fin = np.all(np.isfinite(g2), axis=1)
    tg, g2 = tg[fin], g2[fin]
    if tg.size < 2:
        raise NavigationError("need at least 2 finite gyro samples")
    return tg, g2


def depth_columns(depth: DepthSamples) -> tuple[F64, F64]:
    """The pressure samples checked and cleaned: times (s) and absolute pressure (Pa)."""
    td, pres = _clean(depth.t, np.asarray(depth.pressure_pa, dtype=np.float64))
    fin = np.isfinite(pres)
    td, pres = td[fin], pres[fin]
    if td.size < 1:
        raise NavigationError("need at least 1 finite pressure sample")
    return td, pres
