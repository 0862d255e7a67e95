"""Helpers of :mod:`recon.nav_stream`: the grid-history table, zero-order-hold lookup, the
constant-rate-turn displacement (the formula of :mod:`recon.nav`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

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
