"""The clutter threshold measured on whole surveys (auvlink.evaluation.clutter_sweep, eval --clutter-sweep)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from auvlink.evaluation.clutter_sweep import (
    apply_rule,
    best_threshold,
    model_threshold,
    reported_ids,
    write_calibrated,
)


def test_reported_ids_follow_the_engine_rule() -> None:
    """Clutter at one emission and an object at a later one: reported; reported once: never made clutter."""
    scores = [(1, 0.8), (1, 0.2), (2, 0.3), (2, 0.9), (3, 0.7), (4, 0.1), (3, 0.6)]
    assert reported_ids(scores, 0.5) == {1, 2, 4}
    assert reported_ids(scores, 0.65) == {1, 2, 3, 4}  # 3: clutter at 0.7, an object at 0.6
    assert reported_ids(scores, 0.95) == {1, 2, 3, 4}
    assert reported_ids(scores, 0.0) == set()
    dets = [{"id": i, "class": "box", "position_ned": [0.0, 0.0, 0.0]} for i in (1, 2, 3, 4)]
    assert [d["id"] for d in apply_rule(dets, scores, 0.5)] == [1, 2, 4]
    assert [d["id"] for d in apply_rule(dets, [], 0.5)] == [1, 2, 3, 4]  # no clutter output: nothing is clutter


def test_best_threshold_is_the_middle_of_a_tie() -> None:
    rows = [{"threshold": t, "f1_1m": f} for t, f in ((0.3, 0.90), (0.35, 0.95), (0.4, 0.95), (0.45, 0.95),
                                                        (0.5, 0.93))]
    assert best_threshold(rows) == 0.4
    assert best_threshold(rows[:3]) == 0.35
    assert best_threshold(rows, prefer=0.45) == 0.45  # the model's own threshold, when it is among the best
    assert best_threshold(rows, prefer=0.5) == 0.4  # not among them: the middle


@pytest.mark.slow
def test_sweep_scores_what_a_run_at_the_threshold_reports(tmp_path: Path) -> None:
    """Two small surveys run as usual and with the sweep, with a model whose threshold calls many clusters
    clutter: the sweep's detections at the model's threshold are those of the plain run, to the bit, and its
    row at that threshold is the run's score."""
    from auvlink.evaluation.surveys import run_surveys
    from classify.checkpoint import load_checkpoint

    model = write_calibrated(None, tmp_path / "low.pt", 0.02, "test: a low threshold")
    cal = load_checkpoint(model).calibration
    # the threshold the engine applies: the decision model's (the shipped model has one)
    assert cal["decision"]["clutter_threshold"] == model_threshold(model) == 0.02
    assert cal["clutter_threshold_source"] == "test: a low threshold"
    assert cal["clutter_threshold_before"] is not None
    plain = run_surveys(2, 5, tmp_path / "plain", workers=2, model=model, progress=False, small=True)
    swept = run_surveys(2, 5, tmp_path / "swept", workers=2, model=model, progress=False, small=True,
                        clutter_sweep=True)
    for a, b in zip(plain["surveys"], swept["surveys"], strict=True):
        assert [(d["id"], d["class"], d["position_ned"]) for d in a["detections"]] == [
            (d["id"], d["class"], d["position_ned"]) for d in b["detections"]]
        assert a["score"] == b["score"]
        assert {i for i, _ in b["clutter_scores"]} == {d["id"] for d in b["detections_all"]}
    dropped = sum(len(b["detections_all"]) - len(b["detections"]) for b in swept["surveys"])
    assert dropped >= 1  # the low threshold made some cluster clutter: the rule was exercised
    cs = swept["clutter_sweep"]
    assert cs["model_threshold"] == 0.02 and cs["best"] == best_threshold(cs["rows"], prefer=0.02)
    row = next(r for r in cs["rows"] if r["threshold"] == 0.02)
    assert row["recall_1m"] == plain["overall"]["recall_1m"]
    assert row["precision_1m"] == plain["overall"]["precision_1m"]
    assert row["recall_1m_ci95"] == plain["overall"]["recall_1m_ci95"]
    assert "--clutter-sweep" in swept["command"]


@pytest.mark.slow
@pytest.mark.train
def test_calibrated_model_from_the_command_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--calibrated-model`` writes the model with the sweep's best threshold, and never replaces a file
    without --force (refused before any work)."""
    from auvlink.cli import main
    from classify.checkpoint import load_checkpoint

    out = tmp_path / "cal.pt"
    assert main(["eval", "--surveys", "1", "--seed", "5", "--small", "--workers", "1", "--out",
                 str(tmp_path / "run"), "--calibrated-model", str(out)]) == 0
    text = capsys.readouterr().out
    assert "clutter threshold on these 1 surveys" in text and "<- best" in text and "<- model" in text
    data = json.loads((tmp_path / "run" / "surveys.json").read_text())
    cal = load_checkpoint(out).calibration
    assert model_threshold(out) == cal["decision"]["clutter_threshold"] == data["clutter_sweep"]["best"]
    assert "--clutter-sweep" in cal["clutter_threshold_source"]
    assert main(["eval", "--surveys", "1", "--seed", "5", "--small", "--workers", "1", "--out",
                 str(tmp_path / "json"), "--clutter-sweep", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["clutter_sweep"]["rows"] and "<- best" not in json.dumps(doc)
    before = out.read_bytes()
    assert main(["eval", "--surveys", "1", "--small", "--out", str(tmp_path / "again"),
                 "--calibrated-model", str(out)]) == 1
    assert "--force" in capsys.readouterr().err
    assert out.read_bytes() == before and not (tmp_path / "again" / "surveys.json").exists()


@pytest.mark.slow
@pytest.mark.train
def test_calibrate_model_sets_the_sweeps_best_threshold_in_place(tmp_path: Path) -> None:
    """What ``auvlink train --calibrate-surveys`` runs after training: the checkpoint itself takes the sweep's best
    threshold, keeps the one it had as ``clutter_threshold_before``, and says where the new one came from; its
    weights are untouched; the surveys' results stay in the folder given."""
    import torch

    from auvlink.evaluation.surveys import calibrate_model
    from classify.checkpoint import load_checkpoint

    model = write_calibrated(None, tmp_path / "m.pt", 0.02, "test: a low threshold")
    weights = load_checkpoint(model).model.state_dict()
    cs = calibrate_model(model, 1, 5, tmp_path / "cal", workers=1, progress=False, small=True)
    ck = load_checkpoint(model)
    assert cs["surveys"] == 1 and cs["model_threshold"] == 0.02
    assert model_threshold(model) == cs["best"] == best_threshold(cs["rows"], prefer=0.02)
    assert ck.calibration["clutter_threshold_before"] == 0.02
    assert "1 simulated surveys (draw seed 5, small)" in ck.calibration["clutter_threshold_source"]
    assert all(torch.equal(v, ck.model.state_dict()[k]) for k, v in weights.items())
    assert (tmp_path / "cal" / "surveys.json").exists()


def test_train_refuses_bad_calibration_options_before_any_work(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    from auvlink.cli import main

    out = tmp_path / "m.pt"
    assert main(["train", "--out", str(out), "--calibrate-surveys", "0"]) == 1
    assert "--calibrate-surveys must be an integer in [1, " in capsys.readouterr().err
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "keep.txt").write_text("mine")
    assert main(["train", "--out", str(out), "--calibrate-surveys", "2", "--calibrate-out", str(busy)]) == 1
    assert "--calibrate-out" in capsys.readouterr().err
    assert not out.exists() and (busy / "keep.txt").read_text() == "mine"
