"""End to end (issue #6): a simulated survey log replayed through the whole pipeline, timed from outside.

Run: ``auvlink bench e2e --out DIR [--full]`` (or ``python benchmarks/bench_e2e.py --out DIR [--full]``).

1. Simulate a lawnmower survey into a mission log with ``auvlink sim --scene S --out LOG`` (the default
   scene stretched by ``_sim_log.survey_scene_text``: quick 5 minutes of survey, ``--full`` 30 minutes,
   both between the shipped scene's GNSS phases on the surface; smoke one 45 m line, about 30 s, no GNSS).
   The log is cached under ``DIR/e2e-cache`` (keyed by the scene text),
   so a rerun only replays.
2. ``auvlink log info LOG --json``: the mission seconds and message count, and how long ``log info`` takes.
3. ``auvlink replay LOG --out DIR/e2e-replay --fast``: wall seconds of the child process (Python start-up,
   imports, replay through the live framers/codecs/drivers, navigation, reconstruction, classification,
   outputs and report), its peak resident set (``wait4`` rusage of that child alone), x real time =
   mission seconds / wall seconds, and its CPU seconds (user + system, all threads: on a machine shared with
   other work the steadier figure). Goal: a 30-minute survey in <= 60 s (>= 30x).
4. From ``DIR/e2e-replay/summary.json``: the per-stage timings (and x real time per stage: mission seconds /
   stage seconds; ``first_frame_s``, the start-up to the first frame processed from the process's start, goal
   <= 1 s) and detection / classification precision and recall against the simulator's ground truth.
   The summary's format belongs to the pipeline: whatever keys it has are reported (``summary_keys``), numbers
   are taken where found, nothing is assumed.
5. The profile of the slowest stage: the log replayed once more in a child process with the profiler on in that
   stage only (``benchmarks/_stage_profile.py``): its top functions by cumulative time.

6. The Oculus path (issues 37, 38): the same survey's first line flown with a Blueprint Oculus M750d
   (:data:`OCULUS_MODEL`, its data-sheet aperture and realistic acoustic profile: 512 beams x 4000 range lines a
   ping) for :data:`OCULUS_MINUTES`, simulated once (cached like the DIDSON log) and replayed alike: x real time of
   the whole process and per stage (goal >= 30x, :data:`GOAL_OCULUS_X_REALTIME`), CPU seconds, peak RSS and the
   detections' scores (``oculus`` in the result).

Quick and full (not smoke) also time ``auvlink demo --out DIR/e2e-demo`` (goal: <= 3 minutes after set-up).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from _common import smoke, table, write_json
from _stage_profile import profile_in_child

MINUTES = {"smoke": 0.5, "quick": 5.0, "full": 30.0}
GOAL_X_REALTIME = 30.0  # 30-minute survey in <= 60 s
GOAL_DEMO_S = 180.0
GOAL_FIRST_FRAME_S = 1.0  # issue 38: start-up (interpreter, imports, set-up) to the first frame processed
#: the Oculus row: the sonar flown, and minutes of mission per mode (one line of the survey; its log holds ~2 MB a ping)
OCULUS_MODEL = "oculus-m750d"
OCULUS_MINUTES = {"smoke": 0.1, "quick": 1.0, "full": 3.0}
GOAL_OCULUS_X_REALTIME = 30.0  # issue 37: replay >= 30x real time at Oculus rates
#: summary timings that are not a stage of the mission's data (no x real time): the fixed start-up and the total
NOT_STAGES = ("start_up_s", "first_frame_s", "total_s")


def _auvlink() -> list[str]:
    """The command that runs the CLI of this interpreter's environment."""
    exe = Path(sys.executable).with_name("auvlink")
    return [str(exe)] if exe.is_file() else [sys.executable, "-m", "auvlink"]


