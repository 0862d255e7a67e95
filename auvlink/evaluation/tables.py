"""Text table and plot of an evaluation over random surveys (:mod:`auvlink.evaluation.surveys`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from auvlink.evaluation.survey_scores import BINS, KINDS, OBJECT_KINDS

COLUMNS = ("surveys", "objects", "detections", "precision_1m", "recall_1m", "precision_2m", "recall_2m",
           "detections_per_object", *KINDS)


def _cell(v: Any) -> str:
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.2f}"
    return str(v)


def rows(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One row for all surveys, then one per factor bin (the survey's factors, then the acoustic ones the surveys
    were drawn with); failures flattened into columns."""
    out = [{"factor": "all", "bin": "", **result["overall"], **result["overall"]["failures"]}]
    for f in result["by_factor"]:
        for r in result["by_factor"][f]:
            out.append({**r, **r["failures"]})
    return out


def _layout(names: Sequence[str], cells: Sequence[Sequence[str]], left: Sequence[int] = ()) -> str:
    """Columns as wide as their widest cell, two spaces apart, under a dashed rule; right-aligned but for the
    columns ``left``."""
    widths = [max([len(n), *(len(row[i]) for row in cells)]) for i, n in enumerate(names)]

    def line(values: Sequence[str]) -> str:
        return "  ".join(v.ljust(w) if i in left else v.rjust(w)
                         for i, (v, w) in enumerate(zip(values, widths, strict=True))).rstrip()

    return "\n".join([line(names), "  ".join("-" * w for w in widths), *(line(row) for row in cells)])


def text_table(result: dict[str, Any]) -> str:
    """The table printed by ``auvlink eval --surveys``: P/R at 1 m and 2 m (class must match)."""
    cols = ("factor", "bin", *COLUMNS)
    cells = [[_cell(r.get(c, "")) for c in cols] for r in rows(result)]
    names = [c.replace("precision", "P").replace("recall", "R").replace("detections_per_object", "det/obj")
             for c in cols]
    return _layout(names, cells)


def interval_line(result: dict[str, Any]) -> str:
    """Overall precision and recall at 1 m with their 95 % intervals (bootstrap over the surveys)."""
    o = result["overall"]

    def one(name: str) -> str:
        lo, hi = o.get(f"{name}_1m_ci95", (math.nan, math.nan))
        return f"{name} {o[f'{name}_1m']:.3f} ({lo:.3f}-{hi:.3f})"

    return (f"overall at 1 m, 95 % interval from a bootstrap over the {o['surveys']} surveys: {one('precision')}, "
            f"{one('recall')}")


def class_table(result: dict[str, Any]) -> str:
    """Per true class: objects, recall at 1 m, failures by kind, and what the wrongly classified were called."""
    names = ("class", "objects", "R_1m", *OBJECT_KINDS, "called")
    cells = []
    for r in result.get("by_class", []):
        called = ", ".join(f"{k} {v}" for k, v in sorted(r["called"].items(), key=lambda kv: (-kv[1], kv[0])))
        cells.append([r["class"], str(r["objects"]), _cell(r["recall_1m"]),
                      *(str(r["failures"][k]) for k in OBJECT_KINDS), called or "-"])
    return _layout(names, cells, left=(0, len(names) - 1))  # names left, counts right


def plot(result: dict[str, Any], path: Path) -> Path:
    """Per factor, precision and recall (1 m, class must match) per bin, with the 0.90 / 0.95 targets."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5), sharey=True)
    for ax, f in zip(axes.ravel(), BINS, strict=True):
        rs = result["by_factor"][f]
        x = range(len(rs))
        p = [r["precision_1m"] for r in rs]
        rc = [r["recall_1m"] for r in rs]
        ax.bar([i - 0.2 for i in x], [0 if math.isnan(v) else v for v in p], 0.4, label="precision")
        ax.bar([i + 0.2 for i in x], [0 if math.isnan(v) else v for v in rc], 0.4, label="recall")
        ax.set_xticks(list(x), [f"{r['bin']}\n(n={r['surveys']})" for r in rs], fontsize=8)
        ax.axhline(0.95, color="k", lw=0.8, ls="--")
        ax.axhline(0.90, color="gray", lw=0.8, ls=":")
        ax.set_title(f, fontsize=10)
        ax.set_ylim(0, 1.05)
    axes[0, 0].legend(fontsize=8, loc="lower left")
    o = result["overall"]
    fig.suptitle(f"{o['surveys']} random surveys (seed {result.get('seed')}): P {o['precision_1m']:.2f}, "
                 f"R {o['recall_1m']:.2f} at 1 m, class must match; {o['detections_per_object']:.2f} det/object",
                 fontsize=11)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
