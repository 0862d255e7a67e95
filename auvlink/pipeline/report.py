"""``report.html``: one self-contained page (PNG figures inlined) per run."""

from __future__ import annotations

import base64
import datetime as dt
import html
from pathlib import Path
from typing import Any

from auvlink.atomic import write_text
from auvlink.pipeline import plots
from auvlink.pipeline.results import MissionResult
from auvlink.version import __version__

_CSS = """body{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px}
th{background:#f3f3f3}img{max-width:100%}h2{border-bottom:1px solid #ddd;margin-top:1.6em}"""


def _img(png: bytes | None, alt: str) -> str:
    if png is None:
        return f"<p><em>{html.escape(alt)}: nothing to show.</em></p>"
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'


def _table(rows: list[dict[str, Any]]) -> str:
    if not rows:
        return "<p><em>none</em></p>"
    cols = list(rows[0])
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)

    def cell(v: Any) -> str:
        return html.escape(f"{v:.3f}" if isinstance(v, float) else str(v))

    body = "".join("<tr>" + "".join(f"<td>{cell(r.get(c))}</td>" for c in cols) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _integrity(loss: dict[str, Any]) -> list[str]:
    """The log-integrity section: one line, and the lost spans (kind, where, seconds, messages) if any."""
    parts = [f"<p>Log integrity: {html.escape(str(loss.get('summary') or 'complete'))}</p>"]
    spans = loss.get("spans") or []
    if spans:
        parts.append(_table([{"lost": s["kind"], "byte": s["offset"], "bytes": s["bytes"],
                              "seconds": "?" if s["seconds"] is None else s["seconds"],
                              "messages": "?" if s["messages"] is None else s["messages"], "reason": s["reason"]}
                             for s in spans[:200]]))
    return parts


def write_report(result: MissionResult, summary: dict[str, Any], out_dir: Path) -> Path:
    det_rows = [{"id": d.id, "class": d.class_name, "score": d.score, "north": d.position_ned[0],
                 "east": d.position_ned[1], "depth": d.position_ned[2], "n_points": d.n_points}
                for d in result.detections]
    dev_rows = [{"device": k, **{kk: vv for kk, vv in v.items() if not isinstance(vv, dict | list)}}
                for k, v in (result.replay_stats or {}).items() if isinstance(v, dict)]
    scores = summary.get("scores")
    score_html = "<p><em>The log has no ground truth.</em></p>"
    if scores:
        keys = ("detections", "truth_objects", "matched", "detection_precision", "detection_recall",
                "classification_precision", "classification_recall", "centroid_error_mean_m")
        score_html = _table([{k: scores[k] for k in keys}]) + _table(scores["matches"])
        if scores["missed"]:
            score_html += f"<p>Missed: {html.escape(', '.join(scores['missed']))}</p>"
    parts = [
        f"<!doctype html><html><head><meta charset='utf-8'><title>auvlink report</title><style>{_CSS}</style>"
        "</head><body>",
        "<h1>auvlink mission report</h1>",
        f"<p>{html.escape(result.mode)}; log <code>{html.escape(str(result.log))}</code>; "
        f"auvlink {__version__}; written "
        f"{dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}.</p>",
        "<h2>Survey map</h2>", _img(plots.survey_map(result), "survey map"),
        "<h2>Detections</h2>", _table(det_rows),
        "<h2>Against the ground truth</h2>", score_html,
        "<h2>Object point clouds</h2>", _img(plots.object_views(result), "object point clouds"),
        "<h2>Sonar frames</h2>", _img(plots.sonar_strip(result), "sonar frames"),
        "<h2>Timing per stage</h2>", _img(plots.stage_timings(result), "timing"),
        _table([{"stage": k, **v} for k, v in result.latency.items()]),
        "<h2>Devices: frames, drops and errors</h2>", _table(dev_rows),
        f"<p>Dropped ({html.escape(result.mode)}): "
        f"{html.escape(', '.join(f'{k} {v}' for k, v in result.drops.items()) or 'nothing')}</p>",
        "<h3>Events (port gaps, reopenings, errors)</h3>", _table(result.events[:200]),
        "<h2>Reconstruction</h2>",
        _table([{k: v for k, v in result.recon_stats.items() if not isinstance(v, dict)}]),
        *_integrity(result.loss_json()),
        "</body></html>",
    ]
    return write_text(out_dir / "report.html", "\n".join(parts))  # atomic: never a half report