def oculus_scene_text(minutes: float, model: str = OCULUS_MODEL) -> str:
    """The survey scene's first line (``minutes`` long) flown with the Oculus ``model``: its data-sheet vertical
    aperture and its own realistic acoustic profile (:func:`auvlink.sim.scene.with_sonar_model`'s choices)."""
    from auvlink.sonar import describe

    d = describe(model)
    text = one_line_scene_text(minutes)
    text = re.sub(r"(?m)^spread_deg\s*=.*$", f'spread_deg = {d.vertical_aperture_deg}\nmodel = "{model}"', text,
                  count=1)
    return text + f'\n[acoustics]\nprofile = "{d.acoustic_profile}"\n'


def scene_text(minutes: float) -> str:
    """The survey scene: the default scene stretched to ``minutes`` (< 1 minute: one line)."""
    if minutes >= 1.0:
        from _sim_log import survey_scene_text

        return survey_scene_text(minutes)
    return one_line_scene_text(minutes)


def one_line_scene_text(minutes: float) -> str:
    """The default scene's survey as one line of ``minutes`` (at least 10 m), no surface phases (no GNSS)."""
    from auvlink.sim.scene import default_scene_text, loads_scene

    text = default_scene_text()
    sv = loads_scene(text).survey
    length = max(10.0, minutes * 60.0 * sv.speed)
    text = re.sub(r"(?m)^line_length\s*=.*$", f"line_length = {length:.3f}", text, count=1)
    text = text.replace("[gnss]", "[gnss]\nenabled = false")  # the survey alone (no surface phases)
    return re.sub(r"(?m)^lines\s*=.*$", "lines = 1", text, count=1)


def run_child(cmd: list[str], log_file: Path, cwd: Path | None = None) -> dict[str, Any]:
    """Run ``cmd`` (output to ``log_file``); wall and CPU seconds and peak RSS of that child alone."""
    with open(log_file, "wb") as out:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, cwd=cwd)
        _, status, ru = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    return {"rc": proc.returncode, "wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime,
            "peak_rss_MB": ru.ru_maxrss / 1e3, "command": " ".join(cmd)}


def _tail(path: Path, n: int = 2000) -> str:
    try:
        return path.read_text(errors="replace")[-n:]
    except OSError:
        return ""


def cached_log(cache: Path, minutes: float, text: str | None = None, name: str = "survey"
               ) -> tuple[Path, dict[str, Any] | None]:
    """The simulated survey log for ``minutes`` (the scene ``text``, default :func:`scene_text`; made once, then
    reused); the sim run, None if cached."""
    text = scene_text(minutes) if text is None else text
    key = hashlib.sha1(text.encode()).hexdigest()[:10]
    cache.mkdir(parents=True, exist_ok=True)
    log = cache / f"{name}-{minutes:g}min-{key}.mcap"
    if log.is_file():
        return log, None
    scene = cache / f"{name}-{minutes:g}min-{key}.toml"
    scene.write_text(text)
    partial = log.with_suffix(".partial.mcap")  # renamed when whole: a killed run is never reused
    sim = run_child([*_auvlink(), "sim", "--scene", str(scene), "--out", str(partial), "--quiet", "--force"],
                    cache / "sim.log")
    if sim["rc"] != 0 or not partial.is_file():
        raise RuntimeError(f"auvlink sim failed (rc {sim['rc']}): {_tail(cache / 'sim.log')}")
    partial.rename(log)
    sim["log_MB"] = log.stat().st_size / 1e6
    return log, sim


def log_info(log: Path, work: Path) -> dict[str, Any]:
    """``auvlink log info LOG --json``: its run and the parts of its answer this benchmark uses."""
    out = work / "log-info.json"
    with open(out, "wb") as f:
        t0 = time.perf_counter()
        rc = subprocess.run([*_auvlink(), "log", "info", str(log), "--json"], stdout=f,
                            stderr=subprocess.DEVNULL, check=False).returncode
        wall = time.perf_counter() - t0
    info: dict[str, Any] = {}
    if rc == 0:
        try:
            info = json.loads(out.read_text())
        except ValueError:
            info = {}
    return {"rc": rc, "wall_s": wall, "duration_s": info.get("duration_s"),
            "message_count": info.get("message_count"), "size_MB": log.stat().st_size / 1e6,
            "frames": {k: v.get("count") for k, v in (info.get("channels") or {}).items() if isinstance(v, dict)}}


