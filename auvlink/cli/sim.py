"""``auvlink sim``: simulate a mission into a log, or live on the virtual ports of a config file.

    auvlink sim [--scene SCENE.toml] --out LOG.mcap [--force] [--seed N] [--duration S] [--no-noise] [--workers N]
    auvlink sim [--scene SCENE.toml] --live CONFIG.toml [--speed X] [--duration S] [--seed N] [--no-noise]

Without ``--scene`` the scene shipped in the package is used. ``--out`` runs as fast as the machine
allows (a progress bar on stderr, a summary on stdout); ``--live`` serves the devices of the
config at ``--speed`` x real time until the survey ends, ``--duration`` passes or Ctrl-C / SIGTERM.
An existing ``--out`` is replaced only with ``--force``; the log is written as ``LOG.mcap.partial`` and
renamed when complete (a failed or interrupted run leaves ``LOG.mcap`` as it was).
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
from types import FrameType

from auvlink.atomic import check_output_file
from auvlink.config import load_config
from auvlink.sim.scene import Scene, load_default_scene, load_scene


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--scene", help="scene file (TOML); default: the scene shipped in the package")
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--out", help="write the simulated mission to this log (.mcap), as fast as possible")
    mode.add_argument("--live", metavar="CONFIG", help="serve the devices of this vehicle config in real time")
    parser.add_argument("--force", action="store_true", help="--out: replace an existing log")
    parser.add_argument("--seed", type=int, default=None, help="seed of every random draw (default: the scene's)")
    parser.add_argument("--duration", type=float, default=None, help="seconds of mission (default: the survey)")
    parser.add_argument("--no-noise", action="store_true", help="noise-free sensors (truth + wire quantization)")
    parser.add_argument("--speed", type=float, default=1.0, help="--live: times real time (default 1)")
    parser.add_argument("--workers", type=int, default=None,
                        help="--out: worker processes (default: 2 for long missions, else 1)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar and no summary")


def _scene(path: str | None) -> Scene:
    return load_default_scene() if path is None else load_scene(path)


def _to_log(args: argparse.Namespace) -> int:
    from auvlink.sim.mission import simulate_to_log  # lazy: Open3D and trimesh (the parser imports every subcommand)

    check_output_file(args.out, force=args.force, inputs=[args.scene], what="log")
    result = simulate_to_log(_scene(args.scene), args.out, seed=args.seed, progress=not args.quiet,
                             duration=args.duration, noise=False if args.no_noise else None,
                             workers=args.workers)
    if not args.quiet:
        total = sum(result.frames.values())
        print(f"{result.path}: {result.duration_s:.1f} s of mission, {total} frames in {result.wall_s:.1f} s "
              f"({result.sonar_fps:.0f} sonar frames/s, {result.workers} worker(s))")
        for name, n in result.frames.items():
            print(f"  {name:<10} {n:>9} frames")
    return 0


def _live(args: argparse.Namespace) -> int:
    from auvlink.sim.device_server import serve  # lazy: Open3D and trimesh (the parser imports every subcommand)

    config = load_config(args.live)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        result = serve(_scene(args.scene), config, speed=args.speed, duration=args.duration, seed=args.seed,
                       noise=False if args.no_noise else None, stop=stop,
                       out=None if args.quiet else sys.stdout)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if not args.quiet:
        print(f"auvlink sim: stopped after {result.seconds:.1f} s")
        if result.late_frames:
            print(f"  behind real time: {result.late_frames} frames late, by up to {result.behind_s:.2f} s "
                  "(a machine too busy for this speed: readers see these frames late)")
        for p in result.ports:
            print(f"  {p.device:<10} {p.frames:>8} frames {p.bytes:>11} bytes {p.dropped:>6} dropped")
    return 0


def run(args: argparse.Namespace) -> int:
    return _live(args) if args.live else _to_log(args)
