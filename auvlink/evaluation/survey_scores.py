"""Scoring a survey's detections against its truth, and pooling the scores over surveys and factor bins.

Per survey (:func:`score_survey`): detections are matched to true objects greedily by horizontal
distance (each at most once, within ``radius`` m; :func:`auvlink.pipeline.truth_scores.match`, as ``summary.json``'s
scores); a match counts as correct when the classes agree
(precision = correct / detections, recall = correct / objects), at 1 m and at 2 m. Failures are
counted by kind, each detection and each object once:

- every detection is *assigned* to its nearest true object when that lies within ``ASSIGN_M``
  (2.5 m) horizontally, else it is ``clutter``;
- an object with two or more assigned detections is ``split`` (counted once per extra detection);
- an object with none is ``merged`` when it lies inside the horizontal box (``size``, grown by
  ``MERGE_PAD_M``) of a detection assigned to another object, else ``missed``;
- an object's nearest assigned detection farther than 1 m is ``offset`` (found, but mislocated),
  within 1 m with another class ``wrong_class``.

Pooling (:func:`pool`) sums counts, so precision and recall of a bin weigh every object and
detection of its surveys alike. Their 95 % intervals at 1 m (``precision_1m_ci95``, ``recall_1m_ci95``) come from a
bootstrap over the surveys (:func:`interval95`): objects of one survey share its seabed and geometry, so surveys,
not objects, are the independent draws. The factor bins are fixed (:data:`BINS`), not quantiles of the draw.
Per true class (:func:`by_class`): its objects, their recall at 1 m and their failures by kind, and what
the wrongly classified ones were called: which objects a survey misses or names wrongly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from auvlink.pipeline.truth_scores import match

ASSIGN_M = 2.5
MERGE_PAD_M = 0.3
RADII = (1.0, 2.0)
KINDS = ("split", "merged", "missed", "clutter", "wrong_class", "offset")

#: factor -> bin edges; a value v falls in bin i when edges[i] <= v < edges[i + 1] (last bin closed)
BINS: dict[str, tuple[float, ...]] = {
    "roughness": (0.0, 0.02, 0.05, 0.10),
    "slope_deg": (0.0, 3.0, 6.0, 10.0),
    "tilt_deg": (20.0, 25.0, 35.0, 45.0),
    "altitude": (3.0, 4.5, 6.0, 7.0),
    "speed": (0.6, 0.9, 1.2, 1.5),
    "fps": (5.0, 8.0, 11.0, 15.0),
}


def bin_label(factor: str, value: float) -> str:
    edges = BINS[factor]
    i = int(np.clip(np.searchsorted(edges, value, side="right") - 1, 0, len(edges) - 2))
    return f"{edges[i]:g}-{edges[i + 1]:g}"


def score_survey(detections: Sequence[dict[str, Any]], truth: Sequence[tuple[str, float, float]]
                 ) -> dict[str, Any]:
    """Counts of one survey. ``detections``: detections.jsonl lines (``class``, ``position_ned``,
    ``size``); ``truth``: (class, north, east) per object."""
    det_xy = np.array([d["position_ned"][:2] for d in detections], dtype=np.float64).reshape(-1, 2)
    det_cls = [str(d["class"]) for d in detections]
    tru_xy = np.array([[n, e] for _, n, e in truth], dtype=np.float64).reshape(-1, 2)
    tru_cls = [c for c, _, _ in truth]
    out: dict[str, Any] = {"detections": len(detections), "objects": len(truth)}
    for r in RADII:
        pairs = match(det_xy, tru_xy, r)
        out[f"correct_{r:g}m"] = sum(det_cls[i] == tru_cls[j] for i, j, _ in pairs)
        out[f"located_{r:g}m"] = len(pairs)
    kinds = dict.fromkeys(KINDS, 0)
    assigned: list[list[tuple[float, int]]] = [[] for _ in truth]
    if len(truth) and len(detections):
        dist = np.linalg.norm(det_xy[:, None, :] - tru_xy[None, :, :], axis=2)
        for i in range(len(detections)):
            j = int(np.argmin(dist[i]))
            if dist[i, j] <= ASSIGN_M:
                assigned[j].append((float(dist[i, j]), i))
            else:
                kinds["clutter"] += 1
    else:
        kinds["clutter"] = len(detections)
    per_object = []
    for j, a in enumerate(assigned):
        kind = "ok"
        if not a:
            inside = False
            for i, d in enumerate(detections):
                half = 0.5 * np.asarray(d.get("size", [0.0, 0.0])[:2], dtype=np.float64) + MERGE_PAD_M
                if np.all(np.abs(tru_xy[j] - det_xy[i]) <= half):
                    inside = True
            kind = "merged" if inside else "missed"
            kinds[kind] += 1
        else:
            kinds["split"] += len(a) - 1
            dmin, i = min(a)
            if dmin > 1.0:
                kind = "offset"
            elif det_cls[i] != tru_cls[j]:
                kind = "wrong_class"
            if kind != "ok":
                kinds[kind] += 1
            if len(a) > 1:
                kind = f"split+{kind}" if kind != "ok" else "split"
        per_object.append({"class": tru_cls[j], "kind": kind, "detections": len(a),
                           "detected_as": [det_cls[i] for _, i in sorted(a)],
                           "distance_m": [round(dd, 3) for dd, _ in sorted(a)]})
    out["failures"] = kinds
    out["per_object"] = per_object
    return out


def _ratio(a: float, b: float) -> float:
    return a / b if b else math.nan


BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0


def interval95(correct: Sequence[float], total: Sequence[float]) -> tuple[float, float]:
    """95 % interval of the pooled ratio sum(correct) / sum(total) of several surveys: a percentile bootstrap
    that resamples whole surveys (``scipy.stats.bootstrap``, paired, fixed seed so a result file is
    reproducible). NaN, NaN for fewer than 2 surveys or nothing to divide by."""
    c, t = np.asarray(correct, np.float64), np.asarray(total, np.float64)
    if c.size < 2 or t.sum() <= 0:
        return math.nan, math.nan
    from scipy.stats import bootstrap

    def ratio(a: np.ndarray, b: np.ndarray, axis: int = -1) -> np.ndarray:
        return np.asarray(a.sum(axis=axis) / np.maximum(b.sum(axis=axis), 1e-12))

    res = bootstrap((c, t), ratio, paired=True, vectorized=True, n_resamples=BOOTSTRAP_RESAMPLES,
                    method="percentile", rng=np.random.default_rng(BOOTSTRAP_SEED))
    ci = res.confidence_interval
    return float(ci.low), float(ci.high)


def pool(scores: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Sum the counts of several surveys; precision, recall, detections per object, and the 95 % intervals of
    precision and recall at 1 m (:func:`interval95`)."""
    n_det = sum(s["detections"] for s in scores)
    n_obj = sum(s["objects"] for s in scores)
    out: dict[str, Any] = {"surveys": len(scores), "objects": n_obj, "detections": n_det}
    for r in RADII:
        c = sum(s[f"correct_{r:g}m"] for s in scores)
        loc = sum(s[f"located_{r:g}m"] for s in scores)
        out[f"precision_{r:g}m"] = _ratio(c, n_det)
        out[f"recall_{r:g}m"] = _ratio(c, n_obj)
        out[f"detection_precision_{r:g}m"] = _ratio(loc, n_det)
        out[f"detection_recall_{r:g}m"] = _ratio(loc, n_obj)
    out["detections_per_object"] = _ratio(n_det, n_obj)
    correct = [s["correct_1m"] for s in scores]
    out["precision_1m_ci95"] = interval95(correct, [s["detections"] for s in scores])
    out["recall_1m_ci95"] = interval95(correct, [s["objects"] for s in scores])
    out["failures"] = {k: sum(s["failures"][k] for s in scores) for k in KINDS}
    return out


