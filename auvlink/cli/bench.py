"""``auvlink bench [STAGE ...] --out DIR [--full|--smoke] [--json] [--report-only]``: run the benchmarks.

Each stage is a script ``benchmarks/bench_<stage>.py`` in the repository with
``run(quick: bool, out_dir: Path) -> dict``; it prints its own table and writes ``<stage>.json``.
This command runs the chosen stages (all by default), merges them into ``DIR/results.json`` (stages
of an earlier run into the same folder are kept), then renders ``DIR/bench.html`` with its PNG plots
(``benchmarks/report.py``). A stage that raises is recorded with its error, the others still run,
and the exit code is 1. ``--smoke`` sets ``AUVLINK_BENCH_SMOKE=1``: every stage shrinks its inputs
(the CI run, well under two minutes; figures not to be quoted). ``--report-only`` re-renders the
report from an existing ``results.json``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import resource
import shlex
import sys
import time
import traceback
from pathlib import Path
from types import ModuleType
from typing import Any

from auvlink.atomic import write_text
from auvlink.errors import AuvlinkError
from auvlink.jsonutil import to_jsonable

STAGES = ("decode", "log", "sim", "recon", "classify", "e2e", "batch", "stability", "survey")


def benchmarks_dir() -> Path:
    """The repository's ``benchmarks/`` folder (the package is installed editable from it)."""
    return Path(__file__).resolve().parents[2] / "benchmarks"


def load_stage(stage: str) -> ModuleType:
    return _load(f"bench_{stage}", f"no benchmark for stage {stage!r}")


def _load(name: str, what: str) -> ModuleType:
    path = benchmarks_dir() / f"{name}.py"
    if not path.is_file():
        raise AuvlinkError(f"{what} ({path} is missing)")
    if str(path.parent) not in sys.path:  # the scripts import their helpers (_common, peers) by name
        sys.path.insert(0, str(path.parent))
    spec = importlib.util.spec_from_file_location(f"auvlink_{name}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def available_stages() -> list[str]:
    return [s for s in STAGES if (benchmarks_dir() / f"bench_{s}.py").is_file()]


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("stages", nargs="*", metavar="STAGE", help=f"stages to run (default: all of {STAGES})")
    p.add_argument("--out", type=Path, default=Path("bench-out"), help="output folder (default bench-out)")
    size = p.add_mutually_exclusive_group()
    size.add_argument("--full", action="store_true", help="the long version (bigger inputs, more repeats)")
    size.add_argument("--smoke", action="store_true",
                      help="tiny inputs (AUVLINK_BENCH_SMOKE=1): checks that every stage still runs")
    p.add_argument("--json", action="store_true", help="print results.json on stdout at the end")
    p.add_argument("--report-only", action="store_true",
                   help="only re-render DIR/bench.html from DIR/results.json")


def render_report(out: Path) -> Path:
    """Render ``out/bench.html`` (and ``out/plots/``) from ``out/results.json``."""
    path = out / "results.json"
    try:
        results = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise AuvlinkError(f"cannot read {path}: {exc}") from exc
    if not _is_bench_results(results):
        raise AuvlinkError(f"{path} is not a benchmark results file (no 'stages' table); choose another --out")
    report = _load("report", "no report generator")
    html_path: Path = report.render(results, out)
    return html_path


def _is_bench_results(results: object) -> bool:
    """Whether ``results`` (parsed JSON) is what :func:`run` writes: a table with a ``stages`` table of tables."""
    stages = results.get("stages") if isinstance(results, dict) else None
    return isinstance(stages, dict) and all(isinstance(s, dict) for s in stages.values())


def _previous_stages(path: Path) -> dict[str, Any]:
    """The stages of an earlier run in ``path`` (none when absent or unreadable); a file that is not a
    benchmark's results is refused, never replaced."""
    if not path.is_file():
        if path.exists() or path.is_symlink():
            raise AuvlinkError(f"{path} is not a regular file; choose another --out")
        return {}
    try:
        previous = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    if not _is_bench_results(previous):
        raise AuvlinkError(f"{path} is not a benchmark results file (no 'stages' table) and would be replaced; "
                           "choose another --out")
    stages: dict[str, Any] = previous["stages"]
    return stages


def _machine() -> dict[str, Any]:
    common = _load("_common", "no benchmark helpers")
    info: dict[str, Any] = common.machine()
    return info


def run(args: argparse.Namespace) -> int:
    if args.report_only:
        print(f"report: {render_report(args.out)}")
        return 0
    stages = args.stages or available_stages()
    for stage in stages:
        if stage not in STAGES:
            raise AuvlinkError(f"unknown benchmark stage {stage!r}; choose from {', '.join(STAGES)}")
    if args.smoke:
        os.environ["AUVLINK_BENCH_SMOKE"] = "1"
    mode = "smoke" if args.smoke else "full" if args.full else "quick"
    if args.out.exists() and not args.out.is_dir():
        raise AuvlinkError(f"--out {args.out} is not a folder; choose a new or existing folder")
    args.out.mkdir(parents=True, exist_ok=True)
    previous = _previous_stages(args.out / "results.json")  # checked before the stages run (minutes)
    t_start = time.perf_counter()
    load_before = os.getloadavg()
    results: dict[str, Any] = {
        "mode": mode, "quick": not args.full,
        "command": " ".join(["auvlink bench", *args.stages, "--out", shlex.quote(str(args.out))]
                            + (["--full"] if args.full else []) + (["--smoke"] if args.smoke else [])),
        "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": _machine(), "loadavg_before": list(load_before), "stages": {},
    }
    failed = []
    for stage in stages:
        print(f"\n=== bench {stage} ({mode}) ===", flush=True)
        t0 = time.perf_counter()
        try:
            result = load_stage(stage).run(quick=not args.full, out_dir=args.out)
        except Exception as exc:  # a broken stage must not hide the others' figures
            traceback.print_exc()
            result = {"error": f"{type(exc).__name__}: {exc}"}
            failed.append(stage)
        result["wall_s"] = time.perf_counter() - t0
        result["mode"] = mode
        result["run_started_utc"] = results["started_utc"]  # stages merged from several runs stay traceable
        result["loadavg_1min"] = os.getloadavg()[0]
        # high-water mark of this process so far (a stage that raises it is the one that used the memory)
        result["bench_process_peak_rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
        results["stages"][stage] = result
    results["wall_s"] = time.perf_counter() - t_start
    results["loadavg_after"] = list(os.getloadavg())
    path = args.out / "results.json"
    results["stages"] = {**previous, **results["stages"]}
    write_text(path, json.dumps(to_jsonable(results), indent=2, allow_nan=False) + "\n")  # atomic: never half
    print(f"\nresults: {path}")
    print(f"report: {render_report(args.out)}")
    print(f"{len(stages)} stage(s) in {results['wall_s']:.1f} s; load average {load_before[0]:.2f} -> "
          f"{results['loadavg_after'][0]:.2f} on {os.cpu_count()} cores")
    if args.json:
        print(json.dumps(to_jsonable(results), allow_nan=False))
    if failed:
        print(f"failed stage(s): {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0
