"""The end-to-end benchmark's helpers: robust to the pipeline's summary format, and its smoke scene."""

from __future__ import annotations

import importlib
import json
import sys
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def e2e() -> Iterator[ModuleType]:
    sys.path.insert(0, str(BENCH))  # the scripts import their helpers (_common, _sim_log) by name
    try:
        yield importlib.import_module("bench_e2e")
    finally:
        sys.path.remove(str(BENCH))


def test_summary_of_todays_layout(e2e: ModuleType, tmp_path: Path) -> None:
    (tmp_path / "summary.json").write_text(json.dumps({
        "detections": 8, "timings": {"replay_decode_s": 1.5, "total_s": 4.0},
        "scores": {"detection_precision": 0.875, "detection_recall": 1.0, "classification_precision": 0.5,
                   "classification_recall": 0.25, "matched": 7},
        "recon": {"frames": 3001, "objects": 8}, "devices": {"gyro": {"samples": 30001}}}))
    s = e2e.read_summary(tmp_path)
    assert s["summary_found"] and s["summary_keys"] == ["detections", "devices", "recon", "scores", "timings"]
    assert s["timings"] == {"replay_decode_s": 1.5, "total_s": 4.0}
    assert s["detections"] == 8 and s["recon"] == {"frames": 3001.0, "objects": 8.0}
    assert e2e._score(s["scores"], "detection", "precision") == 0.875
    assert e2e._score(s["scores"], "classification", "recall") == 0.25


def test_summary_in_another_layout_or_missing(e2e: ModuleType, tmp_path: Path) -> None:
    assert e2e.read_summary(tmp_path) == {"summary_found": False}
    (tmp_path / "summary.json").write_text("[1, 2]")
    assert not e2e.read_summary(tmp_path)["summary_found"]
    (tmp_path / "summary.json").write_text("{not json")
    assert not e2e.read_summary(tmp_path)["summary_found"]
    # no "timings" table: durations are picked up wherever they are; lists of detections are counted
    (tmp_path / "summary.json").write_text(json.dumps({
        "stages": {"decode_s": 2.0, "recon_seconds": 3.0, "ok": True}, "detections": [{}, {}, {}]}))
    s = e2e.read_summary(tmp_path)
    assert s["timings"] == {"stages.decode_s": 2.0, "stages.recon_seconds": 3.0}
    assert s["detections"] == 3 and s["scores"] == {}
    assert e2e._score(s["scores"], "detection", "precision") is None


def test_numbers_skips_bools_and_text(e2e: ModuleType) -> None:
    assert e2e.numbers({"a": 1, "b": True, "c": "x", "d": {"e": 2.5, "f": [1]}}) == {"a": 1.0, "d.e": 2.5}


def test_smoke_scene_is_one_line_of_about_thirty_seconds(e2e: ModuleType) -> None:
    from auvlink.sim.scene import loads_scene

    sv = loads_scene(e2e.scene_text(0.5)).survey
    assert sv.lines == 1
    assert sv.line_length / sv.speed == pytest.approx(30.0)
    assert loads_scene(e2e.scene_text(5.0)).survey.lines >= 2
