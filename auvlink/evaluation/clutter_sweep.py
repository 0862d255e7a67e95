"""The clutter threshold measured on whole surveys (``auvlink eval --surveys N --clutter-sweep``).

The classifier calls a cluster ``clutter`` (not an object: not reported) when its probability of clutter reaches
the checkpoint's ``clutter_threshold``. ``auvlink train`` sets that threshold from held-out synthesized clouds
(:func:`classify.training.workflow.calibrate_clutter`), whose mix of objects and seabed patches is not a survey's.
Here it is measured where it acts: every survey is replayed with no cluster called clutter (``run_log(...,
clutter_threshold=math.inf)``) while the engine records each classification's probability of clutter
(``MissionResult.clutter_scores``, one per emission of an object id). :func:`apply_rule` then gives, for any
threshold, exactly the detections a run at that threshold reports, by the engine's own rule: an emission whose
probability reaches the threshold makes its id clutter unless that id was reported before (an object once
reported stays one; a later emission of a clutter id may report it). Recon does not depend on the classifier,
so nothing else changes. :func:`sweep` scores every threshold of a grid over all surveys (pooled as
:func:`auvlink.evaluation.survey_scores.pool`), and :func:`best_threshold` picks the one with the highest F1 at 1 m
(the middle one of a tie). :func:`write_calibrated` stores it in a copy of the checkpoint.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from auvlink.evaluation.survey_scores import pool, score_survey

if TYPE_CHECKING:
    from classify.checkpoint import Checkpoint

#: the thresholds scored (and the model's own, added when it is not among them)
GRID: tuple[float, ...] = tuple(round(float(t), 2) for t in np.arange(0.30, 0.951, 0.05))


def reported_ids(scores: Iterable[tuple[int, float]], threshold: float) -> set[int]:
    """The ids a run with ``threshold`` reports at the end, from the (id, P(clutter)) of every emission in order."""
    state: dict[int, str] = {}
    for i, p in scores:
        if state.get(i) == "reported":
            continue
        state[i] = "clutter" if p >= threshold else "reported"
    return {i for i, s in state.items() if s == "reported"}


def apply_rule(detections: Sequence[dict[str, Any]], scores: Iterable[tuple[int, float]],
               threshold: float) -> list[dict[str, Any]]:
    """The detections (``detections.jsonl`` lines of a run that called nothing clutter) a run at ``threshold``
    reports; an id without a score (a model without the ``clutter`` output) is always reported."""
    scores = list(scores)
    keep = reported_ids(scores, threshold)
    scored = {i for i, _ in scores}
    return [d for d in detections if int(d["id"]) in keep or int(d["id"]) not in scored]


def _f1(o: dict[str, Any]) -> float:
    p, r = float(o.get("precision_1m", 0.0)), float(o.get("recall_1m", 0.0))
    return 2.0 * p * r / (p + r) if p + r > 0 else 0.0


def sweep(records: Sequence[dict[str, Any]], thresholds: Iterable[float] = GRID) -> list[dict[str, Any]]:
    """Per threshold the pooled scores over the survey records (each with ``detections_all``,
    ``clutter_scores`` and ``truth``), with the 95 % intervals of precision and recall that the pool gives."""
    rows = []
    for t in sorted(set(float(x) for x in thresholds)):
        scores = [score_survey(apply_rule(r["detections_all"], [tuple(s) for s in r["clutter_scores"]], t),
                               [tuple(x) for x in r["truth"]]) for r in records]
        o = pool(scores)
        rows.append({"threshold": t, "precision_1m": o["precision_1m"], "recall_1m": o["recall_1m"],
                     "precision_1m_ci95": o["precision_1m_ci95"], "recall_1m_ci95": o["recall_1m_ci95"],
                     "f1_1m": _f1(o), "detections_per_object": o["detections_per_object"],
                     "failures": o["failures"]})
    return rows


def best_threshold(rows: Sequence[dict[str, Any]], prefer: float | None = None) -> float:
    """The threshold of the highest F1 at 1 m; of several equal ones, ``prefer`` (the model's own: a sweep that
    cannot tell them apart gives no reason to move it) if it is among them, else the middle one (the most
    margin)."""
    best = max(r["f1_1m"] for r in rows)
    tied = sorted({float(r["threshold"]) for r in rows if r["f1_1m"] >= best - 1e-12})
    if prefer is not None and float(prefer) in tied:
        return float(prefer)
    return tied[(len(tied) - 1) // 2]


def table(rows: Sequence[dict[str, Any]], model_threshold: float, best: float) -> str:
    """The sweep as a text table (the model's threshold and the best one marked)."""
    out = ["clutter threshold  precision  recall   F1     det/obj  missed  clutter  wrong class"]
    for r in rows:
        f = r["failures"]
        mark = ("  <- model" if r["threshold"] == model_threshold else "") + (
            "  <- best" if r["threshold"] == best else "")
        out.append(f"{r['threshold']:>17.2f}  {r['precision_1m']:>9.3f}  {r['recall_1m']:>6.3f}  {r['f1_1m']:.3f}"
                   f"  {r['detections_per_object']:>7.3f}  {f.get('missed', 0):>6}  {f.get('clutter', 0):>7}"
                   f"  {f.get('wrong_class', 0):>11}{mark}")
    return "\n".join(out)


def _checkpoint(model: Path | None) -> Checkpoint:
    """The checkpoint ``model`` (None: the shipped one)."""
    from classify.checkpoint import load_checkpoint
    from classify.infer import DEFAULT_MODEL

    return load_checkpoint(Path(model) if model is not None else DEFAULT_MODEL)


def write_calibrated(model: Path | None, out: Path, threshold: float, source: str) -> Path:
    """A copy of the checkpoint ``model`` (None: the shipped one) at ``out`` whose clutter threshold is
    ``threshold`` (its decision model's, :mod:`classify.decision`, when it has one: what the engine applies; else
    ``clutter_threshold``); the one it had is kept as ``clutter_threshold_before``, and ``source`` says where the new
    one came from (``clutter_threshold_source``)."""
    from classify.checkpoint import save_recalibrated

    ck = _checkpoint(model)
    cal = dict(ck.calibration)
    cal["clutter_threshold_before"] = model_threshold(model)
    if cal.get("decision"):
        cal["decision"] = {**cal["decision"], "clutter_threshold": float(threshold)}
    else:
        cal["clutter_threshold"] = float(threshold)
    cal["clutter_threshold_source"] = source
    return save_recalibrated(ck, out, cal)


def model_threshold(model: Path | None) -> float:
    """The clutter threshold the checkpoint ``model`` (None: the shipped one) applies where the engine classifies
    (its decision model's when it has one, else ``clutter_threshold``, as :class:`classify.infer.Classifier` reads
    them)."""
    from classify.decision import CLUTTER_THRESHOLD
    from classify.infer import DEFAULT_CLUTTER_THRESHOLD

    cal = _checkpoint(model).calibration
    if cal.get("decision"):
        return float(cal["decision"].get("clutter_threshold", CLUTTER_THRESHOLD))
    return float(cal.get("clutter_threshold", DEFAULT_CLUTTER_THRESHOLD))
