"""``auvlink replay LOG.mcap --out DIR [--speed X | --fast]``: a mission log through the pipeline.

The raw frames go back through the same framers, codecs and drivers as live operation; then
navigation, reconstruction, clustering and classification. DIR receives ``detections.jsonl``,
``cloud.ply``, ``objects/*.ply`` (per point object id and time; ``--ply-frame zup`` for viewers that
want z up), ``results.mcap`` (Foxglove schemas: docs/VIEWER.md), ``summary.json`` and ``report.html``.
DIR is checked before any work (new or empty unless ``--force``, writable; never a folder where the
run would replace its log, ``--config`` or ``--model``: exit 2, :mod:`auvlink.pipeline.run_guard`), locked for the
run (a second run into it is refused) and filled in a temporary folder renamed when whole
(:func:`auvlink.atomic.atomic_dir`).
``--json``: one JSON object on stdout at the end (:func:`json_result`), nothing else there (progress and
warnings go to stderr).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path
from typing import Any

from auvlink.atomic import atomic_dir
from auvlink.clock import process_age_s
from auvlink.config import load_config
from auvlink.errors import AuvlinkError
from auvlink.jsonutil import dumps
from auvlink.pipeline.run_guard import output_dir_lock, refuse_input_overwrite


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("log", type=Path, help="mission log (.mcap)")
    p.add_argument("--out", type=Path, required=True, help="output folder")
    p.add_argument("--force", action="store_true", help="write into a non-empty DIR (files of the same names replaced)")
    pace = p.add_mutually_exclusive_group()
    pace.add_argument("--speed", type=float, default=None, help="replay at X times real time")
    pace.add_argument("--fast", action="store_true", help="as fast as possible (the default)")
    p.add_argument("--model", type=Path, default=None, help="classifier checkpoint (default: the shipped one)")
    p.add_argument("--no-classify", action="store_true", help="stop after clustering")
    p.add_argument("--no-report", action="store_true", help="skip report.html")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (counts, detections, outputs, timings) on stdout, nothing else")
    p.add_argument("--config", type=Path, default=None,
                   help="vehicle configuration (TOML) to use instead of the one the log stores")
    p.add_argument("--ply-frame", choices=("ned", "zup"), default="ned",
                   help="frame of the PLY files: ned (world frame, default) or zup (x east, y north, z up)")


def process(log: Path, out: Path, *, speed: float | None, model: Path | None, classify: bool,
            report: bool, progress: bool, config: Path | None = None, ply_frame: str = "ned") -> dict[str, object]:
    # lazy: the pipeline loads SciPy and matplotlib (the parser imports every subcommand module); the outputs and
    # the report (protobuf, the Foxglove schemas, the figures) only after the run, off the path to the first frame
    from auvlink.pipeline.process import run_log

    check_inputs(log, speed)
    vehicle = load_config(config) if config is not None else None
    age = process_age_s()  # s since this process started (interpreter, imports) when the run begins
    result = run_log(log, speed=speed, model=model, classify=classify, progress=progress, config=vehicle)
    if age is not None:  # the start-up to the first frame processed, as the user waits for it
        result.timings["first_frame_s"] = age + result.timings["start_up_s"]
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.report import write_report

    with atomic_dir(out) as tmp:
        summary = write_outputs(result, tmp, ply_frame=ply_frame)
        if report:
            write_report(result, summary, tmp)
    if report:
        summary["report"] = str(out / "report.html")
    return summary


def check_inputs(log: Path, speed: float | None) -> None:
    """What can be checked of the input before any work."""
    if not log.is_file():
        raise AuvlinkError(f"{log}: no such log")
    if speed is not None and not (math.isfinite(speed) and speed > 0):
        raise AuvlinkError(f"--speed must be a finite number > 0, got {speed} (leave it out, or --fast, for "
                           "as fast as possible)")


def engine_line(summary: dict[str, object]) -> str | None:
    """Frames processed, time per stage and what was skipped, in one line."""
    rec, tim, drops = summary.get("recon"), summary.get("timings"), summary.get("drops")
    if not isinstance(rec, dict) or not isinstance(tim, dict):
        return None
    stages = ", ".join(f"{k.removesuffix('_s')} {v:.1f} s" for k, v in tim.items() if k != "total_s")
    line = f"{rec.get('frames_processed', 0)} sonar frames processed; {stages}; total {tim.get('total_s', 0):.1f} s"
    if rec.get("frames_without_navigation"):
        line += f"; {rec['frames_without_navigation']} frames without navigation"
    if isinstance(drops, dict) and drops:
        line += f"; skipped as dropped live: {', '.join(f'{k} {v}' for k, v in drops.items())}"
    return line


def scores_line(summary: dict[str, object]) -> str | None:
    """One line of precision/recall against the ground truth, or None without truth."""
    s = summary.get("scores")
    if not isinstance(s, dict):
        return None
    return (f"against the truth: detection P/R {s['detection_precision']:.2f}/{s['detection_recall']:.2f}, "
            f"classification P/R {s['classification_precision']:.2f}/{s['classification_recall']:.2f}")


def json_result(command: str, log: Path, out: Path, summary: dict[str, Any]) -> dict[str, Any]:
    """The ``--json`` object of ``replay`` and ``demo``: counts (detections per class), one short line
    per detection (id, class, score, position NED m, points), the scores against the truth (when the
    log has it), the paths of the files in ``out`` by name and the timings (s)."""
    dets = [json.loads(line) for line in (out / "detections.jsonl").read_text().splitlines() if line.strip()]
    counts: dict[str, int] = {}
    for d in dets:
        counts[d["class"]] = counts.get(d["class"], 0) + 1
    scores, recon = summary.get("scores"), summary.get("recon")
    outputs = {p.name: str(p) for p in sorted(out.iterdir()) if not p.name.startswith(".")}  # all DIR holds
    return {
        "command": command, "log": str(log), "out": str(out),
        "counts": {"detections": len(dets), "by_class": dict(sorted(counts.items())),
                   "sonar_frames": recon.get("frames_processed") if isinstance(recon, dict) else None},
        "detections": [{k: d[k] for k in ("id", "class", "score", "position_ned", "size", "n_points")} for d in dets],
        "scores": {k: v for k, v in scores.items() if not isinstance(v, list | dict)} if isinstance(scores, dict)
        else None,
        "outputs": outputs,
        "timings": summary.get("timings"),
        "log_loss": summary.get("log_loss") or {"state": "complete"},  # the log's loss report (JSON)
    }


def loss_line(log: Path, summary: dict[str, object]) -> str | None:
    """One line when the log was damaged or cut off (what was lost, in seconds and messages), else None."""
    loss = summary.get("log_loss")
    if not isinstance(loss, dict) or loss.get("state", "complete") == "complete":
        return None
    return f"auvlink: warning: {log}: {loss.get('summary')}"


def run(args: argparse.Namespace) -> int:
    check_inputs(args.log, args.speed)
    refuse_input_overwrite([args.log, args.config, args.model], folder=("--out", args.out))
    with output_dir_lock(args.out, force=args.force):  # checked before any work (and before the heavy imports)
        summary = process(args.log, args.out, speed=args.speed, model=args.model, classify=not args.no_classify,
                          report=not args.no_report, progress=not args.quiet, config=args.config,
                          ply_frame=args.ply_frame)
    line = loss_line(args.log, summary)
    if line:
        print(line, file=sys.stderr)
    if args.json:
        sys.stdout.write(dumps(json_result("replay", args.log, args.out, summary)) + "\n")
        return 0
    print(f"{summary['detections']} objects -> {args.out / 'detections.jsonl'}")
    line = engine_line(summary)
    if line and not args.quiet:
        print(line)
    line = scores_line(summary)
    if line:
        print(line)
    if "report" in summary:
        print(f"report: {summary['report']}")
    return 0
