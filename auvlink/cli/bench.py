"""``auvlink bench [STAGE ...] --out DIR [--full] [--json]``: run the benchmark scripts.

Each stage is a script ``benchmarks/bench_<stage>.py`` in the repository with
``run(quick: bool, out_dir: Path) -> dict``; it prints its own table and writes ``<stage>.json``.
This command runs the chosen stages (all by default), then writes ``DIR/results.json``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import time
from pathlib import Path
from types import ModuleType
from typing import Any

from auvlink.errors import AuvlinkError
from auvlink.jsonutil import to_jsonable

STAGES = ("decode", "log", "sim", "recon", "classify", "e2e")


def benchmarks_dir() -> Path:
    """The repository's ``benchmarks/`` folder (the package is installed editable from it)."""
    return Path(__file__).resolve().parents[2] / "benchmarks"


def load_stage(stage: str) -> ModuleType:
    path = benchmarks_dir() / f"bench_{stage}.py"
    if not path.is_file():
        raise AuvlinkError(f"no benchmark for stage {stage!r} ({path} is missing)")
    if str(path.parent) not in sys.path:  # the scripts import their helpers (_common, peers) by name
        sys.path.insert(0, str(path.parent))
    spec = importlib.util.spec_from_file_location(f"auvlink_bench_{stage}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def available_stages() -> list[str]:
    return [s for s in STAGES if (benchmarks_dir() / f"bench_{s}.py").is_file()]


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("stages", nargs="*", metavar="STAGE", help=f"stages to run (default: all of {STAGES})")
    p.add_argument("--out", type=Path, default=Path("bench-out"), help="output folder (default bench-out)")
    p.add_argument("--full", action="store_true", help="the long version (bigger inputs, more repeats)")
    p.add_argument("--json", action="store_true", help="print results.json on stdout at the end")


def run(args: argparse.Namespace) -> int:
    stages = args.stages or available_stages()
    for stage in stages:
        if stage not in STAGES:
            raise AuvlinkError(f"unknown benchmark stage {stage!r}; choose from {', '.join(STAGES)}")
    args.out.mkdir(parents=True, exist_ok=True)
    results: dict[str, Any] = {"quick": not args.full, "stages": {}}
    for stage in stages:
        module = load_stage(stage)
        print(f"\n=== bench {stage} ===", flush=True)
        t0 = time.perf_counter()
        result = module.run(quick=not args.full, out_dir=args.out)
        result["wall_s"] = time.perf_counter() - t0
        results["stages"][stage] = result
    path = args.out / "results.json"
    previous: dict[str, Any] = {}
    if path.is_file():
        try:
            previous = json.loads(path.read_text()).get("stages", {})
        except (OSError, ValueError):
            previous = {}
    results["stages"] = {**previous, **results["stages"]}
    path.write_text(json.dumps(to_jsonable(results), indent=2, allow_nan=False) + "\n")
    print(f"\nresults: {path}")
    if args.json:
        print(json.dumps(to_jsonable(results), allow_nan=False))
    return 0
