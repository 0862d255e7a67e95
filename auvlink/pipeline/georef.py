"""The engine's georeferencing: GNSS fixes -> the anchor of dead reckoning, the site datum, lat/lon.

The engine feeds :class:`Georef` the navigation depth samples and the GNSS fixes (routed from the
``nmea`` device as :class:`GnssPayload` by :class:`auvlink.pipeline.nav_inputs.NavAdaptor`), in time
order, with the causal navigator for the pose at each fix. Every fix is gated first
(:func:`auvlink.codecs.nmea_checks.fix_rejection`): only a measured fix quality (GGA 1, 2, 4, 5; RMC
status A with such a mode) and a plausible position (latitude, longitude in range, HDOP > 0) go on;
the others are counted by kind (``no_fix``, ``quality_estimated``, ``quality_simulation``, ...,
``implausible``). :class:`recon.nav_anchor.GnssAnchor` does the anchoring (outliers against the robust
mean of a surface period, fixes after surfacing beyond what dead reckoning can drift, the closure
refused when it is). This class holds the datum: the vehicle configuration's ``[site]``; without one,
the mean of the first :data:`DATUM_FIXES` fixes that agree within the anchor's outlier gate of their
median (never a single fix; until then there is no datum and the fixes wait). It converts fixes to W
(PROJ, :mod:`auvlink.geodesy`) and positions of dead reckoning's frame D to W: ``p_W = p_D + offset``
(live: the start anchor) ``+ correction(t)`` (at the end: the closure error distributed over the
submerged track). Nothing here raises on a fix: a fix the conversion cannot take is counted
(``unconvertible``) and skipped.
"""

from __future__ import annotations

import math
import sys
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj.exceptions import ProjError

from auvlink.codecs.nmea_checks import fix_rejection
from auvlink.geodesy import Datum
from recon.nav_anchor import AnchorConfig, GnssAnchor, robust_mean

F64 = NDArray[np.float64]
#: fixes that make a datum without ``[site]``: the median / MAD gate of :func:`recon.nav_anchor.robust_mean`
#: outvotes up to 2 wild fixes of 5, and 5 s at the slowest receiver rate (1 Hz) fits every surface wait
DATUM_FIXES = 5
#: fixes kept waiting for a datum; older ones are dropped (counted ``outliers``) while the fixes disagree
DATUM_WINDOW = 4 * DATUM_FIXES


class GnssPayload(NamedTuple):
    latitude: float  # deg (NaN without a fix)
    longitude: float
    height: float  # m above the ellipsoid (NaN when unknown)
    quality: int  # GGA fix quality (RMC: the quality of its mode, auvlink.codecs.nmea_checks.RMC_MODE_QUALITY)
    hdop: float  # NaN when not sent


class _Pending(NamedTuple):
    t: float
    fix: GnssPayload
    pose: tuple[Any, Any] | None  # (position (1, 3) in D, R_WB) at t, None before navigation
    travelled: tuple[float, float] | None  # (dead-reckoned path, unaided distance) m since the dive


def gnss_payload(fmt_record: Any, seen_gga: bool) -> GnssPayload | None:
    """A GGA sentence (or, from a receiver that sends no GGA, an RMC) as a fix, values as sent (the gate is
    :meth:`Georef.on_fix`'s); other sentences: None."""
    from auvlink.codecs import nmea

    r = fmt_record
    if isinstance(r, nmea.GgaFix):
        return GnssPayload(r.latitude_deg, r.longitude_deg, r.ellipsoidal_height_m, r.quality, r.hdop)
    if isinstance(r, nmea.RmcFix) and not seen_gga:
        return GnssPayload(r.latitude_deg, r.longitude_deg, math.nan, r.quality, math.nan)
    return None


