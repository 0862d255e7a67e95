"""``bench.html``: the benchmark report rendered from ``results.json`` (PNG plots beside it and embedded).

Reads the JSON contract of docs/BENCHMARKS.md: per stage, ``tradeoffs`` (one row per swept knob setting:
``time_s`` per ``time_unit``, ``error`` named by ``error_name``, ``default``), ``peers`` (ours against a
peer in the same run, ``ratio = peer_s / ours_s``) and ``stability`` (``case``, ``ok``, ``detail``).
The report holds, per stage, its scalar figures and row tables; per knob a time-vs-error scatter with
the Pareto front (no other setting is both faster and more accurate) and the default ringed; one
table and bar chart of every peer ratio; the stability table; the machine and the command.

``python benchmarks/report.py DIR`` re-renders ``DIR/bench.html`` from ``DIR/results.json``.
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

MAX_ROWS = 40  # rows shown per generic table


def pareto_front(points: Sequence[tuple[float, float]]) -> list[bool]:
    """For (time, error) pairs, True where no other point is at least as good in both and better in one."""
    out = []
    for i, (t, e) in enumerate(points):
        dominated = any((t2 <= t and e2 <= e) and (t2 < t or e2 < e)
                        for j, (t2, e2) in enumerate(points) if j != i)
        out.append(not dominated)
    return out


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_").lower() or "x"


def _fmt(v: Any) -> str:
    if isinstance(v, bool) or v is None:
        return "-" if v is None else ("yes" if v else "no")
    if isinstance(v, float):
        if v == 0 or math.isnan(v):
            return f"{v:g}"
        return f"{v:.4g}" if 1e-3 <= abs(v) < 1e6 else f"{v:.3e}"
    if isinstance(v, list | tuple) and len(v) <= 6 and all(not isinstance(x, dict | list) for x in v):
        return ", ".join(_fmt(x) for x in v)
    return str(v)


def _simple(v: Any) -> bool:
    """A value that fits a table cell: a scalar or a short list of scalars."""
    if isinstance(v, list | tuple):
        return len(v) <= 6 and all(not isinstance(x, dict | list | tuple) for x in v)
    return not isinstance(v, dict)


def _table(rows: Sequence[dict[str, Any]], columns: Sequence[str] | None = None, css: str = "",
           max_rows: int = MAX_ROWS) -> str:
    if not rows:
        return "<p>(no rows)</p>"
    cols: list[str] = list(columns) if columns else []
    if not cols:
        for r in rows:
            cols += [k for k, v in r.items() if k not in cols and _simple(v)]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = []
    for r in rows[:max_rows]:
        cls = ""
        if "ok" in r and isinstance(r["ok"], bool):
            cls = ' class="ok"' if r["ok"] else ' class="fail"'
        cells = "".join(f"<td>{html.escape(_fmt(r.get(c)))}</td>" for c in cols)
        body.append(f"<tr{cls}>{cells}</tr>")
    more = f"<p>({len(rows) - max_rows} more rows in results.json)</p>" if len(rows) > max_rows else ""
    return f'<table class="{css}"><tr>{head}</tr>{"".join(body)}</table>{more}'


def _save(fig: Any, path: Path) -> str:
    """Write the figure as PNG and return an <img> with it embedded (the page stands alone)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90, bbox_inches="tight")
    plt.close(fig)
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return (f'<img alt="{html.escape(path.name)}" data-file="{html.escape(path.parent.name)}/'
            f'{html.escape(path.name)}" src="data:image/png;base64,{data}">')


def tradeoff_plot(stage: str, knob: str, rows: Sequence[dict[str, Any]], plots: Path) -> tuple[str, Path]:
    """Scatter of time against error for one knob; the Pareto front joined, the default ringed."""
    pts = [(float(r["time_s"]), float(r["error"])) for r in rows]
    front = pareto_front(pts)
    fig, ax = plt.subplots(figsize=(5.2, 3.6))
    ax.scatter([p[0] for p in pts], [p[1] for p in pts], c=["tab:blue" if f else "tab:gray" for f in front],
               zorder=3, label="setting")
    fp = sorted(p for p, f in zip(pts, front, strict=True) if f)
    if len(fp) > 1:
        ax.step([p[0] for p in fp], [p[1] for p in fp], where="post", color="tab:blue", alpha=0.6,
                label="Pareto front")
    for r, (t, e) in zip(rows, pts, strict=True):
        ax.annotate(str(r["setting"]), (t, e), textcoords="offset points", xytext=(4, 4), fontsize=8)
        if r.get("default"):
            ax.scatter([t], [e], s=180, facecolors="none", edgecolors="tab:red", linewidths=2, zorder=4,
                       label="default")
    unit = rows[0].get("time_unit", "")
    ax.set_xlabel(f"time [s per {unit}]" if unit else "time [s]")
    ax.set_ylabel(str(rows[0].get("error_name", "error")))
    ax.set_title(f"{stage}: {knob}")
    ax.grid(alpha=0.3)
    positive_t = all(p[0] > 0 for p in pts)
    if positive_t and max(p[0] for p in pts) / min(p[0] for p in pts) > 30:
        ax.set_xscale("log")
    else:  # small times (us per frame) as 2e-05, not as overlapping 0.00002 labels
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4))
    positive_e = all(p[1] > 0 for p in pts)
    if positive_e and max(p[1] for p in pts) / min(p[1] for p in pts) > 30:
        ax.set_yscale("log")
    handles, labels = ax.get_legend_handles_labels()
    seen: dict[str, Any] = {}
    for h, lab in zip(handles, labels, strict=True):
        seen.setdefault(lab, h)
    ax.legend(seen.values(), seen.keys(), fontsize=8)
    path = plots / f"tradeoff_{slug(stage)}_{slug(knob)}.png"
    return _save(fig, path), path


