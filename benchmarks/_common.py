"""Shared helpers of the benchmark scripts: timing, tables, JSON results, the machine description."""

from __future__ import annotations

import json
import os
import platform
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from auvlink.jsonutil import to_jsonable


def machine() -> dict[str, Any]:
    """What ran the benchmark (CPU model, cores, Python)."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "platform": platform.platform()}


def best_time(fn: Callable[[], Any], repeat: int = 3, min_time: float = 0.0) -> float:
    """Best wall time of ``repeat`` calls of ``fn`` in seconds (each call at least once)."""
    best = float("inf")
    for _ in range(max(1, repeat)):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
        if min_time and best > min_time:
            break
    return best


def table(rows: Sequence[dict[str, Any]], columns: Sequence[str] | None = None) -> str:
    """A plain-text table of ``rows`` (list of dicts)."""
    if not rows:
        return "(no rows)"
    cols = list(columns or rows[0].keys())

    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return f"{v:.4g}" if abs(v) < 1e5 else f"{v:.0f}"
        return "-" if v is None else str(v)

    cells = [[fmt(r.get(c)) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]
    line = "  ".join(c.ljust(w) for c, w in zip(cols, widths, strict=True))
    out = [line, "  ".join("-" * w for w in widths)]
    out += ["  ".join(v.ljust(w) for v, w in zip(row, widths, strict=True)) for row in cells]
    return "\n".join(out)


def smoke() -> bool:
    """True in the CI smoke mode (``auvlink bench --smoke`` sets ``AUVLINK_BENCH_SMOKE=1``): every stage
    shrinks its inputs so that all stages together finish in well under two minutes, to keep the scripts
    from rotting; the figures are not meant to be quoted."""
    return os.environ.get("AUVLINK_BENCH_SMOKE", "") not in ("", "0")


def script_main(run: Callable[..., dict[str, Any]], doc: str | None) -> None:
    """``python benchmarks/bench_X.py [--out DIR] [--full]``: the command line of every script."""
    import argparse

    ap = argparse.ArgumentParser(description=doc)
    ap.add_argument("--out", type=Path, default=Path("bench-out"))
    ap.add_argument("--full", action="store_true", help="the long version")
    a = ap.parse_args()
    run(quick=not a.full, out_dir=a.out)


def write_json(out_dir: Path, name: str, result: dict[str, Any]) -> Path:
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}.json"
    result = {"benchmark": name, "machine": machine(), **result}
    path.write_text(json.dumps(to_jsonable(result), indent=2, allow_nan=False) + "\n")
    return path
