"""Detection and classification over random surveys of the condition space (issue 16).

Run: ``auvlink bench survey --out DIR [--full]`` (or ``python benchmarks/bench_survey.py --out DIR [--full]``).

Draws surveys from the condition space (:mod:`auvlink.evaluation.draw`: seabed depth, slope and
roughness, altitude, tilt, speed, frame rate, heading, line spacing, 5-8 objects), simulates each into
a log, replays it through the pipeline and scores it (:mod:`auvlink.evaluation.surveys`; the same code
as ``auvlink eval --surveys N --seed S``): precision and recall at 1 m and 2 m with the class required
to match, overall, per factor bin (one plot per factor in the report) and failures by kind.
Quick: 8 surveys; ``--full``: 40 (the issue's acceptance size); smoke: 2 small surveys (2 lines,
2 objects). Seed 1 throughout. Two worker processes. Nothing is cached.

``tradeoffs`` (docs/BENCHMARKS.md): per acoustic profile (``ideal``, each sonar's flown with that sonar, and
``random``: the whole acoustic space, :mod:`auvlink.evaluation.acoustic_draw`), the same surveys simulated and
replayed under it:
wall seconds per sonar frame (simulate + replay) against 1 - F1 at 1 m (class must match). Quick: 2 small
surveys per profile; ``--full``: 8 surveys; smoke: ``ideal`` from the 2 small surveys above, 1 small survey under
``random`` (the first of those, its acoustics drawn).
``acoustic_profiles`` holds each profile's precision, recall and detections per object.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from _common import script_main, smoke, table, write_json

from auvlink.evaluation.acoustic_draw import SPACES, models_of
from auvlink.evaluation.survey_scores import BINS
from auvlink.evaluation.surveys import run_surveys
from auvlink.evaluation.tables import plot, text_table

SEED = 1
SURVEYS = {"smoke": 2, "quick": 8, "full": 40}
ACOUSTIC_SURVEYS = {"smoke": 1, "quick": 2, "full": 8}  # per acoustic profile


def _f1(p: float, r: float) -> float:
    return 0.0 if not p + r > 0 else 2.0 * p * r / (p + r)  # nan (no detection) counts as 0


def acoustic_tradeoffs(mode: str, folder: Path, workers: int, ideal: dict[str, Any]
                       ) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Per acoustic profile, the ``tradeoffs`` row (s per sonar frame against 1 - F1 at 1 m) and a row of its
    precision, recall and detections per object (module docstring); ``ideal``: the smoke run's own result."""
    n = ACOUSTIC_SURVEYS[mode]
    spaces = ("ideal", "random") if mode == "smoke" else (*SPACES[1:], "random")
    trade, detail = [], []
    for space in spaces:
        result = ideal if mode == "smoke" and space == "ideal" else run_surveys(
            n, SEED, folder / f"acoustics-{space}", workers=workers, progress=False, small=mode != "full",
            acoustics=space, sonar=(models_of(space) or ("didson",))[0])
        recs, o = result["surveys"], result["overall"]
        frames = sum(r["sonar_frames"] for r in recs)
        wall = sum(r["sim_wall_s"] + r["replay_wall_s"] for r in recs)
        error = 1.0 - _f1(o["precision_1m"], o["recall_1m"])
        trade.append({"knob": "acoustic profile", "setting": space, "time_s": wall / max(frames, 1),
                      "time_unit": "s per sonar frame (simulate + replay)", "error": error,
                      "error_name": "1 - F1 at 1 m (class must match)", "default": space == "ideal"})
        detail.append({"profile": space, "surveys": len(recs), "objects": o["objects"], "detections": o["detections"],
                       "precision_1m": o["precision_1m"], "recall_1m": o["recall_1m"],
                       "detections_per_object": o["detections_per_object"], "s_per_frame": wall / max(frames, 1)})
    return trade, detail


def factor_plots(result: dict[str, Any]) -> list[dict[str, Any]]:
    """One curve per factor for the bench report: P and R (1 m, class must match) at each bin's centre."""
    out = []
    for f, edges in BINS.items():
        rows = result["by_factor"][f]
        x = [0.5 * (edges[k] + edges[k + 1]) for k in range(len(edges) - 1)]
        out.append({"title": f"P/R per {f} bin (1 m, class must match)", "x": x, "xlabel": f, "ylabel": "P, R",
                    "series": {"precision": [r["precision_1m"] for r in rows],
                               "recall": [r["recall_1m"] for r in rows],
                               "target 0.90 (theory)": [0.9] * len(x)}})
    return out


def run(quick: bool = True, out_dir: Path = Path("bench-out")) -> dict[str, Any]:
    mode = "smoke" if smoke() else "quick" if quick else "full"
    n = SURVEYS[mode]
    folder = out_dir / "survey-eval"
    workers = min(2, os.cpu_count() or 1)
    result = run_surveys(n, SEED, folder, workers=workers, progress=True, small=mode == "smoke", acoustics="ideal")
    png = plot(result, folder / "surveys.png")
    print(text_table(result))
    o = result["overall"]
    rows = [{"factor": f, "bin": r["bin"], "surveys": r["surveys"], "objects": r["objects"],
             "precision_1m": r["precision_1m"], "recall_1m": r["recall_1m"], "precision_2m": r["precision_2m"],
             "recall_2m": r["recall_2m"], "detections_per_object": r["detections_per_object"], **r["failures"]}
            for f in BINS for r in result["by_factor"][f]]
    print(table([{k: v for k, v in r.items() if k in ("factor", "bin", "precision_1m", "recall_1m")} for r in rows]))
    res: dict[str, Any] = {
        "seed": SEED, "surveys": n, "command": result["command"], "workers": workers,
        "precision_1m": o["precision_1m"], "recall_1m": o["recall_1m"], "precision_2m": o["precision_2m"],
        "recall_2m": o["recall_2m"], "detections_per_object": o["detections_per_object"],
        "failures": o["failures"], "by_factor": rows, "plots": factor_plots(result), "plot_file": str(png),
        "survey_wall_s": result["wall_s"],
        "per_survey": [{"index": r["index"], "objects": r["score"]["objects"], "detections": r["score"]["detections"],
                        "correct_1m": r["score"]["correct_1m"], "mission_s": r["mission_s"],
                        "sim_wall_s": r["sim_wall_s"], "replay_wall_s": r["replay_wall_s"], **r["factors"]}
                       for r in result["surveys"]],
    }
    res["tradeoffs"], res["acoustic_profiles"] = acoustic_tradeoffs(mode, folder, workers, result)
    print(table(res["acoustic_profiles"]))
    write_json(out_dir, "survey", res)
    return res


if __name__ == "__main__":
    script_main(run, __doc__)
