"""Evaluation over random surveys: draw, simulate, replay, score (``auvlink eval --surveys N``).

Each survey of the draw (:mod:`auvlink.evaluation.draw`), with its acoustic conditions
(:mod:`auvlink.evaluation.acoustic_draw`: ``acoustics`` = ``ideal``, a sonar profile or ``random``) as its
``[acoustics]`` table, is written as a scene file ``DIR/surveys/NNN/scene.toml``, simulated into
``DIR/surveys/NNN/mission.mcap`` by
:func:`auvlink.sim.mission.simulate_to_log` (what ``auvlink sim --out`` runs, noise on), replayed by
:func:`auvlink.pipeline.process.run_log` and written by :func:`auvlink.pipeline.outputs.write_outputs`
(what ``auvlink replay`` runs: framers, codecs, the streaming engine, classification; the outputs go
to ``DIR/surveys/NNN/out/``, the detections to ``out/detections.jsonl``) and scored against
the scene's objects (:mod:`auvlink.evaluation.survey_scores`). The log is deleted after its replay unless
``keep_logs`` (a 3-minute survey is ~150 MB); nothing is cached: every run simulates afresh.

Surveys run in ``workers`` processes (spawned, one thread each); the results do not depend on the
number of workers. ``DIR/surveys.json`` holds the command, seed, every survey's draw, timings and
scores (``acoustics``: each survey's acoustic draw), the pooled scores overall and per factor bin (the
acoustic factors after the survey's); ``DIR/surveys.png`` plots them.

``clutter_sweep`` (``--clutter-sweep``): each survey is replayed with no cluster called clutter, and every
classification's probability of clutter is recorded (:mod:`auvlink.evaluation.clutter_sweep`). The survey's
score is that of the detections a run at the model's own threshold reports (the same detections, by the engine's
rule), and ``surveys.json`` also holds the scores at every threshold of the sweep (``clutter_sweep``). The
survey's ``out/`` then holds every cluster, those the model calls clutter too.
"""

from __future__ import annotations

import json
import math
import multiprocessing as mp
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from auvlink.evaluation.acoustic_draw import IDEAL, AcousticDraw, by_acoustic_factor, check_pairing, draw_acoustics
from auvlink.evaluation.clutter_sweep import GRID, apply_rule, best_threshold, model_threshold, sweep, write_calibrated
from auvlink.evaluation.draw import SurveyDraw, draw_surveys
from auvlink.evaluation.survey_scores import by_class, by_factor, pool, score_survey
from auvlink.jsonutil import to_jsonable


@dataclass(frozen=True)
class SurveyJob:
    draw: SurveyDraw
    folder: Path
    model: Path | None = None
    keep_log: bool = False
    clutter_threshold: float | None = None  # --clutter-sweep: the model's threshold (the survey is run at inf)
    acoustics: AcousticDraw = IDEAL


def run_survey(job: SurveyJob) -> dict[str, Any]:
    """Simulate, replay and score one survey (see the module docstring); returns its record."""
    from auvlink.atomic import atomic_dir
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.process import run_log
    from auvlink.sim.mission import simulate_to_log
    from auvlink.sim.scene import load_scene

    d, folder = job.draw, job.folder
    folder.mkdir(parents=True, exist_ok=True)
    scene_path = folder / "scene.toml"
    table = job.acoustics.table_toml()
    scene_path.write_text(d.scene_toml() + ("\n" + table if table else ""))
    log = folder / "mission.mcap"
    t0 = time.perf_counter()
    sim = simulate_to_log(load_scene(scene_path), log, progress=False, workers=1)
    t1 = time.perf_counter()
    sweep_at = job.clutter_threshold
    result = run_log(log, model=job.model, classify=True, progress=False,  # what `auvlink replay` runs
                     clutter_threshold=None if sweep_at is None else math.inf)
    out = folder / "out"
    with atomic_dir(out) as tmp:
        summary = write_outputs(result, tmp)
    t2 = time.perf_counter()
    if not job.keep_log:
        log.unlink()
    lines = (out / "detections.jsonl").read_text().splitlines()
    dets = [json.loads(x) for x in lines if x.strip()]
    truth = [(c, n, e) for c, n, e, _ in d.objects]
    rec = summary.get("recon") if isinstance(summary.get("recon"), dict) else {}
    extra: dict[str, Any] = {}
    if sweep_at is not None:  # every cluster was reported: keep them all, score what the model reports
        keys = ("id", "class", "position_ned", "size")
        extra = {"detections_all": [{k: x.get(k) for k in keys} for x in dets], "truth": truth,
                 "clutter_scores": [list(v) for v in result.clutter_scores]}
        dets = apply_rule(dets, result.clutter_scores, sweep_at)
    return {**extra, "index": d.index, "folder": str(folder), "draw": d.to_dict(), "factors": d.factors(),
            "acoustics": job.acoustics.to_dict(), "acoustic_factors": job.acoustics.factors(),
            "mission_s": sim.duration_s, "sonar_frames": sim.frames.get("sonar", 0),
            "sim_wall_s": t1 - t0, "replay_wall_s": t2 - t1, "recon": rec,
            "detections": [{k: x.get(k) for k in ("id", "class", "score", "position_ned", "size", "n_points",
                                                  "passes")}
                           for x in dets],
            "score": score_survey(dets, truth)}


def worker_init() -> None:
    """A survey worker process: one thread for each numerical library (the workers are the parallelism)."""
    os.environ["OMP_NUM_THREADS"] = "1"
    os.environ["MKL_NUM_THREADS"] = "1"
    os.environ["OPENBLAS_NUM_THREADS"] = "1"


