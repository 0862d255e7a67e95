"""Read missions for the catalogue from their batch folders; write ``catalogue.geojson`` and ``catalogue.csv``.

``catalogue.geojson``: a FeatureCollection of Points, one per physical object. In a geographic catalogue
the coordinates are ``[lon, lat]`` (WGS84 degrees, RFC 7946); in a datum-less one they are ``[east,
north]`` in metres of the local frame, and the collection's ``frame`` member says so (such a file is
GeoJSON by prior arrangement only: a GIS must not read it as WGS84). Properties: ``id``, ``class``
(majority vote), ``status`` (``new`` / ``missing`` / ``stable``), ``votes`` {class: count}, ``north``,
``east``, ``depth`` (m), ``spread_m`` / ``spread_max_m`` (RMS and largest distance of the sightings from
the object, m), ``seen_in`` and ``covered_by`` (mission names in time order), ``not_seen_in`` (covered
but not seen), ``first_seen`` / ``last_seen`` (ISO 8601 UTC of the missions' starts) and ``sightings``
(mission, detection id, class, score, north, east). Top-level members: ``frame``, ``merge_radius_m``,
``edge_margin_m`` and ``missions`` (name, start, detections, covered area m^2) in time order.

``catalogue.csv``: the same, one row per object; lists ``;``-separated, votes as ``class:count``.
``coverage.geojson``: each mission's covered seabed as a (Multi)Polygon feature (properties ``mission``,
``start``, ``area_m2``), in the catalogue's coordinates. All are written atomically
(:func:`auvlink.atomic.write_text`).
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import json
from pathlib import Path
from typing import Any

from auvlink.atomic import write_text
from auvlink.errors import AuvlinkError
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.batch_mission import read_record
from auvlink.pipeline.catalogue import Catalogue, MissionData, SiteObject
from auvlink.pipeline.coverage import geometry_from_json

CSV_COLUMNS = ("id", "class", "status", "lat", "lon", "north", "east", "depth", "spread_m", "spread_max_m",
               "votes", "seen_in", "covered_by", "not_seen_in", "first_seen", "last_seen")


def iso(ns: int) -> str:
    return dt.datetime.fromtimestamp(ns * 1e-9, dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


def load_mission(folder: Path) -> MissionData:
    """A finished batch mission folder (``batch.json`` + ``detections.jsonl``) as :class:`MissionData`."""
    rec = read_record(folder)
    if rec is None:
        raise AuvlinkError(f"{folder}: no batch.json (not a finished batch mission)")
    dets = []
    try:
        lines = (folder / "detections.jsonl").read_text().splitlines()
    except OSError as exc:
        raise AuvlinkError(f"{folder / 'detections.jsonl'}: {exc.strerror or exc}") from exc
    for line in lines:
        if not line.strip():
            continue
        d = json.loads(line)
        n, e, z = (list(d["position_ned"]) + [None] * 3)[:3]
        dets.append({"id": d.get("id"), "class": d.get("class"), "score": d.get("score", 0.0), "north": n,
                     "east": e, "depth": z if z is not None else float("nan"), "lat": d.get("lat"),
                     "lon": d.get("lon")})
    datum = rec.get("datum")
    return MissionData(
        name=str(rec["mission"]), start_ns=int(rec.get("start_ns") or 0), detections=dets,
        coverage=geometry_from_json(rec["coverage"]["geometry"]),
        datum=(float(datum["latitude"]), float(datum["longitude"])) if isinstance(datum, dict) else None,
        georeferenced=bool(rec.get("georeferenced")))


def _times(cat: Catalogue, o: SiteObject) -> tuple[str, str]:
    start = {m.name: m.start_ns for m in cat.missions}
    seen = sorted(start[m] for m in o.seen_in)
    return iso(seen[0]), iso(seen[-1])


def object_properties(cat: Catalogue, o: SiteObject) -> dict[str, Any]:
    rms, top = o.spread()
    first, last = _times(cat, o)
    seen = set(o.seen_in)
    lat, lon = (round(o.lat, 9), round(o.lon, 9)) if o.lat is not None and o.lon is not None else (None, None)
    return {"id": o.id, "class": o.class_name, "status": o.status, "votes": o.votes, "lat": lat, "lon": lon,
            "north": round(o.north, 3), "east": round(o.east, 3), "depth": round(o.depth, 3),
            "spread_m": round(rms, 3), "spread_max_m": round(top, 3),
            "seen_in": [m for m in o.covering if m in seen], "covered_by": o.covering,
            "not_seen_in": [m for m in o.covering if m not in seen], "first_seen": first, "last_seen": last,
            "sightings": [{"mission": s.mission, "id": s.det_id, "class": s.class_name, "score": round(s.score, 4),
                           "north": round(s.north, 3), "east": round(s.east, 3)} for s in o.sightings]}


def catalogue_geojson(cat: Catalogue) -> dict[str, Any]:
    feats = []
    for o in cat.objects:
        props = object_properties(cat, o)
        xy = [round(o.lon, 9), round(o.lat, 9)] if o.lon is not None and o.lat is not None else \
            [props["east"], props["north"]]
        feats.append({"type": "Feature", "geometry": {"type": "Point", "coordinates": xy}, "properties": props})
    missions = [{"name": m.name, "start": iso(m.start_ns), "detections": len(m.detections),
                 "covered_area_m2": round(float(cat.coverage[m.name].area), 1), "georeferenced": m.georeferenced}
                for m in cat.missions]
    return {"type": "FeatureCollection", "name": "auvlink site catalogue", "frame": cat.frame.note,
            "merge_radius_m": cat.radius, "edge_margin_m": cat.edge_margin, "missions": missions,
            "features": feats}


def catalogue_csv(cat: Catalogue) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for o in cat.objects:
        p = object_properties(cat, o)
        p["votes"] = ";".join(f"{k}:{v}" for k, v in p["votes"].items())
        for k in ("seen_in", "covered_by", "not_seen_in"):
            p[k] = ";".join(p[k])
        w.writerow(["" if p[c] is None else p[c] for c in CSV_COLUMNS])
    return buf.getvalue()


def coverage_geojson(cat: Catalogue) -> dict[str, Any]:
    """The missions' covered areas (``[lon, lat]`` in a geographic catalogue, else ``[east, north]`` m)."""
    import numpy as np
    import shapely

    from auvlink.pipeline.catalogue import _geodesy
    from auvlink.pipeline.coverage import geometry_to_json

    datum = cat.frame.datum

    def to_lonlat(xy: Any) -> Any:
        assert datum is not None
        lat, lon, _ = _geodesy().Datum(*datum).to_geodetic(np.column_stack([xy[:, 1], xy[:, 0], np.zeros(len(xy))]))
        return np.column_stack([lon, lat])

    feats = []
    for m in cat.missions:
        g = cat.coverage[m.name]
        geom = geometry_to_json(shapely.transform(g, to_lonlat), 9) if datum is not None and not g.is_empty \
            else geometry_to_json(g)
        feats.append({"type": "Feature", "geometry": geom,
                      "properties": {"mission": m.name, "start": iso(m.start_ns), "area_m2": round(float(g.area), 1)}})
    return {"type": "FeatureCollection", "name": "auvlink survey coverage", "frame": cat.frame.note,
            "features": feats}


def write_catalogue(cat: Catalogue, out_dir: Path) -> tuple[Path, Path]:
    """Write ``catalogue.geojson``, ``catalogue.csv`` and ``coverage.geojson`` into ``out_dir``
    (atomically); returns the first two paths."""
    gj = write_text(out_dir / "catalogue.geojson",
                    json.dumps(to_jsonable(catalogue_geojson(cat)), indent=1, allow_nan=False) + "\n")
    cs = write_text(out_dir / "catalogue.csv", catalogue_csv(cat))
    write_text(out_dir / "coverage.geojson", json.dumps(to_jsonable(coverage_geojson(cat)), allow_nan=False) + "\n")
    return gj, cs


def status_counts(cat: Catalogue) -> dict[str, int]:
    out = {"new": 0, "missing": 0, "stable": 0}
    for o in cat.objects:
        out[o.status] += 1
    return out
