"""Hostile log metadata (issue 34): JSON too deep or too large, stored numbers out of range, unusable truth.

The hostile logs are the small simulated mission (tests/small_mission.py) copied by the project's own
writer (:class:`logs_format.MissionLogWriter`) with one metadata record replaced. Every case must end in
a warning naming the key and the default used (or the value refused), never a traceback, and every
output is still written.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from small_mission import simulate_small

from auvlink.api.log import open_log
from auvlink.cli import main
from auvlink.pipeline.log_meta import live_settings, truth_objects
from logs_format import MissionLogReader, MissionLogWriter, log_info
from logs_format.bounded_json import MAX_JSON_DEPTH, JsonLimitError, loads_bounded, nesting_depth

DEEP = "[" * 200_000 + "]" * 200_000  # json.loads: RecursionError


def _reference_depth(text: str) -> int:
    """Nesting depth by a plain character walk (strings and escapes followed one character at a time)."""
    depth = deepest = 0
    inside = escaped = False
    for ch in text:
        if inside:
            escaped, inside = (False, True) if escaped else (ch == "\\", ch != '"')
            continue
        if ch == '"':
            inside = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


_json = st.recursive(
    st.none() | st.integers() | st.text(alphabet='[]{}"\\ab', max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(alphabet='[{"\\x', max_size=4), inner,
                                                                max_size=3),
    max_leaves=30)


@given(_json)
def test_nesting_depth_counts_brackets_outside_strings_only(value: Any) -> None:
    text = json.dumps(value)
    assert nesting_depth(text) == _reference_depth(text)
    assert loads_bounded(text) == value or nesting_depth(text) > MAX_JSON_DEPTH


def test_limits_refuse_deep_and_large_json_with_a_value_error() -> None:
    with pytest.raises(JsonLimitError, match="200000 levels deep"):
        loads_bounded(DEEP)
    with pytest.raises(ValueError, match="limit 10"):
        loads_bounded('"' + "x" * 20 + '"', max_bytes=10)
    assert loads_bounded('{"a": "[[[[[[" }', max_depth=1) == {"a": "[[[[[["}  # brackets in a string


# -- hostile logs from a real mission ---------------------------------------------------------------
@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_small(tmp_path_factory.mktemp("bounds") / "small.mcap")


def relog(src: Path, dst: Path, records: Mapping[str, Mapping[str, Any]]) -> Path:
    """``src``'s raw frames and metadata into ``dst``, the metadata records named in ``records`` replaced
    (string values are stored as they are: the hostile JSON text itself)."""
    with MissionLogReader(src) as reader:
        meta = {**reader.metadata(), **records}
        with MissionLogWriter(dst, software=False) as w:
            for name, data in meta.items():
                w.add_metadata(name, data)
            for m in reader.messages():
                if m.format is not None:
                    w(m.channel, m.format, m.log_time_ns, m.data)
    return dst


def _truth_record(mission: Path, objects: str) -> dict[str, Any]:
    with MissionLogReader(mission) as reader:
        return {**reader.metadata()["ground_truth"], "objects": objects}


@pytest.mark.slow
@pytest.mark.parametrize("record", ["vehicle_config", "ground_truth"])
def test_200k_deep_metadata_is_refused_by_key_in_log_info_open_log_and_replay(
        mission: Path, tmp_path: Path, record: str, capsys: pytest.CaptureFixture[str]) -> None:
    with MissionLogReader(mission) as reader:
        stored = reader.metadata()[record]
    key = "config" if record == "vehicle_config" else "objects"
    log = relog(mission, tmp_path / "deep.mcap", {record: {**stored, key: DEEP}})
    info = log_info(log, decode=False)
    assert info["metadata"][record][key] is None
    assert info["metadata_problems"] == [f"metadata {record}.{key}: JSON nested 200000 levels deep (limit 64); "
                                         "ignored"]
    with open_log(log) as opened:
        assert opened.metadata[record][key] is None and len(opened.metadata_problems) == 1
    assert main(["log", "info", str(log), "--no-decode"]) == 0
    assert f"warning: metadata {record}.{key}: JSON nested" in capsys.readouterr().out
    assert main(["replay", str(log), "--out", str(tmp_path / "out"), "--quiet", "--no-classify"]) == 0
    err = capsys.readouterr().err
    assert f"{record}.{key}: JSON nested 200000 levels deep" in err and "Traceback" not in err
    assert (tmp_path / "out" / "report.html").is_file()


@pytest.mark.parametrize(("engine", "key", "default"), [
    ({"poll_s": 0}, "poll_s", "1.0"),
    ({"max_pitch_deg": -1}, "max_pitch_deg", "15.0"),
    ({"max_turn_rate_deg_s": float("nan")}, "max_turn_rate_deg_s", "6.0"),
    ({"frame_block": "abc"}, "frame_block", "1"),
])
def test_stored_engine_settings_out_of_range_fall_back_to_the_default_by_key(
        engine: dict[str, Any], key: str, default: str) -> None:
    cfg, t0, warnings = live_settings({"live_pipeline": {"engine": {"poll_s": 2.0, **engine}}})
    assert cfg is not None and t0 is None
    assert str(getattr(cfg, key)) == default and (key == "poll_s" or cfg.poll_s == 2.0)  # the others kept
    assert len(warnings) == 1 and f"'live_pipeline.engine.{key}'" in warnings[0]
    assert warnings[0].endswith(f"using the default {default}")


@pytest.mark.parametrize("t0", [1e30, 10**30, -5, "abc", True])
def test_a_stored_time_origin_far_from_the_log_is_replaced_by_the_first_sample(t0: object) -> None:
    start, end = 1_767_225_600 * 10**9, 1_767_225_700 * 10**9
    _, got, warnings = live_settings({"live_pipeline": {"t0_ns": t0}}, start, end)
    assert got is None and len(warnings) == 1 and "'live_pipeline.t0_ns'" in warnings[0]
    assert live_settings({"live_pipeline": {"t0_ns": start - 5 * 10**9}}, start, end)[1:] == (start - 5 * 10**9, [])


def test_unusable_truth_entries_are_skipped_and_counted() -> None:
    objects = [{"class": "pipe", "position_ned": [1.0, 2.0, 20.0], "latitude": 27.6, "longitude": 123.9},
               {"class": "box", "position": [math.nan, 0.0]}, {"class": "box", "position": [1e308, 0.0]},
               {"class": "box", "position": [math.inf, 0.0]}, {"class": 5, "position": [0.0, 0.0]},
               {"class": "box", "position": "x"}, {"class": "box"}, "reef", {"class": "reef_a", "position": [3, 4]},
               {"class": "box", "position": [0.0, 0.0], "heading_deg": "north"},
               {"class": "box", "position": [0.0, 0.0], "latitude": 91.5}]
    truth = truth_objects({"objects": objects})
    assert [t.class_name for t in truth.objects] == ["pipe", "reef_a"]
    assert truth.objects[0].latitude == 27.6 and math.isnan(truth.objects[1].position_ned[2])
    assert truth.skipped == 9 and "'ground_truth.objects[1].position[0]'" in truth.problem


@pytest.mark.slow
def test_replays_with_hostile_engine_settings_run_and_skip_no_frame_for_them(
        mission: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from auvlink.pipeline.process import run_log

    ref = run_log(mission, classify=False, progress=False)
    capsys.readouterr()
    for name, record in (("poll", {"t0_ns": "0", "engine": json.dumps({"poll_s": 0})}),
                         ("pitch", {"engine": json.dumps({"max_pitch_deg": -1})}),
                         ("t0", {"t0_ns": "1e30", "engine": json.dumps({"frame_block": 64})})):
        got = run_log(relog(mission, tmp_path / f"{name}.mcap", {"live_pipeline": record}), classify=False,
                      progress=False)
        err = capsys.readouterr().err
        assert "auvlink: warning:" in err and "Traceback" not in err, err
        assert got.recon_stats["frames_processed"] == ref.recon_stats["frames_processed"] > 0, name
        assert got.recon_stats["frames_pitched"] == ref.recon_stats["frames_pitched"], name
        assert got.t0_ns == ref.t0_ns, name  # a refused origin: the first sample's time, as without one


@pytest.mark.slow
def test_truth_at_nan_inf_and_1e308_still_gives_every_output_and_a_report_line(
        mission: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = [{"class": "pipe", "position_ned": [math.nan, 0.3, 20.0]}, {"class": "reef_c", "position": [1e308, 1e308]},
           {"class": "box", "position": [math.inf, 0.0]}, {"class": 5, "position": "x"}, {"class": "box"}]
    good = [{"class": "reef_c", "position_ned": [30.0, -0.3, 20.0]}]
    log = relog(mission, tmp_path / "truth.mcap", {"ground_truth": _truth_record(mission, json.dumps(bad + good))})
    out = tmp_path / "out"
    assert main(["replay", str(log), "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "5 ground-truth entries left out as unusable" in err and "Traceback" not in err
    for name in ("detections.jsonl", "cloud.ply", "results.mcap", "summary.json", "report.html", "track.csv"):
        assert (out / name).is_file(), name

    def no_constants(token: str) -> None:
        raise AssertionError(f"{token} in strict JSON")

    summary = json.loads((out / "summary.json").read_text(), parse_constant=no_constants)
    assert summary["scores"]["truth_skipped"] == 5 and summary["scores"]["truth_objects"] == 1
    assert summary["scores"]["matched"] == 1  # the one usable object is still scored
    assert 'id="truth-skipped">5 ground-truth entries' in (out / "report.html").read_text()


def _strict(text: str) -> Any:
    def refuse(token: str) -> None:
        raise AssertionError(f"{token} in a strict JSON output")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_values_are_null_in_every_json_output(tmp_path: Path) -> None:
    import numpy as np

    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.report import write_report
    from auvlink.pipeline.results import Detection, MissionResult
    from auvlink.pipeline.setup import MissionSetup

    pts = np.array([[16.0, 0.3, 19.5], [16.5, 0.4, 19.6], [16.2, 0.9, 19.4]])
    det = Detection(0, "pipe", math.nan, (16.2, 0.5, 19.5), (0.5, 0.6, math.inf), 3, 1.7e9, 1.7e9 + 2, pts,
                    frame="site", latitude=27.6, longitude=123.9, drift_correction_ne=(math.nan, 0.0))
    truth = truth_objects({"objects": [{"class": "pipe", "position_ned": [16.0, 0.3, 20.0]},
                                       {"class": "box", "position_ned": [math.nan, 0.0, 20.0]}]})
    setup = MissionSetup(truth=truth.objects, truth_skipped=truth.skipped, truth_problem=truth.problem)
    result = MissionResult(log=tmp_path / "x.mcap", setup=setup, detections=[det], track=np.zeros((0, 3)),
                           georef={"georeferenced": True, "datum": {"latitude": 27.6, "longitude": 123.9}})
    out = tmp_path / "out"
    summary = write_outputs(result, out)
    write_report(result, summary, out)
    geo = _strict((out / "detections.geojson").read_text())
    props = geo["features"][0]["properties"]
    assert props["score"] is None and props["size"][2] is None and props["drift_correction_ne"][0] is None
    assert _strict((out / "summary.json").read_text())["scores"]["truth_skipped"] == 1
    assert _strict((out / "detections.jsonl").read_text())["score"] is None
    assert 'id="truth-skipped">1 ground-truth entries' in (out / "report.html").read_text()