def _run(job: SurveyJob) -> dict[str, Any]:
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:  # pragma: no cover - torch is a dependency; without it classification fails anyway
        pass
    return run_survey(job)


def run_surveys(n: int, seed: int, out: Path, *, workers: int = 1, model: Path | None = None,
                keep_logs: bool = False, progress: bool = True, small: bool = False,
                clutter_sweep: bool = False, acoustics: str = "random", sonar: str = "didson") -> dict[str, Any]:
    """Run ``n`` surveys of the draw ``seed`` into ``out``; returns (and writes) ``surveys.json``'s content.
    ``small``: the CI smoke draw (:func:`auvlink.evaluation.draw.draw_survey`); ``clutter_sweep``: see the module
    docstring; ``acoustics``: the acoustic space (:func:`auvlink.evaluation.acoustic_draw.draw_acoustics`);
    ``sonar``: the model flown (:func:`auvlink.evaluation.draw.survey_sonar`); a fixed profile with a model it does
    not describe raises ``ValueError`` (:func:`auvlink.evaluation.acoustic_draw.check_pairing`) before any work."""
    check_pairing(acoustics, sonar)
    if model is not None:  # every field checked before the first survey is simulated (minutes)
        from classify.checkpoint import read_checkpoint

        read_checkpoint(model)
    draws = draw_surveys(n, seed, small, sonar)
    at = model_threshold(model) if clutter_sweep else None
    jobs = [SurveyJob(d, out / "surveys" / f"{d.index:03d}", model, keep_logs, at,
                      draw_acoustics(acoustics, seed, d.index, d.window_length, d.sonar)) for d in draws]
    for j in jobs:  # a folder of an earlier run would mix its files with this run's
        if j.folder.exists():
            shutil.rmtree(j.folder)
    t0 = time.perf_counter()
    records: list[dict[str, Any]] = []
    if workers <= 1:
        worker_init()
        for j in jobs:
            records.append(_run(j))
            if progress:
                _progress(records[-1], len(records), n, t0)
    else:
        ctx = mp.get_context("spawn")
        with ctx.Pool(min(workers, n), initializer=worker_init) as p:
            for r in p.imap_unordered(_run, jobs):
                records.append(r)
                if progress:
                    _progress(r, len(records), n, t0)
            p.close()  # the workers end on their own: terminating them (the context's exit) leaks their semaphores
            p.join()
    records.sort(key=lambda r: int(r["index"]))
    result = summarize(records)
    if at is not None:
        rows = sweep(records, (*GRID, at))
        result["clutter_sweep"] = {"model_threshold": at, "best": best_threshold(rows, at), "rows": rows}
    result.update({"seed": seed, "acoustics": acoustics, "surveys_requested": n, "workers": workers,
                   "wall_s": time.perf_counter() - t0,
                   "small": small,
                   "command": f"auvlink eval --surveys {n} --seed {seed} --out {out}" + (" (small)" if small else "")
                   + (" --clutter-sweep" if clutter_sweep else "")
                   + f" --acoustics {acoustics}"  # explicit: the command repeats the run whatever the defaults
                   + (f" --sonar {sonar}" if sonar != "didson" else "")})
    out.mkdir(parents=True, exist_ok=True)
    (out / "surveys.json").write_text(json.dumps(to_jsonable(result), indent=1, allow_nan=True) + "\n")
    return result


def calibrate_model(model: Path, n: int, seed: int, folder: Path | None = None, *, workers: int = 1,
                    progress: bool = True, small: bool = False) -> dict[str, Any]:
    """Set the checkpoint ``model``'s clutter threshold, in place, to the best (F1 at 1 m) of a sweep over ``n``
    surveys of the draw ``seed`` replayed with it (:func:`run_surveys` into ``folder``; None: a temporary folder,
    removed). The threshold it had is kept as ``clutter_threshold_before``. Returns the sweep (``rows``, ``best``,
    ``model_threshold``) and ``surveys`` (how many were scored)."""
    with tempfile.TemporaryDirectory(prefix="auvlink-calibrate-") as tmp:
        result = run_surveys(n, seed, Path(tmp) if folder is None else folder, workers=workers, model=model,
                             progress=progress, small=small, clutter_sweep=True)
    cs = dict(result["clutter_sweep"])
    cs["surveys"] = len(result["surveys"])
    source = (f"clutter sweep over {cs['surveys']} simulated surveys (draw seed {seed}"
              + (", small" if small else "") + "): best F1 at 1 m")
    write_calibrated(model, model, cs["best"], source)  # in place: loaded whole, written under a temporary name
    return cs


def _progress(r: dict[str, Any], k: int, n: int, t0: float) -> None:
    s = r["score"]
    print(f"[{k}/{n}] survey {r['index']:03d}: {s['objects']} objects, {s['detections']} detections, "
          f"{s['correct_1m']} correct at 1 m; sim {r['sim_wall_s']:.0f} s, replay {r['replay_wall_s']:.0f} s "
          f"({time.perf_counter() - t0:.0f} s so far)", flush=True)


def summarize(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Pooled scores overall and per factor bin (the survey's factors, then the acoustic ones the surveys were
    drawn with), and the per-survey records."""
    scores = [r["score"] for r in records]
    factors = [r["factors"] for r in records]
    binned = by_factor(scores, factors) | by_acoustic_factor(scores, [r.get("acoustic_factors", {}) for r in records])
    return {"overall": pool(scores), "by_factor": binned, "by_class": by_class(scores),
            "surveys": records}
