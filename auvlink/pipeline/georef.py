"""The engine's georeferencing: GNSS fixes -> the anchor of dead reckoning, the site datum, lat/lon.

The engine feeds :class:`Georef` the navigation depth samples and the GNSS fixes (routed from the
``nmea`` device as :class:`GnssPayload` by :class:`auvlink.pipeline.nav_inputs.NavAdaptor`), in time
order, with the causal navigator for the pose at each fix. :class:`recon.nav_anchor.GnssAnchor` does
the anchoring; this class holds the datum (the vehicle configuration's ``[site]``; without one, the
first fix with a position becomes the datum and the summary says so), converts fixes to W (PROJ,
:mod:`auvlink.geodesy`) and positions of dead reckoning's frame D to W: ``p_W = p_D + offset`` (live:
the start anchor) ``+ correction(t)`` (at the end: the closure error distributed over the submerged
track).
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auvlink.geodesy import Datum
from recon.nav_anchor import AnchorConfig, GnssAnchor

F64 = NDArray[np.float64]


class GnssPayload(NamedTuple):
    latitude: float  # deg (NaN without a fix)
    longitude: float
    height: float  # m above the ellipsoid (NaN when unknown)
    quality: int
    hdop: float


def gnss_payload(fmt_record: Any, seen_gga: bool) -> GnssPayload | None:
    """A GGA sentence (or, from a receiver that sends no GGA, an RMC) as a fix; other sentences: None."""
    from auvlink.codecs import nmea

    r = fmt_record
    if isinstance(r, nmea.GgaFix):
        ok = r.has_fix
        return GnssPayload(r.latitude_deg if ok else math.nan, r.longitude_deg if ok else math.nan,
                           r.ellipsoidal_height_m, r.quality if ok else 0, r.hdop)
    if isinstance(r, nmea.RmcFix) and not seen_gga:
        ok = r.has_fix
        return GnssPayload(r.latitude_deg if ok else math.nan, r.longitude_deg if ok else math.nan, math.nan,
                           1 if ok else 0, math.nan)
    return None


class Georef:
    """See the module docstring. ``site``: the configured datum (None: the first fix's)."""

    def __init__(self, site: Datum | None, lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0),
                 has_gnss: bool = False) -> None:
        self.datum = site
        self.datum_source = "vehicle configuration [site]" if site is not None else None
        self.has_gnss = has_gnss
        self.anchor = GnssAnchor(AnchorConfig(lever_arm=lever_arm))
        self.fixes_ne: list[tuple[float, float, float]] = []  # (t, north, east) of every fix with a position

    def on_depth(self, t: F64, depth: F64) -> None:
        self.anchor.observe_depth(t, depth)

    def on_fix(self, t: float, fix: GnssPayload, nav: Any) -> None:
        if fix.quality <= 0 or not (math.isfinite(fix.latitude) and math.isfinite(fix.longitude)):
            self.anchor.reject("no_fix")
            return
        if self.datum is None:
            self.datum = Datum(round(fix.latitude, 7), round(fix.longitude, 7), 0.0)
            self.datum_source = "the first GNSS fix (the configuration has no [site])"
        h = fix.height if math.isfinite(fix.height) else None
        ne = self.datum.to_ned(fix.latitude, fix.longitude, h)[0, :2]
        self.fixes_ne.append((t, float(ne[0]), float(ne[1])))
        if not nav.covered(t)[0]:
            self.anchor.add_fix(t, ne, fix.hdop, None)
            return
        pos, rot = nav.pose_at(t)
        self.anchor.add_fix(t, ne, fix.hdop, pos[0], rot, depth=float(pos[0, 2]))

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

    def finalize(self, detections: list[Any], applied: dict[int, F64], epoch: float) -> None:
        """Move every detection (position and points) to the corrected track at its middle time;
        ``applied``: the shift each was handed on with (updated)."""
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
