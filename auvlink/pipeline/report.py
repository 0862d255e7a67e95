"""``report.html``: one self-contained, interactive page per run (opens offline, no CDN).

A jinja2 template (``auvlink/pipeline/templates/report.html.j2``, package data) with the plotly.js
library inlined once and the figures of :mod:`auvlink.pipeline.report_figures`: a zoomable survey
map, a rotatable 3D view per object beside its class's reference mesh, the sonar frames that saw
each detection (:mod:`auvlink.pipeline.report_frames`, small base64 PNGs), the detection table, the
false and missed detections when the truth is known, timings and device health (decode errors,
drops, port events, the log's loss report).
"""

from __future__ import annotations

import datetime as dt
import errno
from pathlib import Path
from typing import Any

import jinja2
from plotly.offline import get_plotlyjs

from auvlink.atomic import write_text
from auvlink.geodesy import Datum
from auvlink.pipeline import report_figures as figs
from auvlink.pipeline.report_frames import detection_frames
from auvlink.pipeline.report_geo import ToGeodetic
from auvlink.pipeline.results import MissionResult
from auvlink.version import __version__

MAX_OBJECT_VIEWS = 40  # 3D views drawn at most (the largest objects first beyond that)
MAX_EVENTS = 200


def _env() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.PackageLoader("auvlink.pipeline", "templates"),
                             autoescape=jinja2.select_autoescape(["html", "j2"]), undefined=jinja2.StrictUndefined,
                             trim_blocks=True, lstrip_blocks=True)
    env.filters["num"] = _num
    return env


def _num(v: Any, digits: int = 3) -> str:
    if isinstance(v, bool) or v is None:
        return "-" if v is None else str(v)
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def _scalars(d: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in d.items() if not isinstance(v, dict | list)}


def _detection_rows(result: MissionResult, matched: figs.TruthMatch | None) -> list[dict[str, Any]]:
    truth = result.setup.truth
    rows = []
    for i, d in enumerate(result.detections):
        j = matched.truth_of(i) if matched else None
        dist = next((p[2] for p in matched.pairs if p[0] == i), None) if matched else None
        verdict = "" if matched is None else ("false detection" if j is None else
                                              ("correct" if truth[j].class_name == d.class_name
                                               else f"true {truth[j].class_name}: misclassified"))
        rows.append({"id": d.id, "class": d.class_name, "score": d.score, "north": d.position_ned[0],
                     "east": d.position_ned[1], "depth": d.position_ned[2], "lat": d.latitude, "lon": d.longitude,
                     "size": " x ".join(f"{v:.2f}" for v in d.size), "n_points": d.n_points,
                     "t_first": d.t_first - result.t0, "t_last": d.t_last - result.t0, "truth": verdict,
                     "distance_m": dist, "ok": matched is None or verdict == "correct"})
    return rows


def _missed(result: MissionResult, matched: figs.TruthMatch | None) -> list[dict[str, Any]]:
    """The true objects no detection matched: class, north, east (m, the detections' frame), heading."""
    if matched is None:
        return []
    truth = result.setup.truth
    return [{"class": truth[j].class_name, "north": float(matched.truth_ne[j, 0]),
             "east": float(matched.truth_ne[j, 1]), "heading": truth[j].heading_deg} for j in matched.missed]


def _objects(result: MissionResult, matched: figs.TruthMatch | None, figures: bool) -> list[dict[str, Any]]:
    order = sorted(range(len(result.detections)), key=lambda i: -result.detections[i].n_points)
    keep = sorted(order[:MAX_OBJECT_VIEWS])
    frames = detection_frames(result.log, [result.detections[i] for i in keep], track=result.track_info)
    out = []
    for i in keep:
        d = result.detections[i]
        j = matched.truth_of(i) if matched else None
        truth = result.setup.truth[j] if j is not None else None
        out.append({"id": d.id, "class": d.class_name, "score": d.score, "n_points": d.n_points,
                    "truth": truth.class_name if truth else None,
                    "view": figs.to_div(figs.object_figure(d, truth), f"object-{d.id}") if figures else None,
                    "frames": [{"t": f.t - result.t0, "png": f.png_b64, "range": f.range_m, "ringed": f.ringed}
                               for f in frames.get(d.id, [])]})
    return out