def numbers(d: Any, prefix: str = "") -> dict[str, float]:
    """Every number in a (nested) dict, keys joined with '.' (bools and non-numbers left out)."""
    out: dict[str, float] = {}
    if isinstance(d, dict):
        for k, v in d.items():
            key = f"{prefix}{k}"
            if isinstance(v, bool):
                continue
            if isinstance(v, int | float):
                out[key] = float(v)
            elif isinstance(v, dict):
                out.update(numbers(v, key + "."))
    return out


def read_summary(out: Path) -> dict[str, Any]:
    """What the pipeline's ``summary.json`` says: its keys, timings (s), scores, detections."""
    path = out / "summary.json"
    if not path.is_file():
        return {"summary_found": False}
    try:
        summary = json.loads(path.read_text())
    except ValueError as exc:
        return {"summary_found": False, "summary_error": str(exc)}
    if not isinstance(summary, dict):
        return {"summary_found": False, "summary_error": f"not an object: {type(summary).__name__}"}
    timings = {k: v for k, v in numbers(summary.get("timings", {})).items()}
    if not timings:  # another layout: any top-level number named like a duration
        timings = {k: v for k, v in numbers(summary).items() if k.endswith(("_s", "seconds"))}
    scores = numbers(summary.get("scores", {}))
    det = summary.get("detections")
    return {"summary_found": True, "summary_keys": sorted(summary), "timings": timings, "scores": scores,
            "detections": det if isinstance(det, int) else (len(det) if isinstance(det, list) else None),
            "recon": numbers(summary.get("recon", {}))}


def _score(scores: dict[str, float], *words: str) -> float | None:
    for k, v in scores.items():
        if all(w in k for w in words):
            return v
    return None


def replay_child(log: Path, replay_dir: Path, log_file: Path, quiet: bool = True) -> dict[str, Any]:
    """``auvlink replay LOG --out DIR --fast`` (``--quiet``) in a child process, DIR emptied first; its run
    (:func:`run_child`), raising when it failed."""
    shutil.rmtree(replay_dir, ignore_errors=True)
    cmd = [*_auvlink(), "replay", str(log), "--out", str(replay_dir), "--fast", *(["--quiet"] if quiet else [])]
    replay = run_child(cmd, log_file)
    if replay["rc"] != 0:
        raise RuntimeError(f"auvlink replay {log.name} failed (rc {replay['rc']}): {_tail(log_file)}")
    return replay


def stage_rows(timings: dict[str, float], mission_s: float) -> list[dict[str, Any]]:
    """Table rows of the summary's timings, with x real time per stage (mission s / stage s)."""
    return [{"step": f"  summary timings: {k}", "seconds": v,
             "x_realtime": mission_s / v if v > 0 and k not in NOT_STAGES else None} for k, v in timings.items()]


