"""Detections against a simulated mission's ground truth: detection and classification precision/recall.

A detection matches the nearest unmatched true object whose horizontal distance is at most
``radius`` (m), greedily by distance (:func:`match`, the one matching of the project: ``summary.json`` and
``auvlink eval --surveys``, :func:`auvlink.evaluation.survey_scores.score_survey`, both use it). Detection precision =
matched / detections, recall = matched / true objects; classification counts a match as correct when the classes
agree.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from auvlink.pipeline.results import METRE_DECIMALS, SCORE_DECIMALS, MissionResult


def match(det_xy: np.ndarray, truth_xy: np.ndarray, radius: float) -> list[tuple[int, int, float]]:
    """Greedy nearest-pair matching of detections ``det_xy`` (n, 2) to true objects ``truth_xy`` (m, 2), north and
    east in one frame (m): the pairs whose horizontal distance is at most ``radius`` (m) are taken nearest first,
    each detection and each true object at most once. Equal distances are taken in the order of the detection
    index, then of the truth index (a stable sort of the row-major distance matrix), so the pairs depend on the
    inputs alone. A non-finite position matches nothing. Returns (detection index, truth index, distance m), nearest
    first."""
    if det_xy.size == 0 or truth_xy.size == 0:
        return []
    d = np.linalg.norm(det_xy[:, None, :] - truth_xy[None, :, :], axis=2)
    within = np.flatnonzero(d <= radius)  # row-major: detection index, then truth index (NaN is never <= radius)
    order = within[np.argsort(d.ravel()[within], kind="stable")]
    pairs: list[tuple[int, int, float]] = []
    used_d: set[int] = set()
    used_t: set[int] = set()
    for flat in order:
        i, j = divmod(int(flat), d.shape[1])
        if i in used_d or j in used_t:
            continue
        used_d.add(i)
        used_t.add(j)
        pairs.append((i, j, float(d[i, j])))
    return pairs


def truth_in_result_frame(result: MissionResult) -> np.ndarray:
    """The true objects' north, east (n, 2) in the frame of the detections: with a georeference and the
    truth's latitude / longitude, through the run's datum (PROJ), so a run whose datum is not the
    simulator's (a replay with another ``[site]``, the first fix as the datum) is scored right; else as
    stored (the simulator's NED)."""
    from auvlink.geodesy import Datum

    truth = result.setup.truth
    ned = np.array([t.position_ned[:2] for t in truth], dtype=np.float64).reshape(-1, 2)
    datum = Datum.from_dict(result.georef.get("datum")) if result.georef.get("georeferenced") else None
    lat = [t.latitude for t in truth if t.latitude is not None]
    lon = [t.longitude for t in truth if t.longitude is not None]
    if datum is None or not truth or len(lat) != len(truth) or len(lon) != len(truth):
        return ned
    return datum.to_ned(lat, lon)[:, :2]


def score_detections(result: MissionResult, radius: float = 1.0) -> dict[str, Any] | None:
    """Scores against the truth, or None when the log has no ground truth; ``truth_skipped`` counts the
    entries of the log's truth left out as unusable (:func:`auvlink.pipeline.log_meta.truth_objects`)."""
    truth = result.setup.truth
    if not truth and not result.setup.truth_skipped:
        return None
    dets = result.detections
    det_xy = np.array([d.position_ned[:2] for d in dets]).reshape(-1, 2)
    truth_xy = truth_in_result_frame(result)
    pairs = match(det_xy, truth_xy, radius)
    correct = sum(1 for i, j, _ in pairs if dets[i].class_name == truth[j].class_name)
    n_det, n_truth = len(dets), len(truth)
    # scores and distances as detections.jsonl writes them
    rows = [{"truth_class": truth[j].class_name, "detected_class": dets[i].class_name,
             "score": round(float(dets[i].score), SCORE_DECIMALS), "distance_m": round(float(dist), METRE_DECIMALS),
             "detection_id": dets[i].id}
            for i, j, dist in pairs]
    missed = [truth[j].class_name for j in range(n_truth) if j not in {p[1] for p in pairs}]
    return {
        "radius_m": radius,
        "detections": n_det,
        "truth_objects": n_truth,
        "truth_skipped": result.setup.truth_skipped,
        "matched": len(pairs),
        "detection_precision": len(pairs) / n_det if n_det else 0.0,
        "detection_recall": len(pairs) / n_truth if n_truth else 0.0,
        "classification_precision": correct / n_det if n_det else 0.0,
        "classification_recall": correct / n_truth if n_truth else 0.0,
        "centroid_error_mean_m": round(float(np.mean([p[2] for p in pairs])), METRE_DECIMALS) if pairs else None,
        "matches": rows,
        "missed": missed,
        "false_detections": [dets[i].id for i in range(n_det) if i not in {p[0] for p in pairs}],
    }