def by_factor(scores: Sequence[dict[str, Any]], factors: Sequence[dict[str, float]]) -> dict[str, list[dict[str, Any]]]:
    """Per factor, per bin (fixed edges), the pooled scores of the surveys that fall in it."""
    out: dict[str, list[dict[str, Any]]] = {}
    for f, edges in BINS.items():
        rows = []
        for k in range(len(edges) - 1):
            label = f"{edges[k]:g}-{edges[k + 1]:g}"
            sel = [s for s, fa in zip(scores, factors, strict=True) if bin_label(f, fa[f]) == label]
            rows.append({"factor": f, "bin": label, **pool(sel)})
        out[f] = rows
    return out


#: the failure kinds an object (not a detection) can have, as :func:`by_class` counts them
OBJECT_KINDS = ("split", "merged", "missed", "wrong_class", "offset")


def by_class(scores: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per true class (sorted by name): ``objects``, ``correct_1m`` (the object's nearest assigned detection
    within 1 m has its class; split objects count as found when it has), ``recall_1m``, ``failures`` (the
    object kinds of :func:`score_survey`; a split object with another failure counts as both) and
    ``called`` (class -> count: what its wrongly classified objects were named)."""
    acc: dict[str, dict[str, Any]] = {}
    for s in scores:
        for o in s["per_object"]:
            row = acc.setdefault(o["class"], {"objects": 0, "correct_1m": 0, "failures": dict.fromkeys(OBJECT_KINDS, 0),
                                              "called": {}})
            row["objects"] += 1
            kinds = [k for k in str(o["kind"]).split("+") if k != "ok"]
            for k in kinds:
                row["failures"][k] += 1
            if not set(kinds) - {"split"}:
                row["correct_1m"] += 1
            if "wrong_class" in kinds and o["detected_as"]:
                name = str(o["detected_as"][0])
                row["called"][name] = row["called"].get(name, 0) + 1
    return [{"class": c, **r, "recall_1m": _ratio(r["correct_1m"], r["objects"])} for c, r in sorted(acc.items())]