def stage_x_realtime(timings: dict[str, float], mission_s: float) -> dict[str, float]:
    """x real time of each stage of the summary's timings (the fixed start-up and the total left out)."""
    return {k: mission_s / v for k, v in timings.items() if v > 0 and k not in NOT_STAGES}


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    mode = "smoke" if smoke() else "quick" if quick else "full"
    minutes = MINUTES[mode]
    out_dir.mkdir(parents=True, exist_ok=True)
    work = out_dir / "e2e-work"
    work.mkdir(exist_ok=True)
    t_start = time.perf_counter()
    log, sim = cached_log(out_dir / "e2e-cache", minutes)
    info = log_info(log, work)
    replay_dir = out_dir / "e2e-replay"
    help_text = subprocess.run([*_auvlink(), "replay", "--help"], capture_output=True, text=True,
                               check=False).stdout
    replay = replay_child(log, replay_dir, work / "replay.log", quiet="--quiet" in help_text)
    summary = read_summary(replay_dir)
    mission_s = float(info["duration_s"] or minutes * 60.0)
    x_rt = mission_s / replay["wall_s"]
    scores = summary.get("scores", {})
    timings: dict[str, float] = summary.get("timings", {})
    decode_s = next((v for k, v in timings.items() if "replay" in k or "decode" in k), None)

    rows: list[dict[str, Any]] = []
    if sim is not None:
        rows.append({"step": "auvlink sim (not cached)", "seconds": sim["wall_s"], "cpu_s": sim["cpu_s"],
                     "peak_rss_MB": sim["peak_rss_MB"]})
    rows.append({"step": "auvlink log info", "seconds": info["wall_s"]})
    rows.append({"step": "auvlink replay --fast (whole process)", "seconds": replay["wall_s"],
                 "cpu_s": replay["cpu_s"], "x_realtime": x_rt, "peak_rss_MB": replay["peak_rss_MB"]})
    rows += stage_rows(timings, mission_s)
    total = timings.get("total_s")
    outside = replay["wall_s"] - total if total is not None else None
    if outside is not None:  # what the pipeline's own timings do not cover
        rows.append({"step": "  start-up, imports, outputs, report (wall - total_s)", "seconds": outside})
    demo: dict[str, Any] | None = None
    if mode != "smoke":
        demo_dir = out_dir / "e2e-demo"
        shutil.rmtree(demo_dir, ignore_errors=True)
        demo = run_child([*_auvlink(), "demo", "--out", str(demo_dir)], work / "demo.log")
        demo["ok"] = demo["rc"] == 0 and demo["wall_s"] <= GOAL_DEMO_S
        rows.append({"step": "auvlink demo (shipped scene)", "seconds": demo["wall_s"], "cpu_s": demo["cpu_s"],
                     "peak_rss_MB": demo["peak_rss_MB"]})
    print(table(rows, ["step", "seconds", "cpu_s", "x_realtime", "peak_rss_MB"]))
    profile = profile_in_child(log, timings, work)  # a second replay, profiled in its slowest stage only
    if profile is not None:
        print(f"\nprofile of the slowest stage, {profile['stage']} ({profile['profiled_s']:.2f} s profiled):")
        print(table(profile["top"], ["function", "ncalls", "tottime_s", "cumtime_s"]))
    oculus = oculus_replay(out_dir, mode, work)
    det_p, det_r = _score(scores, "detection", "precision"), _score(scores, "detection", "recall")
    cls_p, cls_r = _score(scores, "classification", "precision"), _score(scores, "classification", "recall")
    print(f"mission {mission_s:.0f} s ({info['message_count']} messages, {info['size_MB']:.0f} MB log): replay "
          f"end to end {replay['wall_s']:.1f} s = {x_rt:.1f}x real time (goal >= {GOAL_X_REALTIME:.0f}x); "
          f"peak RSS {replay['peak_rss_MB']:.0f} MB; CPU {replay['cpu_s']:.1f} s (all threads; on a loaded machine "
          "the steadier figure)")
    if det_p is not None:
        print(f"detections {summary.get('detections')}: detection P/R {det_p:.2f}/{det_r or 0:.2f}, "
              f"classification P/R {cls_p or 0:.2f}/{cls_r or 0:.2f}")
    if not summary.get("summary_found"):
        print(f"summary.json not found or unreadable in {replay_dir}: {summary.get('summary_error', '')}")
    else:
        print(f"summary.json keys: {', '.join(summary['summary_keys'])}")
    if timings.get("first_frame_s") is not None:
        print(f"start-up to the first frame processed (process start, imports, set-up): {timings['first_frame_s']:.2f}"
              f" s (goal <= {GOAL_FIRST_FRAME_S:.0f} s)")
    load = os.getloadavg()[0]
    print(f"load average {load:.2f} on {os.cpu_count()} cores")
    result: dict[str, Any] = {
        "mode": mode, "mission_s": mission_s, "log": str(log), "log_MB": info["size_MB"],
        "log_cached": sim is None, "sim": sim, "log_info": info,
        "replay": replay, "wall_s": replay["wall_s"], "x_realtime": x_rt, "peak_rss_MB": replay["peak_rss_MB"],
        "cpu_s": replay["cpu_s"], "x_realtime_cpu": mission_s / replay["cpu_s"] if replay["cpu_s"] > 0 else None,
        "replay_decode_s": decode_s, "outside_pipeline_timings_s": outside,
        "replay_decode_x_realtime": mission_s / decode_s if decode_s else None,
        "stage_timings_s": timings, "stage_x_realtime": stage_x_realtime(timings, mission_s),
        "first_frame_s": timings.get("first_frame_s"), "goal_first_frame_s": GOAL_FIRST_FRAME_S,
        "slowest_stage_profile": profile, "slowest_stage_top": profile["top"] if profile else [],
        "scores": scores,
        "detection_precision": det_p, "detection_recall": det_r,
        "classification_precision": cls_p, "classification_recall": cls_r,
        "detections": summary.get("detections"), "recon": summary.get("recon", {}),
        "summary_found": summary.get("summary_found", False), "summary_keys": summary.get("summary_keys", []),
        "goal_x_realtime": GOAL_X_REALTIME, "ok": x_rt >= GOAL_X_REALTIME,
        "seconds_per_30_min": replay["wall_s"] * 1800.0 / mission_s,
        "demo": demo, "oculus": oculus, "load_average_1min": load, "elapsed_s": time.perf_counter() - t_start,
    }
    write_json(out_dir, "e2e", result)
    return result


