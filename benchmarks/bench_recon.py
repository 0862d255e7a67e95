"""Reconstruction: highlight extraction + projection frames/s, knobs against error, DBSCAN peers.

Run: ``auvlink bench recon --out DIR`` (or ``python benchmarks/bench_recon.py --out DIR [--full]``).
The survey is synthetic until the simulator is wired in: a 1 m/s straight line at 5 m altitude,
10 frames/s, 512 x 96 frames from :mod:`recon.synthetic` (a ray caster on analytic shapes), objects
every ~15 m so that most frames show only seabed. Everything runs on one thread (threadpoolctl);
errors are distances of the reconstructed points to the true object surfaces.
"""

from __future__ import annotations

import contextlib
import os
import time
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np
from _common import best_time, script_main, table, write_json

from recon.cluster import dbscan_labels
from recon.highlight import HighlightConfig, extract
from recon.pipeline import ReconConfig, Reconstructor
from recon.sonar_geometry import SonarGeometry, paper_minus_exact
from recon.synthetic import Box, Scene, Sphere, render, surface_distance
from recon.trajectory import Trajectory

GEOM = SonarGeometry.from_degrees(30.0, 14.0, lever_arm=(0.8, 0.0, 0.2))


def survey(n_frames: int, seed: int = 7) -> tuple[Scene, Trajectory, np.ndarray, np.ndarray]:
    """A straight line with an object every ~15 m (alternating box / sphere, offset across track)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n_frames) * 0.1
    length = t[-1] * 1.0
    boxes, spheres = [], []
    for k, x in enumerate(np.arange(12.0, length - 2.0, 15.0)):
        y = float(rng.uniform(-0.8, 0.8))
        if k % 2:
            spheres.append(Sphere((x, y, 19.5), 0.5))
        else:
            boxes.append(Box((x, y, 19.7), (1.2, 0.8, 0.6), float(rng.uniform(0, np.pi))))
    # Rayleigh speckle (scale 12 grey levels) and weaker echoes than the test scenes: the knobs matter
    scene = Scene(spheres=tuple(spheres), boxes=tuple(boxes), rayleigh=True, noise_level=12, seabed_level=90,
                  object_level=130)
    pos = np.column_stack([t, np.zeros_like(t), np.full_like(t, 15.0)])
    z = np.zeros_like(t)
    traj = Trajectory.from_euler(t, pos, z, z, z, altitude=np.full_like(t, 5.0))
    imgs = np.stack([render(GEOM, pos[i], traj.rotations[i], scene, rng)[0] for i in range(n_frames)])
    return scene, traj, t, imgs


def _errors(points: np.ndarray, scene: Scene) -> dict[str, Any]:
    if points.shape[0] == 0:
        return {"points": 0, "mean_m": None, "p95_m": None, "far_pct": None}
    d = surface_distance(points, scene)
    return {"points": int(points.shape[0]), "mean_m": float(d.mean()), "p95_m": float(np.percentile(d, 95)),
            "far_pct": float(100.0 * (d > 0.3).mean())}


def throughput(traj: Trajectory, t: np.ndarray, imgs: np.ndarray, quick: bool) -> list[dict[str, Any]]:
    """frames/s of the extraction stage and of the whole per-frame pipeline, skip on and off."""
    rows = []
    n = t.size
    pos, rot = traj.pose_at(t)
    onset = GEOM.flat_onset_ranges(pos, rot, traj.altitude_at(t))
    reps = 3 if quick else 7
    for skip in (True, False):
        cfg = HighlightConfig(skip=skip)
        def stack(cfg: HighlightConfig = cfg) -> None:
            extract(imgs, pos, rot, onset, GEOM, cfg)

        sec = best_time(stack, reps)
        rows.append({"what": "extract+project, one stack", "skip": skip, "frames": n, "seconds": sec,
                     "frames_per_s": n / sec})
        block = 64

        def blocks(cfg: HighlightConfig = cfg, block: int = block) -> None:
            rc = Reconstructor(GEOM, traj, ReconConfig(highlight=cfg))
            for k in range(0, n, block):
                rc.add_frames(t[k : k + block], imgs[k : k + block])

        sec = best_time(blocks, reps)
        rows.append({"what": f"Reconstructor.add_frames, blocks of {block}", "skip": skip, "frames": n,
                     "seconds": sec, "frames_per_s": n / sec})
        m = min(n, 300)

        def single(cfg: HighlightConfig = cfg, m: int = m) -> None:
            rc = Reconstructor(GEOM, traj, ReconConfig(highlight=cfg))
            for k in range(m):
                rc.add_frame(t[k], imgs[k])

        sec = best_time(single, max(1, reps - 2))
        rows.append({"what": "Reconstructor.add_frame, one at a time", "skip": skip, "frames": m,
                     "seconds": sec, "frames_per_s": m / sec})
    return rows


def knobs(scene: Scene, traj: Trajectory, t: np.ndarray, imgs: np.ndarray, quick: bool
          ) -> list[dict[str, Any]]:
    """Run time against error for threshold k, geometry, skip, dtype and the front-slope correction."""
    base = ReconConfig()
    variants: list[tuple[str, ReconConfig]] = [("default (k=8, exact, skip, f64, front slope)", base)]
    for k in (4.0, 6.0, 12.0):
        variants.append((f"k={k:g}", replace(base, highlight=replace(base.highlight, k=k))))
    variants += [
        ("geometry=paper", replace(base, highlight=replace(base.highlight, geometry="paper"))),
        ("skip off", replace(base, highlight=replace(base.highlight, skip=False))),
        ("float32", replace(base, highlight=replace(base.highlight, dtype="float32"))),
        ("front slope off", replace(base, front_slope=False)),
        ("paper, front slope off", replace(base, front_slope=False,
                                           highlight=replace(base.highlight, geometry="paper"))),
        ("threshold=percentile", replace(base, highlight=replace(base.highlight, threshold="percentile"))),
    ]
    rows = []
    reps = 2 if quick else 5
    for name, cfg in variants:
        holder: dict[str, Reconstructor] = {}

        def go(cfg: ReconConfig = cfg, holder: dict[str, Reconstructor] = holder) -> None:
            rc = Reconstructor(GEOM, traj, cfg)
            rc.add_frames(t, imgs)
            holder["rc"] = rc

        sec = best_time(go, reps)
        rc = holder["rc"]
        objs = rc.finish()
        obj_pts = np.concatenate([o.points for o in objs]) if objs else np.zeros((0, 3))
        row = {"knob": name, "frames_per_s": t.size / sec, **_errors(rc.raw_points, scene),
               "objects": len(objs), "object_mean_m": _errors(obj_pts, scene)["mean_m"]}
        rows.append(row)
    return rows


def dbscan_peers(cloud: np.ndarray, quick: bool) -> list[dict[str, Any]]:
    """Open3D against scikit-learn on the survey cloud and on a large synthetic cloud, same labels."""
    rng = np.random.default_rng(3)
    n_obj = 40 if quick else 150
    big = np.concatenate([c + rng.normal(0, [0.35, 0.25, 0.12], (1500, 3))
                          for c in np.column_stack([np.arange(n_obj) * 6.0, rng.uniform(-2, 2, n_obj),
                                                    np.full(n_obj, 19.5)])]
                         + [np.column_stack([rng.uniform(0, 6 * n_obj, 5000), rng.uniform(-3, 3, 5000),
                                             rng.uniform(19, 20, 5000)])])
    rows = []
    for name, pts in (("survey cloud", cloud), ("synthetic blobs", big)):
        if pts.shape[0] < 10:
            continue
        t_o3d = best_time(partial(dbscan_labels, pts, 0.3, 8, "open3d"), 3)
        t_skl = best_time(partial(dbscan_labels, pts, 0.3, 8, "sklearn"), 3)
        a, b = dbscan_labels(pts, 0.3, 8, "open3d"), dbscan_labels(pts, 0.3, 8, "sklearn")
        rows.append({"cloud": name, "points": int(pts.shape[0]), "open3d_s": t_o3d, "sklearn_s": t_skl,
                     "sklearn_over_open3d": t_skl / t_o3d, "same_noise": bool(np.array_equal(a < 0, b < 0)),
                     "clusters": int(a.max() + 1)})
    return rows


def _one_thread() -> contextlib.AbstractContextManager[Any]:
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # scikit-learn brings it; without it OMP_NUM_THREADS=1 above must do
        return contextlib.nullcontext()
    return threadpool_limits(1)


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    t0 = time.perf_counter()
    with _one_thread():
        n = 600 if quick else 2400
        scene, traj, t, imgs = survey(n)
        render_s = time.perf_counter() - t0
        rows = throughput(traj, t, imgs, quick)
        print(table(rows, ["what", "skip", "frames", "seconds", "frames_per_s"]))
        knob_rows = knobs(scene, traj, t, imgs, quick)
        print()
        print(table(knob_rows, ["knob", "frames_per_s", "points", "mean_m", "p95_m", "far_pct", "objects",
                                "object_mean_m"]))
        rc = Reconstructor(GEOM, traj)
        rc.add_frames(t, imgs)
        db = dbscan_peers(rc.raw_points, quick)
        print()
        print(table(db))
    frames_seabed_only = 1.0 - rc.frames_with_points / n
    paper_edge = float(paper_minus_exact(GEOM, 8.0)[0])
    print(f"\nframes showing only seabed: {100 * frames_seabed_only:.0f} %; paper - exact at the fan edge, "
          f"8 m: {paper_edge:.3f} m; goal >= 5000 frames/s with the skip")
    result = {"rows": rows, "knobs": knob_rows, "dbscan": db, "frames": n,
              "frames_seabed_only_fraction": frames_seabed_only, "paper_minus_exact_edge_8m": paper_edge,
              "goal_frames_per_s": 5000, "render_s": render_s, "elapsed_s": time.perf_counter() - t0,
              "threads": 1}
    write_json(out_dir, "recon", result)
    return result


if __name__ == "__main__":
    script_main(run, __doc__)
