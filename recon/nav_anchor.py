"""GNSS anchoring of dead reckoning: the start anchor from the surface fixes before the dive, the closure
error from the fixes after surfacing, and its correction distributed linearly in time.

Dead reckoning (:mod:`recon.nav`, :mod:`recon.nav_stream`) starts at (0, 0) at its first sample: its
frame D is W shifted by an unknown horizontal offset. Each GNSS fix (antenna position in W, NED m,
converted from WGS84 by the caller) taken while the vehicle is at the surface gives one estimate of
that offset, the *residual* ``r = fix - (p_D(t) + R_WB(t) lever)`` (horizontal; ``lever`` = the
antenna in the body frame, so the fixes of a vehicle that moves or rolls on the surface agree).

- **Before the dive** (until the first depth sample deeper than ``dive_depth_m``, at ``t_dive``) every
  accepted fix is a *pre-dive* fix; the anchor is the mean of their residuals within a robust gate of
  their median (``gate_sigmas x 1.4826 MAD``, within [``gate_m``, ``max_gate_m``]), once at least
  ``min_fixes`` are inliers (fewer: no anchor rather than a bad one).
  ``p_W = p_D + anchor``.
- **After surfacing** (fixes after ``t_dive`` while the navigation depth is above ``surface_depth_m``)
  the same robust mean of ``fix - (p_D + anchor + R lever)`` is the *closure error* ``c``: where dead
  reckoning had drifted to, at ``t_closure``, the mean time of those fixes. The correction applied at
  time t is ``c x clip((t - t_dive) / (t_closure - t_dive), 0, 1)``: zero at the dive, the whole
  closure at the surface, linear in time in between (dead reckoning
  drift from a heading or scale error grows about linearly with distance, and the survey speed is
  constant, so time and distance give nearly the same weights).
- Without an anchor but with fixes after surfacing, those fixes give the anchor alone (a constant
  offset; no drift correction). Without any accepted fix, D stays the frame: positions are relative
  to the first navigation sample, and :meth:`GnssAnchor.frame` says so.

**What dead reckoning allows.** Between the dive and the fixes after surfacing, dead reckoning drifts
by at most :func:`drift_bound_m`: ``closure_base_m`` (the fix scatter: each anchor is a mean of fixes
within ``max_gate_m`` of their median, so two anchors differ by at most twice that) plus the distance
travelled (dead-reckoned path, m) x (DVL scale accuracy + sin(start heading error + gyro bias drift x
mission time)) plus, for the time the DVL had no bottom (dead reckoning without velocity), that time x
the fastest ground speed dead reckoning saw since the dive (at least ``unaided_speed_mps``): all of that
distance may be lost. A fix after surfacing whose residual is farther than that from the start anchor is not
used (``beyond_dead_reckoning``); when every such fix is (at least ``min_fixes``), the closure is
*refused*: no correction, the dead-reckoned track with the start anchor is kept, and :meth:`GnssAnchor.summary`
says so (``closure_refused``: the disagreement, the bound, the fixes).

Rejected fixes are counted by reason, never used: ``no_fix`` (quality 0 or an empty position),
``poor_hdop`` (HDOP above ``max_hdop``), ``submerged`` (a fix while the navigation says the antenna is
under water), ``before_navigation`` (no pose yet), ``outliers`` (outside the gate), ``later_dives``,
``beyond_dead_reckoning``; the caller counts more (:meth:`GnssAnchor.reject` takes any key: fix
qualities that are not measurements, implausible values). Only one dive / surface cycle is modelled:
fixes after the vehicle dives again are counted, not used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]
REASONS = ("no_fix", "poor_hdop", "submerged", "before_navigation", "outliers", "later_dives",
           "beyond_dead_reckoning")
#: DVL bottom-track velocity accuracy as a fraction of the distance travelled (Teledyne RDI Workhorse
#: Navigator 600 kHz data sheet: long-term accuracy +-0.2 % +-0.1 cm/s)
DVL_SCALE_ACCURACY = 0.002
#: start heading error, deg (Teledyne RDI Workhorse data sheet: internal flux-gate compass accuracy +-2 deg;
#: dead reckoning takes its start heading from the DVL compass, recon.nav_stream)
START_HEADING_ERROR_DEG = 2.0
#: gyro heading drift, deg/h (KVH DSP-1760 data sheet: bias instability 0.05 deg/h, taken as a steady drift)
GYRO_DRIFT_DEG_PER_H = 0.05


@dataclass(frozen=True)
class AnchorConfig:
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # antenna in the body frame FRD (m)
    surface_depth_m: float = 1.0  # a fix counts while the navigation depth is above this
    dive_depth_m: float = 2.0  # deeper than this: the vehicle has left the surface
    max_hdop: float = 5.0
    gate_m: float = 2.0  # smallest outlier gate around the median (m)
    max_gate_m: float = 10.0  # largest: fixes that scatter more than this are not a position
    gate_sigmas: float = 5.0
    min_fixes: int = 3
    closure_base_m: float = 20.0  # the fix scatter allowed between two anchors: twice max_gate_m
    unaided_speed_mps: float = 1.5  # the least speed assumed without bottom track (a survey AUV's cruise speed)


def drift_bound_m(distance_m: float, duration_s: float, cfg: AnchorConfig, unaided_m: float = 0.0) -> float:
    """The most dead reckoning can drift (m) over ``distance_m`` travelled in ``duration_s`` (module doc), plus
    ``unaided_m``: what the vehicle may have travelled while the DVL had no bottom (all of it may be lost)."""
    heading = math.radians(START_HEADING_ERROR_DEG + GYRO_DRIFT_DEG_PER_H * max(duration_s, 0.0) / 3600.0)
    aided = max(distance_m, 0.0) * (DVL_SCALE_ACCURACY + math.sin(min(heading, math.pi / 2)))
    return cfg.closure_base_m + aided + max(unaided_m, 0.0)


def robust_mean(r: F64, cfg: AnchorConfig) -> tuple[F64 | None, NDArray[np.bool_]]:
    """Mean of the rows of ``r`` (n, 2) (or (n, 3)) within the gate of their median (m), and the inlier mask
    (None: fewer than ``min_fixes`` inliers)."""
    if r.shape[0] == 0:
        return None, np.zeros(0, bool)
    med = np.median(r, axis=0)
    dist = np.linalg.norm(r - med, axis=1)
    gate = min(cfg.max_gate_m, max(cfg.gate_m, cfg.gate_sigmas * 1.4826 * float(np.median(dist))))
    inl = dist <= gate
    if int(inl.sum()) < cfg.min_fixes:
        return None, inl
    return np.asarray(r[inl].mean(axis=0), dtype=np.float64), inl


@dataclass
class _Fixes:
    t: list[float] = field(default_factory=list)
    r: list[tuple[float, float]] = field(default_factory=list)
    ne: list[tuple[float, float]] = field(default_factory=list)

    def add(self, t: float, r: F64, ne: F64) -> None:
        self.t.append(t)
        self.r.append((float(r[0]), float(r[1])))
        self.ne.append((float(ne[0]), float(ne[1])))

    def array(self) -> F64:
        return np.asarray(self.r, dtype=np.float64).reshape(-1, 2)


class GnssAnchor:
    """Feed depth samples and fixes in time order; read :attr:`offset`, :meth:`correction_at` (module doc)."""

    def __init__(self, config: AnchorConfig | None = None) -> None:
        self.config = config or AnchorConfig()
        self.t_dive: float | None = None
        self.pre = _Fixes()
        self.post = _Fixes()
        self.counts: dict[str, int] = {"received": 0, **{k: 0 for k in REASONS}}
        self.beyond = _Fixes()  # fixes after surfacing farther from the start anchor than dead reckoning allows
        self.bound_m: float | None = None  # the drift bound at the last fix after surfacing
        self.travelled_m: float | None = None  # the dead-reckoned path from the dive to that fix
        self.unaided_m = 0.0  # of which the vehicle may have gone this far without bottom track
        self._resurfaced_then_dived = False

    # ------------------------------------------------------------------ input
    def observe_depth(self, t: ArrayLike, depth: ArrayLike) -> None:
        """Navigation depth samples (s, m): the first one deeper than ``dive_depth_m`` ends the surface phase."""
        ta, da = np.asarray(t, dtype=np.float64).ravel(), np.asarray(depth, dtype=np.float64).ravel()
        deep = np.flatnonzero(da > self.config.dive_depth_m)
        if not deep.size:
            return
        if self.t_dive is None:
            self.t_dive = float(ta[deep[0]])
        elif self.post.t and float(ta[deep[-1]]) > self.post.t[-1]:
            self._resurfaced_then_dived = True

    def reject(self, reason: str, n: int = 1) -> None:
        """Count ``n`` fixes not used, for ``reason`` (one of :data:`REASONS`, or the caller's own key)."""
        self.counts["received"] += n
        self.counts[reason] = self.counts.get(reason, 0) + n

    def add_fix(self, t: float, fix_ne: ArrayLike, hdop: float, position_d: ArrayLike | None,
                rotation: Any = None, depth: float | None = None, travelled_m: float | None = None,
                unaided_m: float = 0.0) -> bool:
        """One fix with a position (antenna, W north/east m) at ``t``; ``position_d`` the dead-reckoned
        body position (frame D) at t and ``rotation`` R_WB (scipy, one) there, ``depth`` the navigation
        depth (m), ``travelled_m`` the dead-reckoned path (m) from the dive to t (None: not checked against
        :func:`drift_bound_m`) and ``unaided_m`` the distance the vehicle may have gone without bottom track
        in that time. Returns whether it was used."""
        cfg = self.config
        fix = np.asarray(fix_ne, dtype=np.float64).ravel()[:2]
        if not np.all(np.isfinite(fix)):
            self.reject("no_fix")
            return False
        if np.isfinite(hdop) and hdop > cfg.max_hdop:
            self.reject("poor_hdop")
            return False
        if position_d is None:
            self.reject("before_navigation")
            return False
        if depth is not None and depth > cfg.surface_depth_m:
            self.reject("submerged")
            return False
        if self._resurfaced_then_dived:
            self.reject("later_dives")
            return False
        p = np.asarray(position_d, dtype=np.float64).ravel()[:2]
        lever = np.asarray(cfg.lever_arm, dtype=np.float64)
        arm = np.asarray(rotation.apply(lever), dtype=np.float64).ravel()[:2] if rotation is not None and \
            np.any(lever) else np.zeros(2)
        self.counts["received"] += 1
        r = fix - p - arm
        if self.t_dive is None or t < self.t_dive:
            self.pre.add(t, r, fix)
            return True
        start = self.start_anchor
        if start is not None and travelled_m is not None:
            self.bound_m = drift_bound_m(travelled_m, t - self.t_dive, cfg, unaided_m)
            self.travelled_m, self.unaided_m = travelled_m, unaided_m
            if float(np.hypot(*(r - start))) > self.bound_m:
                self.counts["beyond_dead_reckoning"] += 1
                self.beyond.add(t, r, fix)
                return False
        self.post.add(t, r, fix)
        return True

    # ------------------------------------------------------------------ output
    @property
    def start_anchor(self) -> F64 | None:
        """The offset D -> W from the pre-dive fixes (north, east m), or None."""
        off, _ = robust_mean(self.pre.array(), self.config)
        return off

    @property
    def offset(self) -> F64 | None:
        """The offset D -> W in use: the start anchor, else (surfacing only) the post-surfacing fixes'."""
        start = self.start_anchor
        if start is not None:
            return start
        off, _ = robust_mean(self.post.array(), self.config)
        return off

    @property
    def closure(self) -> F64 | None:
        """The closure error (north, east m) after surfacing, relative to the start anchor; None without both."""
        start = self.start_anchor
        if start is None or self.t_dive is None:
            return None
        off, _ = robust_mean(self.post.array(), self.config)
        return None if off is None else off - start

    @property
    def closure_refused(self) -> dict[str, Any] | None:
        """The closure the fixes after surfacing would give when every one of them is beyond what dead
        reckoning allows (module doc): ``closure_ne_m``, ``closure_m``, ``bound_m``, ``fixes``; else None."""
        start = self.start_anchor
        off, inl = robust_mean(self.beyond.array(), self.config)
        if start is None or off is None or self.closure is not None:
            return None
        c = off - start
        return {"closure_ne_m": [float(v) for v in c], "closure_m": float(np.hypot(*c)), "bound_m": self.bound_m,
                "travelled_m": self.travelled_m, "unaided_m": self.unaided_m, "fixes": int(inl.sum())}

    @property
    def t_surfaced(self) -> float | None:
        """Time of the first fix after surfacing."""
        return self.post.t[0] if self.post.t else None

    @property
    def t_closure(self) -> float | None:
        """The time the closure error refers to: the mean time of the post-surfacing inlier fixes."""
        _, inl = robust_mean(self.post.array(), self.config)
        return float(np.mean(np.asarray(self.post.t)[inl])) if inl.any() else None

    def correction_at(self, t: ArrayLike) -> F64:
        """The drift correction (n, 2) to add at times ``t`` (zeros without a closure)."""
        ta = np.atleast_1d(np.asarray(t, dtype=np.float64))
        c, t_ref = self.closure, self.t_closure
        if c is None or self.t_dive is None or t_ref is None:
            return np.zeros((ta.size, 2))
        span = max(t_ref - self.t_dive, 1e-9)
        w = np.clip((ta - self.t_dive) / span, 0.0, 1.0)
        return w[:, None] * c[None, :]

    def frame(self) -> str:
        """``"site"`` (anchored to the fixes), or ``"first_navigation_sample"`` (no usable fix)."""
        return "site" if self.offset is not None else "first_navigation_sample"

    def summary(self) -> dict[str, Any]:
        """Counts, the anchor and the closure, for ``summary.json``."""
        cfg = self.config
        pre_off, pre_in = robust_mean(self.pre.array(), cfg)
        post_off, post_in = robust_mean(self.post.array(), cfg)
        outliers = int((~pre_in).sum()) + int((~post_in).sum())
        counts = {**self.counts, "outliers": self.counts["outliers"] + outliers,
                  "used_before_dive": int(pre_in.sum()) if pre_off is not None else 0,
                  "used_after_surfacing": int(post_in.sum()) if post_off is not None else 0}
        closure, refused = self.closure, self.closure_refused
        return {
            "frame": self.frame(),
            "start_anchor_ne_m": None if pre_off is None else [float(v) for v in pre_off],
            "offset_ne_m": None if self.offset is None else [float(v) for v in self.offset],
            "closure_ne_m": None if closure is None else [float(v) for v in closure],
            "closure_m": None if closure is None else float(np.hypot(*closure)),
            "t_dive_s": self.t_dive, "t_surfaced_s": self.t_surfaced, "t_closure_s": self.t_closure,
            "correction": "linear in time from the dive to the fixes after surfacing" if closure is not None
            else "refused (beyond what dead reckoning can drift): the dead-reckoned track is kept" if refused
            else "none",
            "closure_bound_m": self.bound_m, "closure_refused": refused,
            "fixes": counts,
        }