def peers_plot(peers: Sequence[dict[str, Any]], plots: Path) -> tuple[str, Path]:
    """Horizontal bars of peer_s / ours_s (log scale; 1 = parity)."""
    labels = [f"{p['stage']}: {p['what']}\n{p['ours']} vs {p['peer']}" for p in peers]
    ratios = [max(float(p["ratio"]), 1e-3) for p in peers]
    fig, ax = plt.subplots(figsize=(7.0, 0.6 * len(peers) + 1.2))
    ax.barh(range(len(peers)), ratios, color=["tab:green" if r >= 1 else "tab:orange" for r in ratios])
    ax.set_yticks(range(len(peers)), labels, fontsize=8)
    ax.axvline(1.0, color="k", lw=1)
    ax.set_xscale("log")
    ax.set_xlabel("peer time / our time (> 1: ours faster)")
    for i, r in enumerate(ratios):
        ax.annotate(f"{r:.3g}x", (r, i), textcoords="offset points", xytext=(3, -3), fontsize=8)
    ax.invert_yaxis()
    path = plots / "peers.png"
    return _save(fig, path), path


def curve_plot(stage: str, spec: dict[str, Any], plots: Path) -> tuple[str, Path]:
    """A stage's own line plot: ``{"title", "x", "series": {label: y}, "xlabel", "ylabel", "loglog"}``."""
    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    x = [float("nan") if v is None else float(v) for v in spec["x"]]
    for label, ys in spec["series"].items():
        y = [float("nan") if v is None else float(v) for v in ys]
        ax.plot(x, y, "--" if "theory" in label else "-o", ms=3, label=label)
    if spec.get("loglog"):
        ax.set_xscale("log")
        ax.set_yscale("log")
    ax.set_xlabel(str(spec.get("xlabel", "")))
    ax.set_ylabel(str(spec.get("ylabel", "")))
    ax.set_title(str(spec.get("title", stage)), fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    path = plots / f"curve_{slug(stage)}_{slug(str(spec.get('title', 'plot')))[:60]}.png"
    return _save(fig, path), path


CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;color:#222}
table{border-collapse:collapse;margin:.5em 0;font-size:13px}td,th{border:1px solid #ccc;padding:2px 6px;
text-align:left}th{background:#eee}tr.fail td{background:#fdd}tr.ok td:last-child{color:#262}
img{max-width:100%;margin:4px}.plots{display:flex;flex-wrap:wrap}h2{border-bottom:2px solid #ccc}"""


def _scalars(res: dict[str, Any]) -> list[dict[str, Any]]:
    skip = {"tradeoffs", "peers", "stability", "machine", "benchmark", "plots"}
    return [{"figure": k, "value": v} for k, v in res.items() if k not in skip and _simple(v)]


def default_points(stages: dict[str, Any]) -> list[dict[str, Any]]:
    """Per stage and knob, the default setting and whether it lies on that knob's Pareto front."""
    out = []
    for stage, res in stages.items():
        knobs: dict[str, list[dict[str, Any]]] = {}
        for r in res.get("tradeoffs", []):
            knobs.setdefault(str(r["knob"]), []).append(r)
        for knob, rows in knobs.items():
            front = pareto_front([(float(r["time_s"]), float(r["error"])) for r in rows])
            for r, f in zip(rows, front, strict=True):
                if r.get("default"):
                    out.append({"stage": stage, "knob": knob, "default": r["setting"], "time_s": r["time_s"],
                                "time_unit": r.get("time_unit", ""), "error": r["error"],
                                "error_name": r.get("error_name", ""), "on_front": f})
    return out


def render(results: dict[str, Any], out_dir: Path) -> Path:
    """Write ``out_dir/bench.html`` and ``out_dir/plots/*.png`` from a results.json structure."""
    plots = out_dir / "plots"
    plots.mkdir(parents=True, exist_ok=True)
    for old in plots.glob("*.png"):
        old.unlink()
    stages: dict[str, Any] = results.get("stages", {})
    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>auvlink bench</title>",
             f"<style>{CSS}</style></head><body><h1>auvlink benchmarks</h1>"]
    meta = [{"figure": k, "value": v} for k, v in results.items() if k not in ("stages", "machine")]
    meta += [{"figure": f"machine.{k}", "value": v} for k, v in (results.get("machine") or {}).items()]
    parts.append("<h2>Run (the latest invocation; stages of earlier runs into this folder are kept)</h2>"
                 + _table(meta, ["figure", "value"]))
    status = [{"stage": s, "mode": r.get("mode"), "run_started_utc": r.get("run_started_utc"),
               "loadavg_1min": r.get("loadavg_1min"), "wall_s": r.get("wall_s"),
               "tradeoff rows": len(r.get("tradeoffs", [])),
               "peers": len(r.get("peers", [])), "stability cases": len(r.get("stability", [])),
               "stability failures": sum(not c.get("ok") for c in r.get("stability", []))}
              for s, r in stages.items()]
    parts.append("<h2>Stages</h2>" + _table(status))
    all_peers = [{"stage": s, **p} for s, r in stages.items() for p in r.get("peers", [])]
    if all_peers:
        img, _ = peers_plot(all_peers, plots)
        parts.append("<h2>Peers in the same run</h2>"
                     + _table(all_peers, ["stage", "what", "ours", "ours_s", "peer", "peer_s", "ratio"])
                     + img)
    defaults = default_points(stages)
    if defaults:
        parts.append("<h2>Defaults against the Pareto front</h2>" + _table(
            defaults, ["stage", "knob", "default", "time_s", "time_unit", "error", "error_name", "on_front"],
            max_rows=10_000))
    for stage, res in stages.items():
        parts.append(f'<h2 id="{slug(stage)}">{html.escape(stage)}</h2>')
        if res.get("error"):
            parts.append(f"<p class='fail'>stage failed: {html.escape(str(res['error']))}</p>")
        parts.append(_table(_scalars(res), ["figure", "value"]))
        trade = res.get("tradeoffs", [])
        if trade:
            knobs: dict[str, list[dict[str, Any]]] = {}
            for r in trade:
                knobs.setdefault(str(r["knob"]), []).append(r)
            imgs = []
            table_rows = []
            for knob, rows in knobs.items():
                img, _ = tradeoff_plot(stage, knob, rows, plots)
                imgs.append(img)
                front = pareto_front([(float(r["time_s"]), float(r["error"])) for r in rows])
                table_rows += [{**r, "pareto": f} for r, f in zip(rows, front, strict=True)]
            parts.append("<h3>Run time against error</h3>" + _table(
                table_rows, ["knob", "setting", "time_s", "time_unit", "error", "error_name", "default", "pareto"],
                max_rows=10_000))
            parts.append(f"<div class='plots'>{''.join(imgs)}</div>")
        if res.get("peers"):
            parts.append("<h3>Peers</h3>" + _table(res["peers"], ["what", "ours", "ours_s", "peer", "peer_s",
                                                                   "ratio"]))
        if res.get("stability"):
            parts.append("<h3>Numerical stability</h3>" + _table(res["stability"], ["case", "ok", "detail"],
                                                                      max_rows=10_000))
        curves = [curve_plot(stage, spec, plots)[0] for spec in res.get("plots", [])]
        if curves:
            parts.append(f"<div class='plots'>{''.join(curves)}</div>")
        for key, val in res.items():
            if key in ("tradeoffs", "peers", "stability", "plots") or not isinstance(val, list) or not val:
                continue
            if all(isinstance(x, dict) for x in val):
                parts.append(f"<h3>{html.escape(key)}</h3>" + _table(val))
        for key, val in res.items():
            if isinstance(val, dict) and key not in ("machine",) and val:
                flat = [{"figure": k, "value": v} for k, v in val.items() if _simple(v)]
                if flat:
                    parts.append(f"<h3>{html.escape(key)}</h3>" + _table(flat, ["figure", "value"]))
    parts.append("</body></html>")
    path = out_dir / "bench.html"
    path.write_text("\n".join(parts))
    return path


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    out = Path(args[0] if args else "bench-out")
    results = json.loads((out / "results.json").read_text())
    print(render(results, out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
