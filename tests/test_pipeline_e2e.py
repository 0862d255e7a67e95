"""End to end on a small simulated mission: simulate -> log -> replay -> recon -> classify -> outputs;
the detections against the simulator's truth (positions and classes)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from live_helpers import classes_against_truth
from small_mission import SCENE, TRUTH, SmallMissionRun

from auvlink.cli import main


@pytest.mark.slow
def test_replay_finds_the_objects(small_mission_run: SmallMissionRun) -> None:
    out = small_mission_run.out  # auvlink replay of the small mission, once per session
    dets = [json.loads(line) for line in (out / "detections.jsonl").read_text().splitlines()]
    for d in dets:
        assert set(d) >= {"id", "class", "score", "position_ned", "size", "n_points", "t_first", "t_last", "cloud"}
        assert (out / d["cloud"]).is_file() and 0.0 <= d["score"] <= 1.0 and d["t_first"] <= d["t_last"]
    truth = np.array(list(TRUTH.values()))
    found = np.array([d["position_ned"][:2] for d in dets]).reshape(-1, 2)
    # each true object has one detection within 1 m, and nothing else was detected
    dist = np.linalg.norm(found[:, None] - truth[None], axis=2)
    assert len(dets) == 2, dets
    assert (dist.min(axis=0) < 1.0).all(), dist
    got, want = classes_against_truth(dets, SCENE)  # each detection named as the object it found
    assert got == want, f"detected classes {got}, the simulator placed {want}"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scores"]["detection_recall"] == 1.0
    assert summary["devices"]["sonar"]["decode_errors"] == 0
    html = (out / "report.html").read_text()
    assert html.count("data:image/png;base64,") >= 4 and "Survey map" in html
    assert (out / "cloud.ply").read_bytes().startswith(b"ply")


def test_replay_of_missing_log_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["replay", str(tmp_path / "nope.mcap"), "--out", str(tmp_path / "o")]) == 1
    assert "no such log" in capsys.readouterr().err
