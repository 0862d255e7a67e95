"""The simulated-mission parts of the recon stage: accuracy, the knobs against error, the 7-object scenes, nav.

Every mission here is rendered by the simulator (:mod:`auvlink.evaluation.simeval`) and scored against its ground
truth with the true navigation (except :func:`nav`, which replays a simulated log through the codecs).

- :func:`accuracy`: the demo scene (8 objects, 5 m altitude, 30 deg tilt): mean and 95th-percentile
  point-to-mesh distance for ``exact`` / ``paper`` geometry x front slope on (arc re-placement) / off.
- :func:`knobs`: ``tradeoffs`` rows, the time of the reconstruction alone (``add_frames`` + ``finish``)
  per frame against the mean point-to-mesh distance, one knob at a time from the pipeline's settings
  (the skip: the time of what it changes, highlight extraction + projection).
- :func:`cluster_knobs`: DBSCAN ``eps`` (with and without the footprint merge) and the voxel size (voxel
  downsampling forced on), clustering time per point against the clustering errors (splits + merges +
  missed + spurious) over the demo and the 7-object scenes.
- :func:`scenes`: the two 7-object scenes of ``tests/test_recon_sim.py`` (flat and 5 deg slope): every
  object exactly one cluster, worst centroid error (goal 0.3 m).
- :func:`nav`: dead-reckoning drift on simulated logs (>= 1 km) with the default noise and with it off.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import replace
from functools import partial
from typing import Any

import numpy as np
from _common import best_time, smoke

from auvlink.evaluation.simeval import (
    SimFrames,
    cluster_errors,
    evaluate,
    nav_drift,
    object_points,
    reconstruct,
    simulate,
)
from auvlink.pipeline.engine_config import default_recon_config
from recon.cluster import ClusterConfig, cluster
from recon.highlight import extract
from recon.reconstructor import ReconConfig

SCENE_OBJECTS = [("sphere", 8.0, 0.5), ("box", 16.0, -0.6), ("reef_a", 25.0, 0.3), ("pipe", 34.0, -0.4),
                 ("hemisphere", 12.0, 3.0), ("half_pipe", 22.0, 4.2), ("reef_c", 31.0, 3.4)]


def scene_text(slope_deg: float) -> str:
    """The 7-object scene of tests/test_recon_sim.py (two 44 m lines, 5 m altitude, 30 deg tilt)."""
    objs = "".join(f'[[objects]]\nclass = "{c}"\nposition = [{n}, {e}]\nheading_deg = {17.0 * i}\n\n'
                   for i, (c, n, e) in enumerate(SCENE_OBJECTS))
    return (f"seed = 11\n[seabed]\ndepth = 20.0\nslope_deg = {slope_deg}\nslope_azimuth_deg = 90.0\n"
            f"roughness = 0.02\n\n{objs}[survey]\npattern = \"lawnmower\"\norigin = [-4.0, 0.0]\nheading_deg = 0.0\n"
            "line_length = 44.0\nline_spacing = 3.5\nlines = 2\naltitude = 5.0\nspeed = 1.5\n\n[sonar]\n"
            "tilt_deg = 30.0\nspread_deg = 14.0\nwindow_start = 1.0\nwindow_length = 10.0\nfps = 10.0\n"
            "lever_arm = [0.6, 0.0, 0.2]\nrays_per_beam = 16\n")


def pipeline_config() -> ReconConfig:
    return default_recon_config()


def demo_frames() -> SimFrames:
    """The demo scene's survey rendered by the simulator (smoke: its first 25 s: the sphere and the box, line 1);
    without its GNSS phases on the surface, which hold no sonar target."""
    from dataclasses import replace

    from auvlink.sim.scene import load_default_scene

    return simulate(replace(load_default_scene(), gnss=None), duration=25.0 if smoke() else None)


def scene_frames() -> dict[str, SimFrames]:
    """The 7-object scenes, flat and 5 deg (none in smoke mode)."""
    from auvlink.sim.scene import loads_scene

    if smoke():
        return {}
    return {f"7 objects, {name}": simulate(loads_scene(scene_text(slope)))
            for name, slope in (("flat seabed", 0.0), ("5 deg slope", 5.0))}


def accuracy(frames: SimFrames) -> list[dict[str, Any]]:
    """exact / paper x front slope arc / off: point-to-mesh distances, objects, centroid errors."""
    base = pipeline_config()
    rows = []
    for geometry in ("exact", "paper"):
        for fs in ("arc", "off"):
            cfg = replace(base, front_slope=fs != "off", highlight=replace(base.highlight, geometry=geometry))
            ev = evaluate(frames, cfg)
            s = ev.summary()
            rows.append({"geometry": geometry, "front_slope": fs, "points": s["points"], "mean_m": s["mean_m"],
                         "p95_m": s["p95_m"], "objects": s["objects"], "truth": len(ev.matches),
                         "exactly_one": s["exactly_one"], "centroid_mean_m": s["centroid_error_mean_m"],
                         "centroid_max_m": s["centroid_error_max_m"]})
    return rows


def knobs(frames: SimFrames, quick: bool) -> list[dict[str, Any]]:
    """``tradeoffs`` rows: time per frame of the reconstruction against the mean point-to-mesh distance."""
    base = pipeline_config()
    hl = base.highlight
    variants: list[tuple[str, str | float, ReconConfig]] = []
    for k in (4.0, 8.0) if smoke() else (3.0, 4.0, 6.0, 8.0):
        variants.append(("threshold k (median + k MAD)", k, replace(base, highlight=replace(hl, k=k))))
    for g in ("exact", "paper"):
        variants.append(("geometry", g, replace(base, highlight=replace(hl, geometry=g))))
    for skip in (True, False):
        variants.append(("seabed-onset skip", "on" if skip else "off", replace(base, highlight=replace(hl, skip=skip))))
    for dt in ("float64", "float32"):
        variants.append(("dtype", dt, replace(base, highlight=replace(hl, dtype=dt))))
    slopes = [("arc", base), ("off", replace(base, front_slope=False))]
    for name, cfg in slopes:
        variants.append(("front slope", name, cfg))
    rows = []
    reps = 1 if smoke() else 2 if quick else 3
    n = frames.times.size
    pos, rot = frames.trajectory.pose_at(frames.times)
    onset = frames.geometry.flat_onset_ranges(pos, rot, frames.trajectory.altitude_at(frames.times))

    def extraction(cfg: ReconConfig) -> None:  # what the skip changes, in the pipeline's blocks of 64
        for k in range(0, n, 64):
            sl = slice(k, k + 64)
            extract(frames.images[sl], pos[sl], rot[sl], onset[sl], frames.geometry, cfg.highlight)

    for knob, setting, cfg in variants:
        def recon_only(cfg: ReconConfig = cfg) -> None:
            reconstruct(frames, cfg)

        skip_knob = knob == "seabed-onset skip"
        sec = best_time(partial(extraction, cfg) if skip_knob else recon_only, 3 * reps if skip_knob else reps)
        ev = evaluate(frames, cfg)
        if ev.distances.size == 0:  # no object found: no error to plot
            continue
        unit = "frame (highlight extraction + projection only)" if skip_knob else "frame"
        rows.append({"knob": knob, "setting": setting, "time_s": sec / n, "time_unit": unit,
                     "error": float(ev.distances.mean()),
                     "error_name": "mean point-to-mesh distance [m] (simulated demo scene, true navigation)",
                     "default": cfg == base, "objects": len(ev.objects), "exactly_one": ev.exactly_one,
                     "p95_m": float(np.percentile(ev.distances, 95))})
    return rows


def cluster_knobs(all_frames: dict[str, SimFrames]) -> list[dict[str, Any]]:
    """DBSCAN eps and voxel size: clustering time per point against splits + merges + missed + spurious."""
    base = pipeline_config()
    inputs = [(f, object_points(f, base)) for f in all_frames.values()]
    n_pts = sum(p[0].shape[0] for _, p in inputs)
    c0 = base.cluster
    settings: list[tuple[str, Any, ClusterConfig]] = [
        ("DBSCAN eps [m]", e, replace(c0, eps=e)) for e in ((0.3, 0.5, 1.0) if smoke() else
                                                            (0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5))]
    if not smoke():  # what eps does alone: the footprint merge (clusters within 0.8 m joined) off
        settings += [("DBSCAN eps [m], footprint merge off", e, replace(c0, eps=e, footprint_gap=0.0))
                     for e in (0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5)]
    settings += [("voxel size [m] (downsampling forced on)", "off" if v == 0 else v,
                  c0 if v == 0 else replace(c0, voxel=v, max_points=0))
                 for v in ((0.0, 0.05, 0.2) if smoke() else (0.0, 0.02, 0.05, 0.1, 0.2, 0.3))]
    rows = []
    for knob, setting, ccfg in settings:
        def go(ccfg: ClusterConfig = ccfg) -> list[Any]:
            return [cluster(p, t, ccfg, e) for _, (p, t, e) in inputs]

        sec = best_time(go, 1 if smoke() else 3)
        counts = [cluster_errors(objs, f.truth_xy) for (f, _), objs in zip(inputs, go(), strict=True)]
        tot = {k: sum(c[k] for c in counts) for k in counts[0]}
        rows.append({"knob": knob, "setting": setting, "time_s": sec / max(1, n_pts), "time_unit": "point",
                     "error": float(tot["wrong"]),
                     "error_name": f"objects wrong: splits + merges + missed + spurious ({len(inputs)} scenes, "
                                   f"{sum(f.truth_xy.shape[0] for f in all_frames.values())} objects)",
                     "default": ccfg == c0, **tot})
    return rows


def scenes(frames: dict[str, SimFrames]) -> list[dict[str, Any]]:
    """Per scene: every object exactly one cluster? the worst centroid error (goal 0.3 m), distances."""
    rows = []
    for name, f in frames.items():
        ev = evaluate(f, pipeline_config())
        err = ev.centroid_error
        worst = int(np.nanargmax(err)) if np.isfinite(err).any() else 0
        names = [o.class_name for o in f.scene.objects]
        rows.append({"scene": name, "objects": len(names), "clusters": len(ev.objects),
                     "exactly_one": ev.exactly_one, **cluster_errors(ev.objects, f.truth_xy),
                     "centroid_mean_m": float(np.nanmean(err)), "centroid_max_m": float(np.nanmax(err)),
                     "worst_object": names[worst], "within_0.3m": int((err <= 0.3).sum()),
                     "mean_m": float(ev.distances.mean()), "p95_m": float(np.percentile(ev.distances, 95)),
                     "centroid_errors_m": [round(float(x), 3) for x in err]})
    return rows


NAV_SCENE = """seed = 5
[seabed]
depth = 30.0
slope_deg = 2.0
slope_azimuth_deg = 45.0
roughness = 0.02
[survey]
pattern = "lawnmower"
origin = [0.0, 0.0]
heading_deg = 30.0
line_length = 250.0
line_spacing = 4.0
lines = 4
altitude = 5.0
speed = 1.5
[sonar]
tilt_deg = 30.0
spread_deg = 14.0
window_start = 1.0
window_length = 10.0
fps = 1.0
"""


def nav(quick: bool) -> dict[str, Any]:
    """Dead-reckoning drift on simulated logs replayed through the codecs: a 4-line lawnmower (1,019 m)
    with the default sensor noise and with it off, and one straight 1 km line with the noise off (what is
    left is the wire's resolution: PD0 velocity in mm/s, heading in 0.01 deg)."""
    from auvlink.sim.scene import loads_scene

    text = NAV_SCENE.replace("lines = 4", "lines = 1") if smoke() else NAV_SCENE
    straight = NAV_SCENE.replace("line_length = 250.0", "line_length = 1000.0").replace("lines = 4", "lines = 1")
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        out = nav_drift(loads_scene(text), tmp, duration=25.0 if smoke() else None)
        if not smoke():  # every sensor noise off (the wire quantization stays)
            out["noise_off"] = nav_drift(loads_scene(text), tmp, noise=False)
            out["noise_off_straight_1km"] = nav_drift(loads_scene(straight), tmp, noise=False)
        for key in ("noise_off", "noise_off_straight_1km"):  # flat figures for the report's table
            if key in out:
                out[f"{key}_max_horizontal_error_m"] = out[key]["max_horizontal_error_m"]
                out[f"{key}_distance_m"] = out[key]["distance_m"]
        out["elapsed_s"] = time.perf_counter() - t0
    return out
