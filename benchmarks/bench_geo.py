"""Where on Earth (issue #15): the e2e survey with and without GNSS fixes before the dive and after surfacing.

Run: ``python benchmarks/bench_geo.py --out DIR [--full]`` (quick: the 5-minute survey of ``bench e2e``,
``--full``: its 30-minute survey). The same survey is simulated twice: as shipped (``[gnss]``: a wait on
the surface with fixes, the dive, the survey, the climb, fixes again) and with ``[gnss] enabled = false``
(the survey alone, dead reckoning from its start: the behaviour before GNSS). Each log is replayed; from
the outputs and the log's truth:

- the horizontal error of the vehicle track against the truth (max, p95, final), at every ``track.csv``
  row: without GNSS (dead reckoning), with the start anchor only (``track.csv`` minus its drift
  correction), and with the drift correction (the track as written);
- detection precision / recall at 1 m against the true objects: without GNSS, with the start anchor
  only (each detection minus its ``drift_correction_ne``), and corrected.
"""

from __future__ import annotations

import csv
import datetime as dt
import io
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from _common import smoke, table, write_json


def _scene_text(minutes: float, gnss: bool) -> str:
    from _sim_log import survey_scene_text

    text = survey_scene_text(minutes)
    return text if gnss else text.replace("[gnss]", "[gnss]\nenabled = false")


def _simulate(text: str, path: Path) -> float:
    from auvlink.sim.mission import simulate_to_log
    from auvlink.sim.scene import loads_scene

    scene_path = path.with_suffix(".toml")
    scene_path.write_text(text)
    if path.is_file():
        return 0.0
    t0 = time.perf_counter()
    partial = path.with_suffix(".partial.mcap")
    simulate_to_log(loads_scene(text, source=str(scene_path)), partial, progress=False)
    partial.rename(path)
    return time.perf_counter() - t0


def _truth(log: Path) -> tuple[np.ndarray, np.ndarray, list[tuple[str, float, float]]]:
    from auvlink.sim.truth import TRAJECTORY_ATTACHMENT
    from logs_format import MissionLogReader

    with MissionLogReader(log) as r:
        traj = np.load(io.BytesIO(r.read_attachment(TRAJECTORY_ATTACHMENT)))
        gt = r.metadata(decode_json=True)["ground_truth"]
    objs = [(o["class"], float(o["position_ned"][0]), float(o["position_ned"][1])) for o in gt["objects"]]
    return traj["t_ns"] * 1e-9, np.column_stack([traj["north"], traj["east"]]), objs


def _track(out: Path) -> dict[str, np.ndarray]:
    with open(out / "track.csv") as f:
        rows = list(csv.DictReader(f))
    t = np.array([dt.datetime.fromisoformat(r["time"].replace("Z", "+00:00")).timestamp() for r in rows])
    col = {k: np.array([float(r[k]) for r in rows]) for k in ("north", "east", "correction_north",
                                                              "correction_east")}
    return {"t": t, **col}


def _errors(t: np.ndarray, ne: np.ndarray, tt: np.ndarray, truth: np.ndarray) -> dict[str, float]:
    ref = np.column_stack([np.interp(t, tt, truth[:, 0]), np.interp(t, tt, truth[:, 1])])
    e = np.linalg.norm(ne - ref, axis=1)
    return {"max_m": float(e.max()), "p95_m": float(np.percentile(e, 95)), "final_m": float(e[-1])}


def _pr(dets: list[tuple[float, float]], objs: list[tuple[str, float, float]], radius: float = 1.0) -> dict[str, float]:
    from auvlink.pipeline.truth_scores import match

    pairs = match(np.array(dets).reshape(-1, 2), np.array([(n, e) for _, n, e in objs]).reshape(-1, 2), radius)
    return {"precision": len(pairs) / len(dets) if dets else 0.0, "recall": len(pairs) / len(objs) if objs else 0.0,
            "matched": len(pairs), "detections": len(dets), "objects": len(objs)}


def _replay(log: Path, out: Path) -> dict[str, Any]:
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.process import run_log

    t0 = time.perf_counter()
    result = run_log(log, progress=False)
    summary = write_outputs(result, out)
    dets = [json.loads(x) for x in (out / "detections.jsonl").read_text().splitlines()]
    return {"summary": summary, "dets": dets, "replay_s": time.perf_counter() - t0}


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    minutes = 0.5 if smoke() else 5.0 if quick else 30.0
    work = out_dir / "geo"
    work.mkdir(parents=True, exist_ok=True)
    res: dict[str, Any] = {"minutes": minutes}
    rows = []
    for gnss in (False, True):
        name = "with_gnss" if gnss else "without_gnss"
        log = work / f"survey-{minutes:g}min-{name}.mcap"
        sim_s = _simulate(_scene_text(minutes, gnss), log)
        rep = _replay(log, work / name)
        tt, truth, objs = _truth(log)
        tr = _track(work / name)
        ne = np.column_stack([tr["north"], tr["east"]])
        corr = np.column_stack([tr["correction_north"], tr["correction_east"]])
        dets = [(d["position_ned"][0], d["position_ned"][1]) for d in rep["dets"]]
        entry: dict[str, Any] = {"sim_s": sim_s, "replay_s": rep["replay_s"], "georef": rep["summary"]["georef"]}
        if gnss:
            entry["track_start_anchor"] = _errors(tr["t"], ne - corr, tt, truth)
            entry["track_corrected"] = _errors(tr["t"], ne, tt, truth)
            raw = [(d["position_ned"][0] - d.get("drift_correction_ne", [0, 0])[0],
                    d["position_ned"][1] - d.get("drift_correction_ne", [0, 0])[1]) for d in rep["dets"]]
            entry["pr_start_anchor"] = _pr(raw, objs)
            entry["pr_corrected"] = _pr(dets, objs)
            rows.append({"run": "GNSS, start anchor only", **entry["track_start_anchor"], **entry["pr_start_anchor"]})
            rows.append({"run": "GNSS, drift-corrected", **entry["track_corrected"], **entry["pr_corrected"]})
        else:
            entry["track"] = _errors(tr["t"], ne, tt, truth)
            entry["pr"] = _pr(dets, objs)
            rows.append({"run": "no GNSS (dead reckoning)", **entry["track"], **entry["pr"]})
        res[name] = entry
    print(table(rows, ["run", "max_m", "p95_m", "final_m", "precision", "recall", "matched", "detections"]))
    g = res["with_gnss"]["georef"]
    print(f"closure error {g.get('closure_m')} m; fixes {g.get('fixes')}")
    write_json(out_dir, "geo", res)
    return res


if __name__ == "__main__":
    from _common import script_main

    script_main(run, __doc__)
