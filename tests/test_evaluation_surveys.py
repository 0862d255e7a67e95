"""Evaluation over random surveys: the draw covers the condition space, the scoring counts each failure
kind, and two small surveys run end to end through the real simulator and pipeline (the CI smoke test)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from image_checks import assert_plot_drawn

from auvlink.evaluation.draw import MIN_SEPARATION, SPACE, draw_survey, draw_surveys, onset_range
from auvlink.evaluation.survey_scores import bin_label, by_class, interval95, pool, score_survey
from auvlink.sim.scene import CLASSES, loads_scene


def test_draw_is_deterministic_and_independent_of_n() -> None:
    a = draw_surveys(5, seed=3)
    b = draw_surveys(8, seed=3)
    assert a == b[:5]
    assert draw_surveys(3, seed=4) != draw_surveys(3, seed=3)


def test_draws_stay_in_the_condition_space() -> None:
    for d in draw_surveys(60, seed=11):
        for name, value in (("depth", d.depth), ("slope_deg", d.slope_deg), ("roughness", d.roughness),
                            ("altitude", d.altitude), ("tilt_deg", d.tilt_deg), ("speed", d.speed), ("fps", d.fps)):
            lo, hi = SPACE[name]
            assert lo - 0.01 <= value <= hi + 0.01, (name, value)
        assert d.line_spacing <= 0.8 * d.swath + 1e-3
        assert 5 <= len(d.objects) <= 8 and all(o[0] in CLASSES for o in d.objects)
        xy = np.array([[n, e] for _, n, e, _ in d.objects])
        dist = np.linalg.norm(xy[:, None] - xy[None], axis=2) + np.eye(len(xy)) * 1e9
        assert dist.min() >= MIN_SEPARATION - 0.01
        # the window holds the flat-seabed onset (an independent formula: h / sin(depression))
        r = (d.altitude - 0.2) / math.sin(math.radians(d.tilt_deg + 7.0))
        assert d.window_start < r < d.window_start + d.window_length
        scene = loads_scene(d.scene_toml())  # a valid scene file
        assert len(scene.objects) == len(d.objects) and scene.survey.lines == d.lines


def test_onset_range_on_a_rising_seabed_is_shorter() -> None:
    assert onset_range(5.0, 30.0) == pytest.approx(10.0)
    assert onset_range(5.0, 30.0, 5.0) < 10.0 < onset_range(5.0, 30.0, -5.0)


def _det(cls: str, n: float, e: float, size: tuple[float, float] = (1.0, 1.0)) -> dict[str, object]:
    return {"class": cls, "position_ned": [n, e, 20.0], "size": [size[0], size[1], 0.5]}


def test_score_counts_every_failure_kind() -> None:
    truth = [("sphere", 0.0, 0.0), ("pipe", 10.0, 0.0), ("box", 20.0, 0.0), ("reef_a", 30.0, 0.0),
             ("reef_b", 31.5, 0.0), ("hemisphere", 40.0, 0.0), ("half_pipe", 50.0, 0.0)]
    dets = [_det("sphere", 0.2, 0.0),  # correct
            _det("pipe", 9.5, 0.0), _det("box", 11.2, 0.0),  # split (the nearest is right)
            _det("reef_a", 30.7, 0.0, (3.5, 2.0)),  # covers reef_b too: merged
            _det("box", 40.1, 0.0),  # wrong class
            _det("half_pipe", 51.6, 0.0),  # offset (1.6 m)
            _det("reef_c", 60.0, 5.0)]  # clutter; the box at 20 m is missed
    s = score_survey(dets, truth)
    assert s["failures"] == {"split": 1, "merged": 1, "missed": 1, "clutter": 1, "wrong_class": 1, "offset": 1}
    assert s["correct_1m"] == 3  # sphere, pipe, reef_a
    assert s["correct_2m"] == 4  # + half_pipe
    p = pool([s, s])
    assert p["precision_1m"] == pytest.approx(3 / 7) and p["recall_1m"] == pytest.approx(3 / 7)
    assert p["detections_per_object"] == pytest.approx(1.0) and p["failures"]["split"] == 2
    rows = {r["class"]: r for r in by_class([s, s])}
    assert sorted(rows) == sorted(c for c, _, _ in truth) and all(r["objects"] == 2 for r in rows.values())
    assert [c for c, r in rows.items() if r["recall_1m"] == 1.0] == ["pipe", "reef_a", "sphere"]  # split: found
    assert rows["pipe"]["failures"]["split"] == 2 and rows["box"]["failures"]["missed"] == 2
    assert rows["reef_b"]["failures"]["merged"] == 2 and rows["half_pipe"]["failures"]["offset"] == 2
    assert rows["hemisphere"]["failures"]["wrong_class"] == 2 and rows["hemisphere"]["called"] == {"box": 2}


def test_interval95_resamples_surveys() -> None:
    """The bootstrap interval holds the pooled ratio, is a point when every survey has the same ratio, narrows with
    more surveys, is reproducible, and is NaN where there is nothing to resample."""
    rng = np.random.default_rng(3)
    total = rng.integers(4, 9, 40).astype(float)
    correct = np.minimum(total, rng.binomial(total.astype(int), 0.9)).astype(float)
    lo, hi = interval95(correct, total)
    ratio = correct.sum() / total.sum()
    assert lo <= ratio <= hi and 0.0 < hi - lo < 0.15
    assert interval95(correct, total) == (lo, hi)
    lo4, hi4 = interval95(np.tile(correct, 4), np.tile(total, 4))
    assert hi4 - lo4 < 0.7 * (hi - lo)
    assert interval95(2 * total, 4 * total) == pytest.approx((0.5, 0.5))
    assert all(math.isnan(v) for v in interval95([3.0], [4.0]) + interval95([0.0, 0.0], [0.0, 0.0]))
    p = pool([{"detections": d, "objects": t, "correct_1m": c, "correct_2m": c, "located_1m": c, "located_2m": c,
               "failures": dict.fromkeys(("split", "merged", "missed", "clutter", "wrong_class", "offset"), 0)}
              for c, t, d in zip(correct, total, total, strict=True)])
    assert p["recall_1m_ci95"] == (lo, hi) and p["precision_1m_ci95"] == (lo, hi)


def test_bins() -> None:
    assert bin_label("roughness", 0.0) == "0-0.02" and bin_label("roughness", 0.10) == "0.05-0.1"
    assert bin_label("fps", 8.0) == "8-11" and bin_label("tilt_deg", 44.99) == "35-45"


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_two_small_surveys_end_to_end(tmp_path: Path) -> None:
    """The CI smoke: 2 small surveys of the space simulated, replayed and scored in two processes."""
    from auvlink.cli import main
    from auvlink.evaluation.surveys import summarize
    from auvlink.evaluation.tables import class_table, interval_line, text_table

    assert main(["eval", "--surveys", "2", "--seed", "5", "--out", str(tmp_path), "--workers", "2", "--small",
                 "--acoustics", "ideal"]) == 0
    data = json.loads((tmp_path / "surveys.json").read_text())
    res = summarize(data["surveys"])
    assert data["seed"] == 5 and len(data["surveys"]) == 2
    for r, d in zip(data["surveys"], (draw_survey(5, 0, True), draw_survey(5, 1, True)), strict=True):
        assert r["draw"]["objects"] == [list(o) for o in d.objects]
        folder = Path(r["folder"])
        assert (folder / "out" / "detections.jsonl").is_file() and not (folder / "mission.mcap").exists()
        assert r["sonar_frames"] > 100 and r["score"]["objects"] == 2
    o = res["overall"]
    assert o["objects"] == 4 and o["detections"] >= 1
    correct = sum(r["score"]["correct_1m"] for r in data["surveys"])  # pooled = the surveys' counts summed
    assert o["precision_1m"] == correct / o["detections"] and o["recall_1m"] == correct / 4
    # RESULTS.md: under `ideal` detection recall 0.985 and recall with the class 0.94 at 1 m (seed 9841, 132 objects):
    # at most one of 4 not found, at most two of 4 not found or named wrong (seed 5's low hemisphere on a 0.08 m rough
    # seabed is held clutter at 0.66, above the shipped threshold)
    located = sum(r["score"]["located_1m"] for r in data["surveys"])
    assert located >= 3 and correct >= 2, data["surveys"]
    assert len(o["recall_1m_ci95"]) == 2 and "95 % interval" in interval_line(res)
    assert "roughness" in text_table(res)
    assert_plot_drawn(tmp_path / "surveys.png")
    assert sum(r["objects"] for r in data["by_class"]) == 4 and data["by_class"] == res["by_class"]
    assert all(r["class"] in class_table(res) for r in res["by_class"])
