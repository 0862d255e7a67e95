"""Simulated sonar frames/s (512 bins x 96 beams, uint8 with speckle) and the cost of K rays per beam.

Run: ``auvlink bench sim --out DIR`` (or ``python benchmarks/bench_sim.py --out DIR [--full]``).

- Every study but ``profiles`` and ``models`` renders the default scene under the idealized model
  (``profile = "ideal"``), whose parameter K (rays per beam) the sweeps vary.
- Frames of the default scene's survey at 10 fps, split into frames with an object in view and
  frames that see only the (sloped, 2 cm rough) seabed; frames/s for each culling mode (``rays``:
  one raycasting scene, only rays that can reach an object's bounding sphere are cast; ``objects``:
  one scene per object; ``none``: every ray cast at every object) at K = 32, best of the repeats.
- Also a flat seabed without roughness (the analytic plane alone).
- K sweep (8, 16, 32, 64) against a reference at K = 512: frames/s, the seabed-onset error on a flat
  seabed (first return per beam against the exact range, in bins; the steepest ray is always cast,
  so it is 0 or 1 by construction) and the highlight error (per beam, nearest object return against
  the reference, m) that the highlight extension inherits.
- Range bins sweep (128, 256, 512, 1024 at K = 32): time per rendered frame against the highlight
  range error after binning (bin-centre range of the nearest object return against the exact
  K = 512 range).
- ``tradeoffs`` (K, range bins: seconds per frame with objects in view against the highlight error),
  ``peers`` (culling ``rays`` against ``none``, objects in view and seabed only) and ``stability``
  (the culled images are byte-identical to the unculled ones) in the JSON contract of docs/BENCHMARKS.md.
- Log generation (:mod:`_sim_log`): a 3-minute (``--full``: 30-minute) survey at 10 fps with every
  device simulated into one MCAP log, in wall and CPU seconds (goal: 30 minutes in <= 60 s).
- Acoustic profiles (:mod:`auvlink.sim.acoustics`): frames/s of ``ideal`` and of each realistic
  profile on the same frames, in the same run (``profiles``; goal >= 200 frames/s, the real sonar
  pings at up to 15-20 per second).
- Sonar models (:mod:`_sim_models`): frames/s of every simulated model (DIDSON, ARIS, Oculus M750d/M1200d at
  512 beams x 4096 range lines) on the survey flown with it, ``ideal`` and its own realistic profile (``models``).
- Smoke mode (``AUVLINK_BENCH_SMOKE=1``): 8 frames per kind, one repeat, every 8th survey pose probed.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from _common import script_main, smoke, table, write_json
from _sim_frames import fps, fps_cpu, frames_of
from _sim_log import run_log
from _sim_models import model_rows
from scipy.spatial.transform import Rotation

from auvlink.sim.acoustics import PROFILES, AcousticsTable
from auvlink.sim.scene import Scene, load_default_scene, with_acoustics
from auvlink.sim.sonar_geometry import RayFan
from auvlink.sim.sonar_render import OBJECT, SonarRenderer


def ideal_default_scene() -> Scene:
    """The default scene under the idealized model: K rays per beam, the parameter the studies vary, is its."""
    return with_acoustics(load_default_scene(), "ideal")


def _stage_us(rd: SonarRenderer, frames: tuple[np.ndarray, Rotation]) -> tuple[float, float]:
    """Mean microseconds per frame in ray tracing and in image forming (returns, speckle, quantize)."""
    pos, rot = frames
    mats = rot.as_matrix()
    t0 = time.perf_counter()
    hits = [rd.trace_matrix(p, m) for p, m in zip(pos, mats, strict=True)]
    t1 = time.perf_counter()
    rng = np.random.default_rng(0)
    for h in hits:
        rd.image(h, rng)
    t2 = time.perf_counter()
    return (t1 - t0) / len(pos) * 1e6, (t2 - t1) / len(pos) * 1e6


def _onset_error_bins(k: int) -> float:
    scene = ideal_default_scene()
    scene = replace(scene, objects=(), seabed=replace(scene.seabed, slope_deg=0.0, roughness=0.0),
                    sonar=replace(scene.sonar, lever_arm=(0.0, 0.0, 0.0)))
    rd = SonarRenderer(scene, rays_per_beam=k, speckle=False)
    alt = scene.survey.altitude
    img = rd.render(np.array([0.0, 0.0, scene.seabed.depth - alt]), 0.0, 0.0, 0.0)
    g = rd.geometry
    t, s = g.tilt, g.spread
    exact = alt / (math.sin(t) * math.cos(s / 2) * np.cos(g.azimuth) + math.cos(t) * math.sin(s / 2))
    first = (img > 0).argmax(axis=0)
    return float(np.abs(first - g.bin_of_range(exact)).mean())


def _nearest_object(rd: SonarRenderer, pos: np.ndarray, mats: np.ndarray) -> np.ndarray:
    """(frames, beams) nearest object-return range, nan where the beam sees no object."""
    out = np.full((len(pos), rd.geometry.n_beams), np.nan)
    for i, (p, m) in enumerate(zip(pos, mats, strict=True)):
        h = rd.trace_matrix(p, m)
        r = np.where(h.kind == OBJECT, h.range, np.inf).reshape(-1, rd.geometry.n_beams).min(axis=0)
        out[i] = np.where(np.isfinite(r), r, np.nan)
    return out


def _k_sweep(scene: Scene, frames: dict[str, tuple[np.ndarray, Rotation]],
             repeat: int, ref: np.ndarray) -> list[dict[str, Any]]:
    pos, rot = frames["objects in view"]
    mats = rot.as_matrix()
    rows = []
    for k in (8, 16, 32, 64):
        rd = SonarRenderer(scene, rays_per_beam=k)
        near = _nearest_object(rd, pos, mats)
        both = np.isfinite(ref) & np.isfinite(near)
        rows.append({
            "K": k, "rays": rd.geometry.n_rays,
            "fps_objects": fps(rd, frames["objects in view"], repeat),
            "fps_seabed": fps(rd, frames["seabed only"], repeat),
            "onset_err_bins": _onset_error_bins(k),
            "highlight_err_m": float(np.abs(near - ref)[both].mean()),
            "beams_missed": float((np.isfinite(ref) & ~np.isfinite(near)).sum()
                                  / max(1, np.isfinite(ref).sum())),
        })
    return rows


def _bins_sweep(scene: Scene, frames: dict[str, tuple[np.ndarray, Rotation]], repeat: int,
                ref: np.ndarray) -> list[dict[str, Any]]:
    """Range bins against the binned highlight range error (K = 32, objects in view)."""
    pos, rot = frames["objects in view"]
    mats = rot.as_matrix()
    rows = []
    for nb in (128, 256, 512, 1024):
        rd = SonarRenderer(scene)
        rd.geometry = RayFan(scene.sonar, rd.geometry.k, n_bins=nb)
        g = rd.geometry
        near = _nearest_object(rd, pos, mats)
        both = np.isfinite(ref) & np.isfinite(near)
        b = g.bin_of_range(np.where(both, near, np.inf))
        binned = np.where(b >= 0, g.range_of_bin[np.maximum(b, 0)], np.nan)
        ok = both & np.isfinite(binned)
        rate = fps(rd, frames["objects in view"], repeat)
        rows.append({"n_bins": nb, "bin_m": g.bin_width, "fps_objects": rate,
                     "highlight_err_m": float(np.abs(binned - ref)[ok].mean())})
    return rows


def _culling(scene: Scene, frames: dict[str, tuple[np.ndarray, Rotation]]) -> dict[str, Any]:
    """Are the images of every culling mode byte-identical on the benchmark frames?"""
    out: dict[str, Any] = {}
    for view, (pos, rot) in frames.items():
        imgs = {c: list(SonarRenderer(scene, cull=c).render_sequence(pos, rot, seed=1))
                for c in ("rays", "objects", "none")}
        same = all(np.array_equal(a, b) for c in ("objects", "none")
                   for a, b in zip(imgs["rays"], imgs[c], strict=True))
        out[view] = {"frames": len(pos), "identical": same}
    return out


def _profiles(scene: Scene, frames: dict[str, tuple[np.ndarray, Rotation]], repeat: int) -> list[dict[str, Any]]:
    """Frames/s (wall and CPU) of every acoustic profile on the same frames, ``ideal`` first."""
    rows = []
    for name in PROFILES:
        rd = SonarRenderer(replace(scene, acoustics=AcousticsTable(profile=name)))
        rows.append({"profile": name, "rays": rd.geometry.n_rays,
                     "fps_objects": fps(rd, frames["objects in view"], repeat),
                     "fps_seabed": fps(rd, frames["seabed only"], repeat),
                     "fps_cpu_objects": fps_cpu(rd, frames["objects in view"], repeat),
                     "fps_cpu_seabed": fps_cpu(rd, frames["seabed only"], repeat)})
    return rows


def _contract(rows: list[dict[str, Any]], sweep: list[dict[str, Any]], bins: list[dict[str, Any]],
              identical: dict[str, Any], default_k: int) -> dict[str, list[dict[str, Any]]]:
    """The ``tradeoffs``, ``peers`` and ``stability`` lists of docs/BENCHMARKS.md."""
    trade = [{"knob": "rays per beam K", "setting": r["K"], "time_s": 1.0 / r["fps_objects"],
              "time_unit": "frame (objects in view)", "error": r["highlight_err_m"],
              "error_name": "highlight range error vs K=512 [m]", "default": r["K"] == default_k}
             for r in sweep]
    trade += [{"knob": "range bins", "setting": r["n_bins"], "time_s": 1.0 / r["fps_objects"],
               "time_unit": "frame (objects in view)", "error": r["highlight_err_m"],
               "error_name": "binned highlight range error vs exact [m]", "default": r["n_bins"] == 512}
              for r in bins]
    peers = []
    for view in ("objects in view", "seabed only"):
        by = {r["cull"]: r for r in rows if r["frames"] == view and r["seabed"] == "sloped rough"}
        ours, peer = 1.0 / by["rays"]["fps"], 1.0 / by["none"]["fps"]
        peers.append({"what": f"sonar simulation per frame, {view}", "ours": "cull=rays (scene culling)",
                      "ours_s": ours, "peer": "cull=none (every ray cast)", "peer_s": peer,
                      "ratio": peer / ours, "identical": identical[view]["identical"]})
    stab = [{"case": f"sim: culled images byte-identical to unculled ({view}, {v['frames']} frames, "
                     "modes rays/objects/none)", "ok": bool(v["identical"]),
             "detail": "identical bytes" if v["identical"] else "images differ between culling modes"}
            for view, v in identical.items()]
    return {"tradeoffs": trade, "peers": peers, "stability": stab}


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    t0 = time.perf_counter()
    load_before = os.getloadavg()
    scene = ideal_default_scene()
    n, repeat, stride = (150, 3, 1) if quick else (600, 5, 1)
    if smoke():
        n, repeat, stride = 8, 1, 8
    frames = frames_of(scene, n, stride)
    flat = replace(scene, seabed=replace(scene.seabed, slope_deg=0.0, roughness=0.0))
    rows = []
    for view, fr in frames.items():
        for cull in ("rays", "objects", "none"):
            rd = SonarRenderer(scene, cull=cull)
            trace_us, image_us = _stage_us(rd, fr)
            rows.append({"frames": view, "seabed": "sloped rough", "cull": cull, "n": len(fr[0]),
                         "fps": fps(rd, fr, repeat), "fps_cpu": fps_cpu(rd, fr, repeat),
                         "trace_us": trace_us, "image_us": image_us})
    rd_flat = SonarRenderer(replace(flat, objects=()))
    trace_us, image_us = _stage_us(rd_flat, frames["seabed only"])
    rows.append({"frames": "seabed only", "seabed": "flat", "cull": "rays",
                 "n": len(frames["seabed only"][0]), "fps": fps(rd_flat, frames["seabed only"], repeat),
                 "fps_cpu": fps_cpu(rd_flat, frames["seabed only"], repeat),
                 "trace_us": trace_us, "image_us": image_us})
    print(table(rows, ["frames", "seabed", "cull", "n", "fps", "fps_cpu", "trace_us", "image_us"]))
    pos, rot = frames["objects in view"]
    ref = _nearest_object(SonarRenderer(scene, rays_per_beam=512, speckle=False), pos, rot.as_matrix())
    sweep = _k_sweep(scene, frames, repeat, ref)
    print()
    print(table(sweep, ["K", "rays", "fps_objects", "fps_seabed", "onset_err_bins", "highlight_err_m",
                        "beams_missed"]))
    bins = _bins_sweep(scene, frames, repeat, ref)
    print()
    print(table(bins, ["n_bins", "bin_m", "fps_objects", "highlight_err_m"]))
    profiles = _profiles(scene, frames, repeat)
    print()
    print(table(profiles, ["profile", "rays", "fps_objects", "fps_seabed", "fps_cpu_objects", "fps_cpu_seabed"]))
    # smoke: two frames of each kind per model, every 32nd survey pose probed (the Oculus' 512 x 4096 frames)
    models = model_rows(scene, 2, 32, repeat) if smoke() else model_rows(scene, n, stride, repeat)
    print()
    print(table(models, ["model", "image", "acoustics", "fps_objects", "fps_seabed", "fps_cpu_objects",
                         "fps_cpu_seabed"]))
    identical = _culling(scene, frames)
    contract = _contract(rows, sweep, bins, identical, scene.sonar.rays_per_beam)
    print()
    print(table(contract["peers"], ["what", "ours_s", "peer_s", "ratio", "identical"]))
    k32 = {r["frames"]: r for r in rows if r["cull"] == "rays" and r["seabed"] == "sloped rough"}
    result: dict[str, Any] = {
        "rows": rows, "k_sweep": sweep, "bins_sweep": bins, "profiles": profiles, "models": models, "goal_fps": 400.0,
        "goal_fps_profiles": 200.0, **contract,
        "fps_k32_objects": k32["objects in view"]["fps"], "fps_k32_seabed": k32["seabed only"]["fps"],
        "fps_cpu_k32_objects": k32["objects in view"]["fps_cpu"],
        "fps_cpu_k32_seabed": k32["seabed only"]["fps_cpu"],
        "loadavg_before": load_before, "loadavg_after": os.getloadavg(),
    }
    print(f"\nK=32, cull=rays: {result['fps_k32_objects']:.0f} frames/s with objects in view, "
          f"{result['fps_k32_seabed']:.0f} seabed only (goal 400); per CPU time "
          f"{result['fps_cpu_k32_objects']:.0f} and {result['fps_cpu_k32_seabed']:.0f}; "
          f"load average {load_before[0]:.1f}")
    result["log"] = run_log(quick, minutes=1.0 if smoke() else None)
    result["elapsed_s"] = time.perf_counter() - t0
    write_json(out_dir, "sim", result)
    return result


if __name__ == "__main__":
    script_main(run, __doc__)
