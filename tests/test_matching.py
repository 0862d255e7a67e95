"""One matching of detections to the truth: a mission's ``summary.json`` scores
(:func:`auvlink.pipeline.truth_scores.score_detections`) and a survey's
(:func:`auvlink.evaluation.survey_scores.score_survey`) pair the same detections with the same true objects, ties
included, as the documented rule says (nearest first; equal distances by detection index, then truth index; a
non-finite position matches nothing)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.evaluation.survey_scores import score_survey
from auvlink.pipeline.log_meta import TruthObject
from auvlink.pipeline.results import Detection, MissionResult
from auvlink.pipeline.setup import MissionSetup
from auvlink.pipeline.truth_scores import match, score_detections

# positions on a 0.5 m grid: many pairs at exactly the same distance (ties); sometimes a NaN coordinate
coordinate = st.one_of(st.integers(0, 6).map(lambda k: 0.5 * k), st.just(math.nan))
grid_xy = st.tuples(st.integers(0, 6).map(lambda k: 0.5 * k), st.integers(0, 6).map(lambda k: 0.5 * k))
position = st.one_of(grid_xy, grid_xy, grid_xy, st.tuples(coordinate, coordinate))


def reference_pairs(det_xy: np.ndarray, truth_xy: np.ndarray, radius: float) -> list[tuple[int, int]]:
    """The rule in plain Python: candidates sorted by (distance, detection index, truth index), taken greedily."""
    d = np.linalg.norm(det_xy[:, None, :] - truth_xy[None, :, :], axis=2) if len(det_xy) and len(truth_xy) else None
    if d is None:
        return []
    cands = sorted((float(d[i, j]), i, j) for i in range(d.shape[0]) for j in range(d.shape[1])
                   if math.isfinite(d[i, j]) and d[i, j] <= radius)
    used_d: set[int] = set()
    used_t: set[int] = set()
    out = []
    for _, i, j in cands:
        if i not in used_d and j not in used_t:
            used_d.add(i)
            used_t.add(j)
            out.append((i, j))
    return out


def mission(dets: list[tuple[tuple[float, float], int]], truth: list[tuple[float, float]]) -> MissionResult:
    """A replay's result with these detections (position, index of the class they were given) and true objects
    (true object ``j`` has class ``c{j}``, so the classification counts tell which object a detection took)."""
    detections = [Detection(id=k, class_name=f"c{c}", score=0.9, position_ned=(n, e, 10.0), size=(1.0, 1.0, 0.5),
                            n_points=10, t_first=0.0, t_last=1.0, points=np.zeros((0, 3)))
                  for k, ((n, e), c) in enumerate(dets)]
    objects = tuple(TruthObject(f"c{j}", (n, e, 10.0)) for j, (n, e) in enumerate(truth))
    return MissionResult(log=None, setup=MissionSetup(truth=objects), detections=detections, track=np.zeros((0, 3)))


@settings(max_examples=300, deadline=None)
@given(dets=st.lists(st.tuples(position, st.integers(0, 5)), max_size=7),
       truth=st.lists(grid_xy, min_size=1, max_size=6), radius=st.sampled_from([1.0, 2.0]))
def test_summary_and_survey_scores_pair_alike(dets: list[tuple[tuple[float, float], int]],
                                              truth: list[tuple[float, float]], radius: float) -> None:
    det_xy = np.array([p for p, _ in dets], dtype=np.float64).reshape(-1, 2)
    truth_xy = np.array(truth, dtype=np.float64).reshape(-1, 2)
    expected = reference_pairs(det_xy, truth_xy, radius)
    assert [(i, j) for i, j, _ in match(det_xy, truth_xy, radius)] == expected

    summary = score_detections(mission(dets, truth), radius)
    assert summary is not None
    got = [(row["detection_id"], int(row["truth_class"][1:])) for row in summary["matches"]]
    assert got == expected
    correct = sum(dets[i][1] == j for i, j in expected)
    assert round(summary["classification_recall"] * len(truth)) == correct

    lines = [{"class": f"c{c}", "position_ned": [n, e, 10.0], "size": [1.0, 1.0, 0.5]} for (n, e), c in dets]
    survey = score_survey(lines, [(f"c{j}", n, e) for j, (n, e) in enumerate(truth)])
    assert survey[f"located_{radius:g}m"] == len(expected) == summary["matched"]
    assert survey[f"correct_{radius:g}m"] == correct


def test_equal_distances_go_to_the_lower_detection_then_the_lower_truth_index() -> None:
    det = np.array([[0.0, 0.0], [2.0, 0.0]])
    truth = np.array([[1.0, 0.0], [3.0, 0.0]])  # detection 0 and 1 both 1 m from truth 0; detection 1 also from 1
    assert [(i, j) for i, j, _ in match(det, truth, 1.0)] == [(0, 0), (1, 1)]
    one = np.array([[0.0, 0.0]])
    two = np.array([[0.0, 1.0], [0.0, -1.0]])  # one detection, two objects at 1 m: the lower truth index
    assert [(i, j) for i, j, _ in match(one, two, 1.0)] == [(0, 0)]


def test_a_non_finite_position_matches_nothing() -> None:
    det = np.array([[math.nan, 0.0], [0.0, 0.0]])
    truth = np.array([[0.0, 0.0]])
    assert match(det, truth, 1.0) == [(1, 0, 0.0)]
    assert match(det[:1], truth, math.inf) == []
