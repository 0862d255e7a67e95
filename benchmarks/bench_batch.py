"""Batch throughput: ``auvlink batch`` with 1 and 2 workers against ``auvlink replay`` one log after another.

Run: ``auvlink bench batch --out DIR [--full]`` (or ``python benchmarks/bench_batch.py --out DIR``).

Missions: simulated surveys of one site (a lawnmower over four objects, each survey its own seed and
start day), made once and cached in ``DIR/batch-cache``. Quick: 4 missions of 2 lines x 36 m (52 s of
mission each); full: 6 missions of 4 lines x 70 m (about 3.5 min each); smoke (``AUVLINK_BENCH_SMOKE=1``):
one mission of one 12 m line and the 1-worker batch only (the CI check that the script runs).

* peer: ``auvlink replay LOG --out DIR/<mission> --quiet`` per log, one process after another (what an
  operator does without batch), whole processes timed;
* ours: ``auvlink batch LOGS --out DIR --workers N --quiet`` for N = 1 and 2 (a fresh output folder each, so
  nothing is skipped), the whole process timed: cluster start, checksums, the missions, the catalogue.

Figures: wall seconds, missions per hour, x real time (mission time over wall time), the per-mission cost
(the median of the workers' own seconds per mission, from each mission's ``batch.json``, leaving out each
worker's first mission, which also pays for loading PyTorch and the model: that warm-up is reported
apart), and an estimate for N machines:
``N x workers per machine x 3600 / per-mission cost`` missions per hour, assuming the logs are read from
a shared file system fast enough (the bandwidth that needs is given) and the scheduler's cost (one small
task per mission) negligible. On a 2-core machine shared with other work the 2-worker gain is bounded by
the free cores: the load average is recorded.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from _common import smoke, table, write_json
from bench_e2e import run_child

from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import load_scene

MODES = {  # missions, lines, line length (m), worker counts
    "smoke": (1, 1, 12.0, (1,)),
    "quick": (4, 2, 36.0, (1, 2)),
    "full": (6, 4, 70.0, (1, 2)),
}
MACHINES = (1, 4, 16, 64)

SCENE = """seed = {seed}
[seabed]
depth = 20.0
roughness = 0.02
[[objects]]
class = "sphere"
position = [10.0, 0.4]
[[objects]]
class = "pipe"
position = [13.0, -0.3]
heading_deg = 60.0
[[objects]]
class = "reef_a"
position = [18.0, 3.8]
[[objects]]
class = "box"
position = [28.0, 3.2]
[survey]
line_length = {length}
line_spacing = 3.5
lines = {lines}
altitude = 5.0
speed = 1.5
[sonar]
tilt_deg = 30.0
spread_deg = 14.0
window_start = 1.0
window_length = 10.0
fps = 10.0
[sensors]
start = "2026-{month:02d}-01T08:00:00Z"
"""


def _auvlink() -> list[str]:
    return [sys.executable, "-c", "import sys; from auvlink.cli import main; sys.exit(main(sys.argv[1:]))"]


def cached_logs(cache: Path, n: int, lines: int, length: float) -> tuple[list[Path], float]:
    """``n`` simulated missions (made once); returns them and the seconds spent simulating now."""
    cache.mkdir(parents=True, exist_ok=True)
    logs, spent = [], 0.0
    for k in range(n):
        text = SCENE.format(seed=100 + k, lines=lines, length=length, month=1 + k % 12)
        key = hashlib.sha1(text.encode()).hexdigest()[:10]
        log = cache / f"mission{k + 1:02d}-{key}.mcap"
        if not log.is_file():
            scene = log.with_suffix(".toml")
            scene.write_text(text)
            partial = cache / f".{log.stem}.partial.mcap"  # renamed when whole: a killed run is never reused
            t0 = time.perf_counter()
            simulate_to_log(load_scene(scene), partial, progress=False)
            partial.rename(log)
            spent += time.perf_counter() - t0
        logs.append(log)
    return logs, spent


def _missions(out: Path) -> list[dict[str, Any]]:
    doc = json.loads((out / "batch.json").read_text())
    return list(doc["missions"])


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    mode = "smoke" if smoke() else "quick" if quick else "full"
    n, lines, length, worker_counts = MODES[mode]
    out_dir.mkdir(parents=True, exist_ok=True)
    logs, sim_s = cached_logs(out_dir / "batch-cache", n, lines, length)
    work = out_dir / "batch-work"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    load0 = os.getloadavg()[0]

    t0 = time.perf_counter()
    for log in logs:  # the peer: one replay process after another
        res = run_child([*_auvlink(), "replay", str(log), "--out", str(work / "replay" / log.stem), "--quiet"],
                        work / "replay.log")
        if res["rc"] != 0:
            raise RuntimeError(f"auvlink replay failed (rc {res['rc']}): see {work / 'replay.log'}")
    peer_s = time.perf_counter() - t0

    rows: list[dict[str, Any]] = []
    runs: dict[int, dict[str, Any]] = {}
    mission_s = 0.0
    for workers in worker_counts:
        out = work / f"batch-{workers}"
        res = run_child([*_auvlink(), "batch", *map(str, logs), "--out", str(out), "--workers", str(workers),
                         "--quiet"], work / f"batch-{workers}.log")
        missions = _missions(out) if (out / "batch.json").is_file() else []
        if res["rc"] != 0 or any(m["status"] != "done" for m in missions):
            raise RuntimeError(f"auvlink batch --workers {workers} failed (rc {res['rc']}): see {work}")
        mission_s = sum(float(m["duration_s"]) for m in missions)
        first = {min((m for m in missions if m["worker"] == w), key=lambda m: m["t_start"])["mission"]
                 for w in {m["worker"] for m in missions}}  # each worker's first mission loads PyTorch
        steady = [float(m["wall_s"]) for m in missions if m["mission"] not in first] or \
            [float(m["wall_s"]) for m in missions]
        per = float(statistics.median(steady))
        warm = float(statistics.mean(float(m["wall_s"]) for m in missions if m["mission"] in first)) - per
        peak = max(float(m.get("peak_rss_mb") or 0.0) for m in missions)
        runs[workers] = {"wall_s": res["wall_s"], "cpu_s": res["cpu_s"], "per_mission_s": per, "warm_up_s": warm}
        rows.append({"run": f"auvlink batch --workers {workers}", "missions": len(missions), "wall_s": res["wall_s"],
                     "missions_per_hour": 3600.0 * len(missions) / res["wall_s"],
                     "x_real_time": mission_s / res["wall_s"], "per_mission_worker_s": per,
                     "worker_warm_up_s": warm, "worker_peak_rss_MB": peak})
    rows.insert(0, {"run": f"auvlink replay x{n}, one after another", "missions": n, "wall_s": peer_s,
                    "missions_per_hour": 3600.0 * n / peer_s, "x_real_time": mission_s / peer_s,
                    "per_mission_worker_s": peer_s / n})
    print(table(rows))

    # the estimate for N machines, from the per-mission cost of the least contended run
    base = runs[min(runs)]
    per = base["per_mission_s"]
    log_mb = sum(p.stat().st_size for p in logs) / len(logs) / 1e6
    cores = os.cpu_count() or 1
    estimate = [{"machines": m, "workers_per_machine": cores, "missions_per_hour": m * cores * 3600.0 / per,
                 "x_real_time": m * cores * (mission_s / n) / per,
                 "read_MB_per_s": m * cores * log_mb / per} for m in MACHINES]
    print(f"\nestimate from {per:.1f} s per mission per worker (after a warm-up of {base['warm_up_s']:.1f} s per "
          f"worker; {cores} workers per machine):")
    print(table(estimate))
    peers = [{"what": f"{n} missions replayed ({mode})", "ours": f"auvlink batch --workers {w}",
              "ours_s": r["wall_s"], "peer": "auvlink replay, one log after another", "peer_s": peer_s,
              "ratio": peer_s / r["wall_s"]} for w, r in runs.items()]
    result = {"missions": n, "mission_s_each": mission_s / n, "log_MB_each": log_mb, "sim_s": sim_s,
              "runs": rows, "estimate": estimate, "peers": peers, "per_mission_s": per,
              "warm_up_s": base["warm_up_s"],
              "loadavg_1min_before": load0, "loadavg_1min_after": os.getloadavg()[0],
              "note": "x real time = mission time / wall time of the whole command; per-mission cost = the "
                      "workers' own seconds (checksum, replay, outputs) per mission, median after each worker's first"}
    write_json(out_dir, "batch", result)
    return result


if __name__ == "__main__":
    from _common import script_main

    script_main(run, __doc__)
