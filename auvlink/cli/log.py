"""``auvlink log info|export|import``: inspect, export and import mission logs.

    auvlink log info LOG.mcap [--json]
    auvlink log export LOG.mcap --out DIR [--force] [--every N] [--max-sonar N] [--channels a,b] [--no-nav]
    auvlink log import CAPTURE.bin --format FMT --out LOG.mcap [--force] [--rate HZ] [--device NAME]
    auvlink log import CANLOG.asc|.blf --out LOG.mcap [--force] [--device NAME]

Outputs are checked before any work: an existing ``--out`` (a non-empty folder for ``export``) is
replaced only with ``--force``; an output that is or would replace the input (``import X --out X``,
its ``.partial``, ``export DIR/a.csv --out DIR``: exit 2, :mod:`auvlink.pipeline.run_guard`) is refused even with
it; ``export`` holds its folder's lock for the run; the output is written under a temporary name (a
temporary folder for ``export``) renamed when whole.

``export`` writes a CSV per navigation channel, every ``--every``-th sonar frame as a fan PNG (default
25: about 80 PNGs for a 3-minute mission at 11 frames/s; ``--every 1`` for all) and ``navigation.csv``,
the navigation solution exactly as ``auvlink replay`` computes it (:mod:`auvlink.pipeline.navigation`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from auvlink.atomic import atomic_dir, check_output_file
from auvlink.jsonutil import to_jsonable
from auvlink.pipeline.run_guard import output_dir_lock, refuse_input_overwrite
from logs_format.export import export_log
from logs_format.importers import import_can_log, import_serial_capture, is_can_log
from logs_format.info import format_info, log_info
from logs_format.profile import LogError

#: ``log export --every`` default: a 3-minute mission at ~11 frames/s gives ~80 fan PNGs, not ~2,000
DEFAULT_EVERY = 25


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="log_command", metavar="ACTION", required=True)
    info = sub.add_parser("info", help="duration, per channel count, rate, gaps, decode errors, metadata")
    info.add_argument("log")
    info.add_argument("--json", action="store_true", help="print the JSON form (duration_s, channels, ...)")
    info.add_argument("--no-decode", action="store_true", help="skip decoding (no decode-error counts)")
    info.add_argument("--gap-factor", type=float, default=3.0, help="a gap is > K x the median period")
    exp = sub.add_parser("export", help="navigation as CSV, sonar frames as fan-shaped PNG images")
    exp.add_argument("log")
    exp.add_argument("--out", required=True, help="output folder")
    exp.add_argument("--force", action="store_true", help="write into a non-empty folder (same names replaced)")
    exp.add_argument("--channels", default=None, help="comma-separated channel names (default: all)")
    exp.add_argument("--every", "--sonar-every", dest="every", type=int, default=DEFAULT_EVERY,
                     help=f"export every N-th sonar frame as PNG (default {DEFAULT_EVERY}; 1 for all)")
    exp.add_argument("--max-sonar", type=int, default=None, help="at most N sonar frames per channel")
    exp.add_argument("--no-png", action="store_true", help="CSV only")
    exp.add_argument("--no-nav", action="store_true", help="no navigation.csv (the replay's navigation solution)")
    imp = sub.add_parser("import", help="a python-can log or a raw serial capture -> a mission log")
    imp.add_argument("file")
    imp.add_argument("--out", required=True, help="mission log to write (.mcap)")
    imp.add_argument("--force", action="store_true", help="replace an existing --out")
    imp.add_argument("--format", default=None, help="wire format of a raw capture (pd0, dsp1760, ...)")
    imp.add_argument("--device", default=None, help="channel name (default: the format, or 'can')")
    imp.add_argument("--rate", type=float, default=None, help="synthetic frame rate in Hz for a raw capture")
    imp.add_argument("--compression", choices=("zstd", "lz4", "none"), default="zstd")


def _check_input(path: str | Path, what: str) -> None:
    """Refuse an input that is missing or not a regular file (a folder; a FIFO or device would block or never end)."""
    p = Path(path)
    if not p.is_file():
        why = "not a regular file (a folder, FIFO or device)" if p.exists() else "no such file"
        raise LogError(f"cannot open {what} {path}: {why}; give a "
                       f"{'mission log (.mcap)' if what == 'log' else 'capture file'}")


def _info(args: argparse.Namespace) -> int:
    _check_input(args.log, "log")
    if not (math.isfinite(args.gap_factor) and args.gap_factor > 1):
        raise LogError(f"--gap-factor must be a number > 1 (a gap is longer than K median periods), "
                       f"got {args.gap_factor}")
    info = log_info(args.log, decode=not args.no_decode, gap_factor=args.gap_factor)
    if args.json:
        print(json.dumps(to_jsonable(info), indent=2, allow_nan=False))
    else:
        print(format_info(info))
    return 0


def _export(args: argparse.Namespace) -> int:
    _check_input(args.log, "log")
    if args.every < 1:
        raise LogError(f"--every must be >= 1, got {args.every}")
    if args.max_sonar is not None and args.max_sonar < 0:
        raise LogError(f"--max-sonar must be >= 0 (0: no sonar frames), got {args.max_sonar}")
    # export writes <channel>.csv, navigation.csv and a folder per sonar channel (replaced whole)
    refuse_input_overwrite([args.log], folder=("--out", args.out),
                           writes=lambda rel: len(rel.parts) > 1 or rel.suffix in (".csv", ".png"))
    with output_dir_lock(args.out, force=args.force):
        return _export_into(args)


def _export_into(args: argparse.Namespace) -> int:
    channels = [c for c in args.channels.split(",") if c] if args.channels else None
    nav_rows: int | None = None
    with atomic_dir(args.out) as tmp:
        result = export_log(args.log, tmp, channels=channels, sonar_every=args.every,
                            max_sonar_frames=args.max_sonar, png=not args.no_png)
        if not args.no_nav:
            # lazy: the pipeline loads SciPy and the engine (the parser imports every subcommand module)
            from auvlink.errors import AuvlinkError
            from auvlink.pipeline.navigation import navigation_solution, write_navigation_csv

            try:
                nav = navigation_solution(Path(args.log))
                nav_rows = write_navigation_csv(nav, tmp / "navigation.csv")
            except AuvlinkError as exc:
                print(f"  navigation.csv not written: {exc}", file=sys.stderr)
    if nav_rows is not None:
        print(f"  navigation.csv: {nav_rows} rows (the replay's navigation solution; positions: {nav.frame})")
    for name, rows in result.csv_rows.items():
        print(f"  {name}.csv: {rows} rows")
    for name, n in result.png_frames.items():
        print(f"  {name}/: {n} PNG frames")
    if result.loss != "complete":
        print(f"  log: {result.loss}", file=sys.stderr)
    return 0


def _import(args: argparse.Namespace) -> int:
    _check_input(args.file, "file")
    check_output_file(args.out, force=args.force, inputs=[args.file], what="log")
    if args.format is None:
        if not is_can_log(args.file):
            raise LogError(f"{args.file}: give --format FMT for a raw capture (or a python-can log file)")
        result = import_can_log(args.file, args.out, device=args.device or "can",
                                compression=args.compression)
    else:
        result = import_serial_capture(args.file, args.format, args.out, device=args.device,
                                       rate_hz=args.rate, compression=args.compression)
    print(f"{result.out}: {result.frames} frames" + (f", {result.skipped} skipped" if result.skipped else ""))
    return 0


def run(args: argparse.Namespace) -> int:
    return {"info": _info, "export": _export, "import": _import}[args.log_command](args)