def oculus_replay(out_dir: Path, mode: str, work: Path) -> dict[str, Any]:
    """Step 6: the Oculus survey line simulated (cached) and replayed; its figures, printed as a table."""
    minutes = OCULUS_MINUTES[mode]
    log, sim = cached_log(out_dir / "e2e-cache", minutes, oculus_scene_text(minutes), name="oculus")
    info = log_info(log, work)
    replay_dir = out_dir / "e2e-replay-oculus"
    replay = replay_child(log, replay_dir, work / "replay-oculus.log")
    summary = read_summary(replay_dir)
    mission_s = float(info["duration_s"] or minutes * 60.0)
    timings: dict[str, float] = summary.get("timings", {})
    scores = summary.get("scores", {})
    rows: list[dict[str, Any]] = []
    if sim is not None:
        rows.append({"step": f"auvlink sim, {OCULUS_MODEL} (not cached)", "seconds": sim["wall_s"],
                     "cpu_s": sim["cpu_s"], "peak_rss_MB": sim["peak_rss_MB"]})
    rows.append({"step": f"auvlink replay --fast, {OCULUS_MODEL} (whole process)", "seconds": replay["wall_s"],
                 "cpu_s": replay["cpu_s"], "x_realtime": mission_s / replay["wall_s"],
                 "peak_rss_MB": replay["peak_rss_MB"]})
    rows += stage_rows(timings, mission_s)
    print(f"\nOculus path: {mission_s:.0f} s of mission, {info['size_MB']:.0f} MB log, "
          f"{(info.get('frames') or {}).get('sonar', '?')} pings")
    print(table(rows, ["step", "seconds", "cpu_s", "x_realtime", "peak_rss_MB"]))
    x_rt = mission_s / replay["wall_s"]
    return {"model": OCULUS_MODEL, "mission_s": mission_s, "log_MB": info["size_MB"], "log_cached": sim is None,
            "sim": sim, "replay": replay, "wall_s": replay["wall_s"], "cpu_s": replay["cpu_s"], "x_realtime": x_rt,
            "x_realtime_cpu": mission_s / replay["cpu_s"] if replay["cpu_s"] > 0 else None,
            "stage_timings_s": timings, "stage_x_realtime": stage_x_realtime(timings, mission_s),
            "detection_precision": _score(scores, "detection", "precision"),
            "detection_recall": _score(scores, "detection", "recall"),
            "classification_precision": _score(scores, "classification", "precision"),
            "classification_recall": _score(scores, "classification", "recall"),
            "detections": summary.get("detections"), "goal_x_realtime": GOAL_OCULUS_X_REALTIME,
            "ok": x_rt >= GOAL_OCULUS_X_REALTIME}


if __name__ == "__main__":
    from _common import script_main

    script_main(run, __doc__)
