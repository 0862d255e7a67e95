"""``auvlink replay LOG.mcap --out DIR [--speed X | --fast]``: a mission log through the pipeline.

The raw frames go back through the same framers, codecs and drivers as live operation; then
navigation, reconstruction, clustering and classification. DIR receives ``detections.jsonl``,
``cloud.ply``, ``objects/*.ply``, ``summary.json`` and ``report.html``. DIR is checked before any work
(new or empty unless ``--force``, writable) and filled in a temporary folder renamed when whole
(:func:`auvlink.atomic.atomic_dir`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from auvlink.atomic import atomic_dir, check_output_dir
from auvlink.config import load_config
from auvlink.errors import AuvlinkError


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
    p.add_argument("--config", type=Path, default=None,
                   help="vehicle configuration (TOML) to use instead of the one the log stores")


def process(log: Path, out: Path, *, speed: float | None, model: Path | None, classify: bool,
            report: bool, progress: bool, config: Path | None = None) -> dict[str, object]:
    # lazy: the pipeline loads SciPy and matplotlib (the parser imports every subcommand module)
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.process import run_log
    from auvlink.pipeline.report import write_report

    check_inputs(log, speed)
    vehicle = load_config(config) if config is not None else None
    result = run_log(log, speed=speed, model=model, classify=classify, progress=progress, config=vehicle)
    with atomic_dir(out) as tmp:
        summary = write_outputs(result, tmp)
        if report:
            write_report(result, summary, tmp)
    if report:
        summary["report"] = str(out / "report.html")
    return summary


def check_inputs(log: Path, speed: float | None) -> None:
    """What can be checked of the input before any work."""
    if not log.is_file():
        raise AuvlinkError(f"{log}: no such log")
    if speed is not None and speed <= 0:
        raise AuvlinkError(f"--speed must be > 0, got {speed}")


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


def loss_line(log: Path, summary: dict[str, object]) -> str | None:
    """One line when the log was damaged or cut off (what was lost, in seconds and messages), else None."""
    loss = summary.get("log_loss")
    if not isinstance(loss, dict) or loss.get("state", "complete") == "complete":
        return None
    return f"auvlink: warning: {log}: {loss.get('summary')}"


def run(args: argparse.Namespace) -> int:
    check_inputs(args.log, args.speed)
    check_output_dir(args.out, force=args.force)  # before any work (and before the heavy imports)
    summary = process(args.log, args.out, speed=args.speed, model=args.model, classify=not args.no_classify,
                      report=not args.no_report, progress=not args.quiet, config=args.config)
    line = loss_line(args.log, summary)
    if line:
        print(line, file=sys.stderr)
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
