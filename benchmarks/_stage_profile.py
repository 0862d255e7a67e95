"""The profile of one pipeline stage of a replay: where that stage's seconds go, function by function.

Run: ``python benchmarks/_stage_profile.py LOG STAGE OUT.json [TOP]`` (``bench e2e`` runs it on its survey log for the
slowest stage of the replay it timed). The log is replayed in this process (:func:`auvlink.pipeline.process.run_log`,
what ``auvlink replay`` runs) under one :class:`cProfile.Profile` that is switched on only while the stage's entry
points run (:data:`ENTRY_POINTS`, the code each ``summary.json`` timing measures), so the other stages do not appear
in it. The answer: the stage's profiled seconds and its top functions by cumulative time (``ncalls``, ``tottime_s``,
``cumtime_s``, ``function`` as ``file:line(name)``).
"""

from __future__ import annotations

import cProfile
import importlib
import json
import pstats
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

#: summary.json timing -> the (module, class, method) it measures (a generator method is profiled per item)
ENTRY_POINTS: dict[str, list[tuple[str, str, str]]] = {
    "replay_decode_s": [("logs_format.replay", "Replay", "samples")],
    "navigation_s": [("auvlink.pipeline.engine", "Engine", "_navigate")],
    "reconstruction_s": [("recon.reconstructor", "Reconstructor", "add_frames")],
    "clustering_s": [("recon.reconstructor", "Reconstructor", "poll"), ("recon.reconstructor", "Reconstructor",
                                                                         "finish")],
    "classification_s": [("auvlink.pipeline.object_labels", "ObjectLabeller", "label")],
}
TOP = 15  # functions reported


def slowest_stage(timings: dict[str, float]) -> str | None:
    """The profiled stage (:data:`ENTRY_POINTS`) with the most seconds in ``timings`` (None: none timed)."""
    timed = {k: v for k, v in timings.items() if k in ENTRY_POINTS}
    return max(timed, key=lambda k: timed[k]) if timed else None


class _Switch:
    """One profiler, on while any wrapped entry point runs (nested calls keep it on)."""

    def __init__(self) -> None:
        self.profile = cProfile.Profile()
        self.depth = 0

    def on(self) -> None:
        if self.depth == 0:
            self.profile.enable()
        self.depth += 1

    def off(self) -> None:
        self.depth -= 1
        if self.depth == 0:
            self.profile.disable()

    def wrap(self, fn: Callable[..., Any], generator: bool) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            self.on()
            try:
                return fn(*args, **kwargs)
            finally:
                self.off()

        def items(*args: Any, **kwargs: Any) -> Iterator[Any]:
            it = fn(*args, **kwargs)
            while True:
                self.on()
                try:
                    item = next(it)
                except StopIteration:
                    return
                finally:
                    self.off()
                yield item

        return items if generator else call


def profile_stage(log: Path, stage: str, top: int = TOP) -> dict[str, Any]:
    """Replay ``log`` with the profiler on for ``stage`` only; its seconds and top functions (see the module doc)."""
    import inspect

    from auvlink.pipeline.process import run_log

    if stage not in ENTRY_POINTS:
        raise ValueError(f"stage {stage!r} has no entry point; one of {', '.join(ENTRY_POINTS)}")
    switch = _Switch()
    saved: list[tuple[Any, str, Any]] = []
    for module, cls_name, method in ENTRY_POINTS[stage]:
        cls = getattr(importlib.import_module(module), cls_name)
        fn = cls.__dict__[method]
        saved.append((cls, method, fn))
        setattr(cls, method, switch.wrap(fn, inspect.isgeneratorfunction(fn)))
    try:
        result = run_log(log, progress=False)
    finally:
        for cls, method, fn in saved:
            setattr(cls, method, fn)
    stats = pstats.Stats(switch.profile)
    rows = sorted(stats.stats.items(), key=lambda kv: kv[1][3], reverse=True)  # type: ignore[attr-defined]
    funcs = [{"function": f"{Path(f).name}:{line}({name})", "ncalls": int(nc), "tottime_s": round(tt, 4),
              "cumtime_s": round(ct, 4)} for (f, line, name), (_, nc, tt, ct, _) in rows[:top]]
    return {"stage": stage, "stage_s_in_profiled_run": float(result.timings.get(stage, 0.0)),
            "profiled_s": float(stats.total_tt), "top": funcs}  # type: ignore[attr-defined]


def run_child(log: Path, stage: str, work: Path, top: int = TOP,
              timeout_s: float | None = None) -> dict[str, Any] | None:
    """:func:`profile_stage` in a child process (this script; a fresh process, as ``auvlink replay`` runs, with no
    signal handler or tracer of its parent's); None when the child failed or ran past ``timeout_s`` (killed; its
    output in ``work/stage-profile.log``)."""
    import subprocess

    out = work / "stage-profile.json"
    with open(work / "stage-profile.log", "wb") as f:
        try:
            rc = subprocess.run([sys.executable, str(Path(__file__)), str(log), stage, str(out), str(top)],
                                stdout=f, stderr=subprocess.STDOUT, check=False, timeout=timeout_s).returncode
        except subprocess.TimeoutExpired:
            return None
    return json.loads(out.read_text()) if rc == 0 and out.is_file() else None


def profile_in_child(log: Path, timings: dict[str, float], work: Path) -> dict[str, Any] | None:
    """:func:`run_child` for the slowest stage of ``timings``; None when no stage was timed or the child failed."""
    stage = slowest_stage(timings)
    return None if stage is None else run_child(log, stage, work)


def main(argv: list[str]) -> int:
    if len(argv) not in (3, 4):
        print("usage: _stage_profile.py LOG STAGE OUT.json [TOP]", file=sys.stderr)
        return 2
    out = profile_stage(Path(argv[0]), argv[1], top=int(argv[3]) if len(argv) == 4 else TOP)
    Path(argv[2]).write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
