"""Outputs a GIS opens: ``detections.geojson``, ``track.csv``, ``track.geojson``, ``detections.kml``.

- ``detections.geojson``: an RFC 7946 FeatureCollection of Points ``[lon, lat]`` (WGS84 degrees; no
  ``crs`` member, RFC 7946 has one datum), properties ``id``, ``class``, ``score``, ``depth`` (m),
  ``size`` ([m, m, m]), ``n_points``, ``t_first`` / ``t_last`` (ISO 8601 UTC), ``drift_correction_ne`` (m);
- ``track.csv``: ``time`` (ISO 8601 UTC), ``lat``, ``lon`` (empty when not georeferenced), ``north``,
  ``east``, ``depth``, ``altitude`` (m), ``heading`` (deg), ``correction_north``, ``correction_east``
  (the drift correction applied, m);
- ``track.geojson``: the track as one LineString Feature;
- ``detections.kml`` (simplekml): one placemark per detection and the track, for Google Earth.

Only ``track.csv`` is written without a georeference (no datum, or no usable GNSS fix): its positions
are then relative to the first navigation sample, as ``summary.json`` (``georef.frame``) says.
"""

from __future__ import annotations

import csv
import datetime as dt
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from auvlink.jsonutil import dumps
from auvlink.pipeline.results import MissionResult

TRACK_COLUMNS = ("time", "lat", "lon", "north", "east", "depth", "altitude", "heading", "correction_north",
                 "correction_east")


def iso(t: float) -> str:
    return dt.datetime.fromtimestamp(t, dt.UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _num(v: float, nd: int) -> float | None:
    return round(float(v), nd) if math.isfinite(v) else None


def detections_geojson(result: MissionResult) -> dict[str, Any]:
    feats = []
    for d in result.detections:
        if d.latitude is None or d.longitude is None:
            continue
        feats.append({"type": "Feature",
                      "geometry": {"type": "Point", "coordinates": [round(d.longitude, 9), round(d.latitude, 9)]},
                      "properties": {"id": d.id, "class": d.class_name, "score": round(d.score, 4),
                                     "depth": round(d.position_ned[2], 3), "size": [round(v, 3) for v in d.size],
                                     "n_points": d.n_points, "t_first": iso(d.t_first), "t_last": iso(d.t_last),
                                     "drift_correction_ne": [round(v, 3) for v in d.drift_correction_ne]}})
    return {"type": "FeatureCollection", "features": feats}


def track_geojson(track: dict[str, np.ndarray]) -> dict[str, Any]:
    lat, lon = track["lat"], track["lon"]
    ok = np.isfinite(lat) & np.isfinite(lon)
    coords = [[round(float(a), 9), round(float(b), 9)] for a, b in zip(lon[ok], lat[ok], strict=True)]
    props = {"name": "vehicle track (drift-corrected)", "t_start": iso(float(track["time"][0])),
             "t_end": iso(float(track["time"][-1]))} if len(track["time"]) else {}
    return {"type": "FeatureCollection", "features": [
        {"type": "Feature", "geometry": {"type": "LineString", "coordinates": coords}, "properties": props}]}


def write_track_csv(track: dict[str, np.ndarray], path: Path) -> None:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRACK_COLUMNS)
        n = len(track.get("time", ()))
        for i in range(n):
            row: list[Any] = [iso(float(track["time"][i]))]
            for k, nd in (("lat", 9), ("lon", 9), ("north", 3), ("east", 3), ("depth", 3), ("altitude", 3),
                          ("heading", 2), ("correction_north", 3), ("correction_east", 3)):
                v = _num(float(track[k][i]), nd)
                row.append("" if v is None else v)
            w.writerow(row)


def write_kml(result: MissionResult, track: dict[str, np.ndarray], path: Path) -> None:
    import simplekml

    kml = simplekml.Kml(name="auvlink detections")
    for d in result.detections:
        if d.latitude is None or d.longitude is None:
            continue
        p = kml.newpoint(name=f"#{d.id} {d.class_name}", coords=[(d.longitude, d.latitude)])
        p.description = (f"class {d.class_name} (score {d.score:.2f}), depth {d.position_ned[2]:.1f} m, "
                         f"{d.n_points} points, seen {iso(d.t_first)} .. {iso(d.t_last)}")
    ok = np.isfinite(track["lat"]) & np.isfinite(track["lon"]) if "lat" in track else np.zeros(0, bool)
    if ok.sum() >= 2:
        kml.newlinestring(name="track", coords=list(zip(track["lon"][ok].tolist(), track["lat"][ok].tolist(),
                                                        strict=True)))
    kml.save(str(path))


def write_gis(result: MissionResult, write: Callable[[str, Callable[[Path], Any]], None]) -> list[str]:
    """Write the GIS files through ``write(name, fn)`` (``fn(path)`` writes the file; the caller makes it
    atomic); returns their names."""
    track = result.track_info
    written = []
    if track.get("time") is not None:
        write("track.csv", lambda p: write_track_csv(track, p))
        written.append("track.csv")
    if not result.georef.get("georeferenced"):
        return written
    dets = dumps(detections_geojson(result), indent=1) + "\n"  # strict JSON: a non-finite value is null
    write("detections.geojson", lambda p: p.write_text(dets))
    written.append("detections.geojson")
    if track.get("time") is not None and len(track["time"]):
        line = dumps(track_geojson(track)) + "\n"
        write("track.geojson", lambda p: p.write_text(line))
        write("detections.kml", lambda p: write_kml(result, track, p))
        written += ["track.geojson", "detections.kml"]
    return written
