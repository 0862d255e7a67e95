"""``auvlink live CONFIG.toml [--out DIR]``: the onboard pipeline on the ports of a vehicle configuration.

Opens every port of the configuration, records the mission log (``DIR/mission.mcap`` unless
``--log``) and runs drivers -> causal navigation -> reconstruction -> streaming clustering ->
classification as the data comes, writing each object to ``DIR/detections.jsonl`` when it is final.
A port that goes is reopened with backoff (the log marks the gap). Ctrl-C / SIGTERM (or the end of
``--duration``) flush everything: DIR gets ``cloud.ply``, ``summary.json`` and ``report.html``, the
log its last chunk. DIR must be new or empty unless ``--force`` (an existing ``--log`` likewise) and is
locked for the run; the ``--log`` is never a file the run writes in DIR (``--log DIR/results.mcap``: the
raw mission would be replaced by the viewer file at the end), nor the ``--config`` or ``--model`` (exit
2, :mod:`auvlink.pipeline.run_guard`); the log is ``mission.mcap.partial`` until it is closed. A full disk stops the
run with one line, exit 1, and DIR still gets every file that can be written. See docs/LIVE.md for real hardware.
"""

from __future__ import annotations

import argparse
import shutil
import signal
import sys
import threading
from pathlib import Path
from types import FrameType

from auvlink.atomic import check_output_file
from auvlink.cli.replay import scores_line
from auvlink.errors import AuvlinkError
from auvlink.pipeline.run_guard import output_dir_lock, refuse_input_overwrite


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("config", type=Path, help="vehicle configuration (TOML: [[devices]] name, format, url, ...)")
    p.add_argument("--out", type=Path, default=Path("live-out"), help="output folder (default live-out)")
    p.add_argument("--log", type=Path, default=None, help="mission log to write (default DIR/mission.mcap)")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty DIR (files of the same names are replaced) and over --log")
    p.add_argument("--duration", type=float, default=None, help="stop after S seconds (default: until Ctrl-C)")
    p.add_argument("--model", type=Path, default=None, help="classifier checkpoint (default: the shipped one)")
    p.add_argument("--no-classify", action="store_true", help="stop after clustering")
    p.add_argument("--no-report", action="store_true", help="skip report.html")
    p.add_argument("--sonar-queue", type=int, default=10,
                   help="sonar frames waiting for the engine before new ones are dropped (default 10)")
    p.add_argument("--backoff-max", type=float, default=5.0,
                   help="longest wait between two attempts to reopen a lost port, s (default 5)")
    p.add_argument("--quiet", action="store_true", help="no line per detection")
    p.add_argument("--ply-frame", choices=("ned", "zup"), default="ned",
                   help="frame of the PLY files: ned (world frame, default) or zup (x east, y north, z up)")


def run(args: argparse.Namespace) -> int:
    if not args.config.is_file():
        raise AuvlinkError(f"{args.config}: no such configuration file")
    if not args.backoff_max > 0:
        raise AuvlinkError(f"--backoff-max must be > 0, got {args.backoff_max}")
    if args.sonar_queue < 1:
        raise AuvlinkError(f"--sonar-queue must be >= 1, got {args.sonar_queue}")
    log = args.log or args.out / "mission.mcap"
    refuse_input_overwrite([args.config, args.model], files=[("--log", log)], folder=("--out", args.out))
    refuse_input_overwrite([log], folder=("--out", args.out))  # the log is the next run's input
    with output_dir_lock(args.out, force=args.force):
        check_output_file(log, force=args.force, inputs=[args.config, args.model], option="--log", what="log")
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    # lazy: the pipeline loads SciPy and matplotlib (the parser imports every subcommand module)
    from auvlink.pipeline.live import LiveRun
    from auvlink.pipeline.report import write_report
    from auvlink.pipeline.results import Detection

    objects = args.out / "objects"
    if args.force and objects.is_dir() and not objects.is_symlink():
        shutil.rmtree(objects)  # replaced whole, as replay does: no PLY of the last run beside the new ones
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    def show(d: Detection) -> None:
        if not args.quiet:
            print(f"object {d.id}: {d.class_name} ({d.score:.2f}) at N {d.position_ned[0]:.1f} "
                  f"E {d.position_ned[1]:.1f} m, {d.n_points} points", flush=True)

    def announce() -> None:
        print(f"auvlink live: the ports of {args.config} opening; log {args.log or args.out / 'mission.mcap'}, "
              f"out {args.out}; Ctrl-C stops", flush=True)

    live = LiveRun(args.config, args.out, log_path=args.log, duration=args.duration, stop=stop,
                   classify=not args.no_classify, model=args.model, sonar_queue=args.sonar_queue,
                   on_detection=show, backoff_max=args.backoff_max, on_ready=announce, ply_frame=args.ply_frame)
    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        result = live.run()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    summary = live.summary
    if not args.no_report:
        try:
            print(f"report: {write_report(result, summary, args.out)}")
        except OSError as exc:  # a full disk: what could be written is written; say what is missing
            live.fatal = "; ".join(filter(None, [live.fatal, f"report.html not written ({exc.strerror or exc})"]))
    lat = result.latency.get("frame_end_to_end")
    frames = result.recon_stats.get("frames_processed", 0)
    print(f"{len(result.detections)} objects -> {args.out / 'detections.jsonl'}; log {live.log_path}")
    if lat:
        print(f"sonar frames: {frames} processed, latency p50 {lat['p50_ms']:.0f} ms, p99 {lat['p99_ms']:.0f} ms; "
              f"dropped {sum(result.drops.values())}")
    gaps = [e for e in result.events if e["kind"] in ("port_lost", "open_failed")]
    if gaps:
        print(f"port gaps: {len(gaps)} ({', '.join(sorted({e['device'] for e in gaps}))}); see summary.json events")
    line = scores_line(summary)
    if line:
        print(line)
    if live.fatal:
        written = "written where it could be" if "not written" in live.fatal else "written"
        print(f"auvlink: error: {live.fatal}; stopped cleanly, {args.out} {written}, the log replays up to its "
              "last complete chunk", file=sys.stderr)
        return 1
    return 0
