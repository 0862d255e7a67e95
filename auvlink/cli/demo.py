"""``auvlink demo``: the shipped scene -> simulated mission log -> replay -> report. No arguments needed.

The images are those of the flown sonar (DIDSON by default, ``--sonar``): rendered under that model's acoustic
profile (beam pattern, sidelobes, pulse, gain, TVG) unless the scene's ``[acoustics]`` table or ``--acoustics``
names another (``ideal``: the idealized model).

The output folder (default ``demo-out``) must be new or empty unless ``--force``, never holds the
``--scene`` at a name the demo writes (exit 2) and is locked for the run; the log and the replay
outputs are each written under a temporary name and renamed when whole. ``--json``: one JSON
object on stdout at the end (as ``auvlink replay --json``); the progress lines go to stderr then.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from auvlink.atomic import check_output_file
from auvlink.jsonutil import dumps
from auvlink.pipeline.run_guard import output_dir_lock, refuse_input_overwrite
from auvlink.sim.acoustics import PROFILES
from auvlink.sim.scene import SIMULATED_MODELS, load_default_scene, load_scene, with_acoustics, with_sonar_model


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", type=Path, default=Path("demo-out"), help="output folder (default demo-out)")
    p.add_argument("--scene", type=Path, default=None, help="scene TOML (default: the shipped scene)")
    p.add_argument("--seed", type=int, default=None, help="override the scene's seed")
    p.add_argument("--sonar", choices=SIMULATED_MODELS, default=None,
                   help="fly this sonar model (high-frequency mode; default: the scene's, the shipped scene's DIDSON)")
    p.add_argument("--acoustics", choices=PROFILES, default=None, metavar="PROFILE",
                   help="the acoustic profile the images are rendered under: ideal (the idealized model) or "
                        f"{', '.join(PROFILES[1:])} (default: the scene's [acoustics] table; the shipped scene, or "
                        "a scene without one, the flown sonar model's own: the images that sonar makes)")
    p.add_argument("--force", action="store_true", help="write into a non-empty output folder (replacing its files)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object (counts, detections, outputs, timings) on stdout, nothing else")


DEMO_LOG = "mission.mcap"


def run(args: argparse.Namespace) -> int:
    log = args.out / DEMO_LOG
    refuse_input_overwrite([args.scene], files=[("--out", log)], folder=("--out", args.out))
    with output_dir_lock(args.out, force=args.force):  # before any work (and before the heavy imports)
        check_output_file(log, force=True, inputs=[args.scene], what="log")  # a leftover mission.mcap.partial
        return _run(args, log)


def _run(args: argparse.Namespace, log: Path) -> int:
    # lazy: Open3D, trimesh, SciPy and matplotlib (the parser imports every subcommand module)
    from auvlink.cli.replay import json_result, process, scores_line
    from auvlink.sim.mission import simulate_to_log

    say = sys.stderr if args.json else sys.stdout  # with --json, stdout carries the JSON object only

    scene = load_scene(args.scene) if args.scene else load_default_scene()
    if args.sonar is not None:
        scene = with_sonar_model(scene, args.sonar)
    scene = with_acoustics(scene, args.acoustics)
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    print(f"[1/2] simulating the mission -> {log}", file=say)
    simulate_to_log(scene, log, seed=args.seed, progress=True)
    t1 = time.perf_counter()
    print(f"      {t1 - t0:.1f} s", file=say)
    print(f"[2/2] replaying through the pipeline -> {args.out}", file=say)
    summary = process(log, args.out, speed=None, model=None, classify=True, report=True, progress=True)
    print(f"      {time.perf_counter() - t1:.1f} s; {summary['detections']} objects detected", file=say)
    line = scores_line(summary)
    if line:
        print(f"      {line}", file=say)
    print(f"report: {(args.out / 'report.html').resolve()}", file=say)
    if args.json:
        result = json_result("demo", log, args.out, summary)
        result["timings"] = {**(result["timings"] or {}), "simulation_s": t1 - t0}
        sys.stdout.write(dumps(result) + "\n")
    return 0