class Georef:
    """See the module docstring. ``site``: the configured datum (None: from the first fixes that agree)."""

    def __init__(self, site: Datum | None, lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 has_gnss: bool = False) -> None:
        self.datum = site
        self.datum_source = "vehicle configuration [site]" if site is not None else None
        self.has_gnss = has_gnss
        self.anchor = GnssAnchor(AnchorConfig(lever_arm=lever_arm))
        self.fixes_ne: list[tuple[float, float, float]] = []  # (t, north, east) of every fix the anchor took
        self._pending: list[_Pending] = []  # fixes waiting for a datum (no [site])
        self._path: tuple[float, float, F64] | None = None  # (t, path m since the dive, D position) at the last fix
        self._unaided = 0.0  # m the vehicle may have gone without bottom track from the dive to surfacing
        self._warned = False

    def on_depth(self, t: F64, depth: F64) -> None:
        self.anchor.observe_depth(t, depth)

    def on_fix(self, t: float, fix: GnssPayload, nav: Any) -> None:
        """One fix at mission time ``t`` (s): gated, then to the anchor (module docstring); never raises."""
        reason = fix_rejection(fix.quality, fix.latitude, fix.longitude, fix.hdop)
        if reason is not None:
            self.anchor.reject(reason)
            return
        pose = nav.pose_at(t) if nav.covered(t)[0] else None
        item = _Pending(t, fix, pose, self._travelled(t, pose, nav))
        if self.datum is None:
            self._pending.append(item)
            self._datum_from_pending()
            return
        self._use(item)

    def _travelled(self, t: float, pose: tuple[Any, Any] | None, nav: Any) -> tuple[float, float] | None:
        """Dead-reckoned path (m) from the dive to ``t`` (the navigator's track up to the first fix after the
        dive, then the chord from fix to fix, seconds apart on the surface), and the distance (m) the vehicle
        may have gone without bottom track in that time (navigator altitude stale: the time x the fastest
        dead-reckoned ground speed, at least the anchor's ``unaided_speed_mps``). None before the dive."""
        t_dive = self.anchor.t_dive
        if pose is None or t_dive is None or t < t_dive:
            return None
        p = np.asarray(pose[0], dtype=np.float64)[0, :2]
        if self._path is None:
            tg, pos = nav.positions(1)
            keep = (tg >= t_dive) & (tg <= t)
            tk, q = np.append(tg[keep], t), np.vstack([pos[keep, :2], p[None, :]])
            step, dt = np.hypot(*np.diff(q, axis=0).T), np.diff(tk)
            stale = ~np.isfinite(nav.altitude_at(tk[1:])) if dt.size else np.zeros(0, bool)
            speed = float(np.max(step / np.maximum(dt, 1e-3), initial=0.0))
            self._unaided = float(dt[stale].sum()) * max(speed, self.anchor.config.unaided_speed_mps)
            length = float(step.sum())
        else:
            t_last, length, p_last = self._path
            length += float(np.hypot(*(p - p_last))) if t >= t_last else 0.0
        self._path = (t, length, p)
        return length, self._unaided

    def _datum_from_pending(self) -> None:
        """The datum from the robust mean of the first DATUM_FIXES fixes that agree (module docstring)."""
        pend = self._pending
        if len(pend) < DATUM_FIXES:
            return
        # in the topocentric frame of the oldest fix (a rigid transform of ECEF: no trouble at the poles or
        # across the antimeridian), on the ellipsoid; the gate and the mean are 3D
        ref = Datum(pend[0].fix.latitude, pend[0].fix.longitude)
        ned = ref.to_ned([x.fix.latitude for x in pend], [x.fix.longitude for x in pend])
        off, inl = robust_mean(ned, self.anchor.config)
        if off is None or int(inl.sum()) < DATUM_FIXES:
            if len(pend) > DATUM_WINDOW:
                self.anchor.reject("outliers")
                del pend[0]
            return
        la, lo, _ = ref.to_geodetic(off)
        self.datum = Datum(round(float(la[0]), 7), round(float(lo[0]), 7), 0.0)
        self.datum_source = (f"the mean of the first {DATUM_FIXES} GNSS fixes that agree (the configuration "
                             "has no [site])")
        self._pending = []
        for item in pend:
            self._use(item)

    def _use(self, item: _Pending) -> None:
        assert self.datum is not None
        fix = item.fix
        try:
            ne = self.datum.to_ned(fix.latitude, fix.longitude, fix.height if math.isfinite(fix.height) else None)
        except (ProjError, ValueError, ArithmeticError):
            self.anchor.reject("unconvertible")
            return
        n, e = float(ne[0, 0]), float(ne[0, 1])
        if not (math.isfinite(n) and math.isfinite(e)):
            self.anchor.reject("unconvertible")
            return
        if item.pose is None:
            self.anchor.add_fix(item.t, (n, e), fix.hdop, None)
            return
        pos, rot = item.pose
        path, unaided = item.travelled if item.travelled is not None else (None, 0.0)
        if self.anchor.add_fix(item.t, (n, e), fix.hdop, pos[0], rot, depth=float(pos[0, 2]), travelled_m=path,
                               unaided_m=unaided):
            self.fixes_ne.append((item.t, n, e))

    # ------------------------------------------------------------------ D -> W
    @property
    def offset(self) -> F64 | None:
        return self.anchor.offset

    @property
    def georeferenced(self) -> bool:
        return self.offset is not None and self.datum is not None

    def shift(self, t: ArrayLike, corrected: bool) -> F64:
        """(n, 3) to add to D positions at times ``t``: the offset (+ the drift correction)."""
        ta = np.atleast_1d(np.asarray(t, dtype=np.float64))
        out = np.zeros((ta.size, 3))
        off = self.offset
        if off is not None:
            out[:, :2] = off
            if corrected:
                out[:, :2] += self.anchor.correction_at(ta)
        return out

    def latlon(self, ned: F64) -> tuple[F64, F64]:
        """Latitude, longitude (deg) of W positions (n, 3); NaN when not georeferenced."""
        p = np.asarray(ned, dtype=np.float64).reshape(-1, 3)
        if not self.georeferenced:
            return np.full(p.shape[0], np.nan), np.full(p.shape[0], np.nan)
        assert self.datum is not None
        lat, lon, _ = self.datum.to_geodetic(p)
        return lat, lon

    def frame(self) -> str:
        return self.anchor.frame() if self.datum is not None else "first_navigation_sample"

    def summary(self) -> dict[str, Any]:
        out = {"gnss_device": self.has_gnss, "georeferenced": self.georeferenced,
               "datum": None if self.datum is None else self.datum.to_dict(), "datum_source": self.datum_source,
               **self.anchor.summary()}
        out["frame"] = self.frame()
        out["positions"] = ("local NED at the site datum (m); lat/lon WGS84" if self.georeferenced else
                            "relative to the first navigation sample (no usable GNSS fix): no lat/lon")
        return out

    # ------------------------------------------------------------------ detections and track
    def locate(self, det: Any, correction: F64 | None = None) -> None:
        """Set a detection's frame and lat/lon from its position (and the drift correction it got)."""
        det.frame = "site" if self.georeferenced else "first_navigation_sample"
        if self.georeferenced:
            lat, lon = self.latlon(np.asarray(det.position_ned))
            det.latitude, det.longitude = float(lat[0]), float(lon[0])
        if correction is not None:
            det.drift_correction_ne = (float(correction[0]), float(correction[1]))

    def refusal_line(self) -> str | None:
        """One line when the closure was refused (:attr:`recon.nav_anchor.GnssAnchor.closure_refused`), else None."""
        r = self.anchor.closure_refused
        if r is None:
            return None
        return (f"GNSS closure refused: the fixes after surfacing put the vehicle {r['closure_m']:.0f} m from its "
                f"dead-reckoned track, more than navigation can drift ({r['bound_m']:.0f} m over "
                f"{r['travelled_m']:.0f} m travelled, {r['unaided_m']:.0f} m of it possibly without bottom track); "
                "the dead-reckoned track is kept")

    def finalize(self, detections: list[Any], applied: dict[int, F64], epoch: float) -> None:
        """Move every detection (position and points) to the corrected track at its middle time;
        ``applied``: the shift each was handed on with (updated). A refused closure: one line on stderr."""
        line = self.refusal_line()
        if line is not None and not self._warned:
            self._warned = True
            print(f"auvlink: warning: {line}", file=sys.stderr)
        for det in detections:
            t_mid = 0.5 * (det.t_first + det.t_last) - epoch
            target = self.shift(t_mid, corrected=True)[0]
            delta = target - applied.get(det.id, np.zeros(3))
            if np.any(delta):
                det.position_ned = tuple(float(v) for v in np.asarray(det.position_ned) + delta)
                det.points = det.points + delta
            applied[det.id] = target
            self.locate(det, self.anchor.correction_at(t_mid)[0])

    def track_table(self, nav: Any, epoch: float, finished: bool, step: int = 5) -> dict[str, F64]:
        """The columns of ``track.csv``: UTC s, lat, lon (NaN without a georeference), north, east, depth,
        altitude (m), heading (deg), the drift correction applied (north, east m), from the causal navigator
        ``nav``; ``fixes``: (UTC s, north, east) of every fix with a position."""
        t, pos = nav.positions(step)
        fixes = np.asarray(self.fixes_ne, dtype=np.float64).reshape(-1, 3)
        fixes[:, 0] += epoch
        if not t.size:
            return {"fixes": fixes}
        corr = self.anchor.correction_at(t) if finished and self.offset is not None else np.zeros((t.size, 2))
        w = pos + self.shift(t, corrected=finished)
        lat, lon = self.latlon(w)
        _, rot = nav.pose_at(t)
        heading = np.mod(np.degrees(rot.as_euler("ZYX")[:, 0]), 360.0)
        return {"time": t + epoch, "lat": lat, "lon": lon, "north": w[:, 0], "east": w[:, 1], "depth": w[:, 2],
                "altitude": nav.altitude_at(t), "heading": heading, "correction_north": corr[:, 0],
                "correction_east": corr[:, 1], "fixes": fixes}
