"""Helpers of :mod:`recon.nav_stream`: the grid-history table, zero-order-hold lookup, the
constant-rate-turn displacement (the formula of :mod:`recon.nav`), gyro samples as rates, the start heading offset."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.frames import Mounting, attitude, rdi_earth_to_ned, to_body

F64 = NDArray[np.float64]



class Grow:
    """A growing (n, k) float64 table with amortised appends."""

    def __init__(self, k: int) -> None:
        self._a = np.zeros((1024, k))
        self.n = 0

    def extend(self, rows: F64) -> None:
        need = self.n + rows.shape[0]
        if need > self._a.shape[0]:
            grown = np.zeros((max(need, 2 * self._a.shape[0]), self._a.shape[1]))
            grown[: self.n] = self._a[: self.n]
            self._a = grown
        self._a[self.n : need] = rows
        self.n = need

    @property
    def view(self) -> F64:
        return self._a[: self.n]


def zoh(t_src: F64, v_src: F64, t_query: F64, carry: F64) -> F64:
    """Value of the last source sample at or before each query time (``carry`` before the first)."""
    j = np.searchsorted(t_src, t_query, side="right") - 1
    out = v_src[np.clip(j, 0, max(t_src.size - 1, 0))] if t_src.size else np.broadcast_to(carry, (t_query.size,)
                                                                                              + carry.shape)
    return np.where((j >= 0).reshape((-1,) + (1,) * (np.ndim(carry))), out, carry)


def turn(psi0: F64, dpsi: F64, w: F64) -> F64:
    """Horizontal displacement per unit time: Rz(psi0) [[sinc, -cosc], [cosc, sinc]] w."""
    sinc = np.sinc(dpsi / np.pi)
    cosc = np.sin(0.5 * dpsi) * np.sinc(0.5 * dpsi / np.pi)
    lx = sinc * w[:, 0] - cosc * w[:, 1]
    ly = cosc * w[:, 0] + sinc * w[:, 1]
    c, s = np.cos(psi0), np.sin(psi0)
    return np.stack([c * lx - s * ly, s * lx + c * ly], axis=1)


def rate_like(graw: F64, pitch: F64, roll: F64) -> F64:
    """Heading rate from body rates (n, 3): (q sin(roll) + r cos(roll)) / cos(pitch)."""
    return np.asarray((graw[:, 1] * np.sin(roll) + graw[:, 2] * np.cos(roll)) / np.cos(pitch), dtype=np.float64)


def body_velocity(v: F64, frame: str, mounting: Mounting, graw: F64, psi: F64, pitch: F64, roll: F64) -> F64:
    """Vehicle velocity over ground from DVL velocities ``v`` (already sign-corrected): body FRD for
    body-fixed frames, NED for earth frames; the lever arm removed, v - omega x l (omega: body rates)."""
    lever = mounting.lever
    if frame in ("earth", "ned"):
        out = rdi_earth_to_ned(v) if frame == "earth" else v
        if np.any(lever):
            out = out - attitude(psi, pitch, roll).apply(np.cross(np.nan_to_num(graw), lever))
        return np.asarray(out, dtype=np.float64)
    out = to_body(v, frame, mounting)  # type: ignore[arg-type]
    if np.any(lever):
        out = out - np.cross(np.nan_to_num(graw), lever)
    return np.asarray(out, dtype=np.float64)


def level(vb: F64, frame: str, pitch: F64, roll: F64) -> F64:
    """Horizontal part of the velocity in the level frame (heading not applied); NED as is."""
    if frame in ("earth", "ned"):
        return vb[:, :2]
    return np.asarray(attitude(np.zeros_like(pitch), pitch, roll).apply(vb), dtype=np.float64)[:, :2]


def heading_offset(heading: F64, t_heading: F64, gyro_heading: F64, grid_t: F64, heading_sum: complex,
                   previous: float) -> tuple[F64, complex]:
    """The start heading offset (rad) at each of ``grid_t``: the circular mean so far of the compass ``heading``
    (rad, at ``t_heading``, s) less the gyro-integrated heading ``gyro_heading`` at those times, continued from
    the running sum ``heading_sum`` (``previous`` before the first of them). Returns the offsets and the new sum."""
    if heading.size == 0:
        return np.full(grid_t.size, previous), heading_sum
    csum = np.cumsum(np.r_[heading_sum, np.exp(1j * (heading - gyro_heading))])[1:]
    j = np.searchsorted(t_heading, grid_t, side="right") - 1
    return np.where(j >= 0, np.angle(csum[np.clip(j, 0, None)]), previous), complex(csum[-1])


def gyro_rates(t: ArrayLike, value: ArrayLike, kind: str, t_previous: float) -> tuple[F64, F64]:
    """Gyro samples as body rates: times (n,) s and rates (n, 3) rad/s (a single-axis gyro fills z; a
    ``delta`` gyro's increments become the mean rate since the previous sample, ``t_previous`` before the
    first); samples with a non-finite time or rate are left out."""
    tg = np.asarray(t, dtype=np.float64)
    g = np.asarray(value, dtype=np.float64).reshape(tg.size, -1 if tg.size else 1)
    graw = np.zeros((tg.size, 3))
    if g.shape[1] == 3:
        graw[:] = g
    else:
        graw[:, 2] = g[:, 0]
    if kind == "delta":
        dt = tg - np.r_[t_previous, tg[:-1]]
        graw = np.where((np.isfinite(dt) & (dt > 0))[:, None], graw / np.where(dt > 0, dt, 1.0)[:, None], np.nan)
    keep = np.all(np.isfinite(graw), axis=1) & np.isfinite(tg)
    return tg[keep], graw[keep]