def _health(result: MissionResult, summary: dict[str, Any]) -> dict[str, Any]:
    loss = result.loss_json()
    devices = [{"device": k, **{c: x for c, x in _scalars(v).items() if c not in ("name", "url")}}
               for k, v in (result.replay_stats or {}).items() if isinstance(v, dict)]
    cols: list[str] = []
    for row in devices:
        cols += [c for c in row if c not in cols]
    return {"device_cols": cols, "devices": devices, "drops": result.drops, "events": result.events[:MAX_EVENTS],
            "events_total": len(result.events),
            "event_cols": sorted({k for e in result.events[:MAX_EVENTS] for k in e}, key=_event_key),
            "loss": str(loss.get("summary") or "complete"), "loss_spans": (loss.get("spans") or [])[:MAX_EVENTS],
            "recon": _scalars(result.recon_stats), "unwritten": summary.get("unwritten") or []}


def _event_key(k: str) -> tuple[int, str]:
    first = ("t", "time", "t_ns", "kind", "device")
    return (first.index(k) if k in first else len(first), k)


def _to_geodetic(result: MissionResult) -> ToGeodetic | None:
    """NED at the run's site datum -> lat, lon, h (WGS84), when the run is geo-referenced."""
    datum = Datum.from_dict(result.georef.get("datum")) if result.georef.get("georeferenced") else None
    return datum.to_geodetic if datum is not None else None


def render_report(result: MissionResult, summary: dict[str, Any], *, figures: bool = True, note: str = "") -> str:
    """The report page as one HTML string (see the module docstring). ``figures=False`` leaves out
    plotly.js and the interactive figures (the page of a full disk: tables, lists and sonar fans,
    ``note`` saying why)."""
    scores = summary.get("scores")
    matched = figs.truth_match(result, float(scores.get("radius_m", 1.0)) if isinstance(scores, dict) else 1.0)
    truth = result.setup.truth
    timing = figs.timings_figure(result) if figures else None
    ctx = {
        "version": __version__, "mode": result.mode, "log": str(result.log),
        "written": dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "plotlyjs": get_plotlyjs() if figures else "", "note": note,
        "map": figs.to_div(figs.survey_map_figure(result, matched, _to_geodetic(result)), "survey-map")
        if figures else None,
        "detections": _detection_rows(result, matched),
        "has_truth": bool(truth), "has_latlon": any(d.latitude is not None for d in result.detections),
        "truth_skipped": result.setup.truth_skipped, "truth_problem": result.setup.truth_problem,
        "scores": _scalars(scores) if isinstance(scores, dict) else None,
        "false_detections": [r for r in _detection_rows(result, matched) if r["truth"] == "false detection"],
        "missed": _missed(result, matched),
        "radius_m": matched.radius_m if matched else None,
        "objects": _objects(result, matched, figures), "n_objects": len(result.detections),
        "timing": figs.to_div(timing, "timings-figure") if timing is not None else None,
        "timings": result.timings, "latency": result.latency,
        "health": _health(result, summary),
    }
    return _env().get_template("report.html.j2").render(**ctx)


def write_report(result: MissionResult, summary: dict[str, Any], out_dir: Path) -> Path:
    """Write ``out_dir/report.html`` (atomically: never a half report); returns its path.

    The page is a few MB (plotly.js inline). A live run writes what it can: when the disk cannot take
    the page (full, or a file-size or quota limit) it is written again without the interactive figures
    (some 100 kB: tables, the false and missed detections, sonar fans), saying so at its top. A replay's
    folder is all or nothing (:func:`auvlink.atomic.atomic_dir`): there, as for any other error, the
    OSError is raised."""
    path = out_dir / "report.html"
    try:
        return write_text(path, render_report(result, summary))
    except OSError as exc:
        if exc.errno not in _FULL or result.mode != "live":
            raise
        note = (f"The interactive figures (map, 3D views, timings) are left out: the full page did not fit "
                f"on the disk ({exc.strerror or exc}).")
        return write_text(path, render_report(result, summary, figures=False, note=note))


_FULL = (errno.ENOSPC, errno.EFBIG, errno.EDQUOT)
