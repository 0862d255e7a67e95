"""report.html in a real headless Chromium, and ``auvlink replay --json``, on a small simulated mission.

The page must load with no console error and show the survey map, one rotatable 3D view per object
(two WebGL scenes each: the points and the reference mesh) and the detection table; it must not fetch
anything (no CDN). False and missed detections are listed by name when the truth says so.
"""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import pytest
from browser_helpers import HeadlessChromium, chromium_or_skip
from small_mission import TRUTH, SmallMissionRun

from auvlink.cli import main
from auvlink.pipeline.report import render_report
from auvlink.pipeline.setup import TruthObject


@pytest.fixture(scope="module")
def replayed(small_mission_run: SmallMissionRun) -> tuple[Path, dict[str, object], Path]:
    """``auvlink replay --json`` on the small mission (once per session): (output folder, the JSON, the log)."""
    return small_mission_run.out, small_mission_run.doc, small_mission_run.log


@pytest.mark.slow
def test_replay_json_is_one_object(replayed: tuple[Path, dict[str, object], Path]) -> None:
    out, doc, log = replayed
    assert doc["command"] == "replay" and doc["log"] == str(log) and doc["out"] == str(out)
    counts = doc["counts"]
    assert isinstance(counts, dict) and counts["detections"] == 2 and counts["by_class"] == {"pipe": 1, "reef_c": 1}
    dets = doc["detections"]
    assert isinstance(dets, list) and {d["class"] for d in dets} == set(TRUTH)
    for d in dets:
        n, e = TRUTH[d["class"]]
        assert abs(d["position_ned"][0] - n) < 1.0 and abs(d["position_ned"][1] - e) < 1.0
    outputs = doc["outputs"]
    assert isinstance(outputs, dict) and all(Path(p).exists() for p in outputs.values())
    assert set(outputs) >= {"detections.jsonl", "summary.json", "report.html"}
    scores = doc["scores"]
    assert isinstance(scores, dict) and scores["detection_recall"] == 1.0
    timings = doc["timings"]
    assert isinstance(timings, dict) and timings["total_s"] > 0
    assert doc["log_loss"]["state"] == "complete"  # type: ignore[index]


@pytest.mark.slow
@pytest.mark.browser
def test_report_renders_in_headless_chromium(replayed: tuple[Path, dict[str, object], Path]) -> None:
    binary = chromium_or_skip()
    out, doc, _ = replayed
    page = out / "report.html"
    html = page.read_text()
    # self-contained: no script or stylesheet from the network, plotly.js inline once
    assert not re.search(r"<script[^>]+src=|<link[^>]+href=\"?https?:", html)
    assert html.count("Plotly.newPlot(") >= 4 and len(html) < 8_000_000
    assert html.count("ring: the object") >= 2  # the fans show where the object is
    n_det = doc["counts"]["detections"]  # type: ignore[index]
    with HeadlessChromium(binary) as browser:
        browser.open(page)
        plots = browser.wait_for(f"document.querySelectorAll('.js-plotly-plot').length >= {n_det + 2}"
                                 " && document.querySelectorAll('.js-plotly-plot').length")
        got = browser.evaluate("""(() => {
            const q = s => Array.from(document.querySelectorAll(s));
            const map = document.getElementById('survey-map');
            return {
              map: !!map && map.classList.contains('js-plotly-plot') && map._fullData.length,
              map_svg: !!map && map.querySelectorAll('.scatterlayer .trace').length,
              views: q('.object .js-plotly-plot').map(d => [d.id,
                  ['scene', 'scene2'].filter(s => d._fullLayout[s] && d._fullLayout[s]._scene
                                                  && d._fullLayout[s]._scene.glplot).length]),
              rows: q('#detection-table tr').length,
              fans: q('.frames img').filter(i => i.complete && i.naturalWidth > 0).length,
              webgl_message: document.body.innerText.includes('WebGL is not supported'),
              duplicate_ids: (ids => ids.length - new Set(ids).size)(  // the page's own (plotly's inner ones aside)
                  q('[id]').filter(e => e.classList.contains('js-plotly-plot') || !e.closest('.js-plotly-plot'))
                           .map(e => e.id)),
            };
        })()""")
        first = doc["detections"][0]["id"]  # type: ignore[index]
        hash_after_click = browser.evaluate(  # a click on a detection of the map goes to its object
            f"document.getElementById('survey-map').emit('plotly_click', {{points: [{{customdata: {first}}}]}});"
            " location.hash")
        errors = list(browser.console_errors)
    assert errors == [], errors
    assert hash_after_click == f"#object-{first}-section"
    assert plots >= n_det + 2  # map, one per object, timings
    assert got["map"] >= 3 and got["map_svg"] >= 3, got  # highlight points, track, truth, detections
    assert [v[1] for v in got["views"]] == [2] * n_det, got["views"]  # points + reference mesh, both drawn
    assert sorted(v[0] for v in got["views"]) == sorted(f"object-{d['id']}" for d in doc["detections"])  # type: ignore[union-attr]
    assert got["rows"] == n_det + 1 and not got["webgl_message"] and got["duplicate_ids"] == 0, got
    assert got["fans"] >= n_det, got  # the sonar frames that saw each object, decoded by the browser


@pytest.mark.slow
def test_report_names_false_and_missed_detections(replayed: tuple[Path, dict[str, object], Path]) -> None:
    import auvlink

    _, _, log = replayed
    run = auvlink.replay(log, classify=False)
    result = run.result
    assert len(result.detections) == 2
    # a truth that moved the reef 10 m away: the reef's detection is false, the moved reef is missed
    truth = (TruthObject("pipe", (16.0, 0.3, 20.0), 60.0), TruthObject("reef_c", (40.0, 5.0, 20.0), 0.0))
    result.setup = dataclasses.replace(result.setup, truth=truth)
    summary = {"scores": {"radius_m": 1.0}}
    html = render_report(result, summary)
    false = re.search(r'<ul id="false-detections">(.*?)</ul>', html, re.S)
    missed = re.search(r'<ul id="missed-objects">(.*?)</ul>', html, re.S)
    assert false and missed, "no list of false or missed detections"
    reef = next(d for d in result.detections if d.position_ned[0] > 25)
    assert f"#{reef.id} unknown" in false.group(1) and false.group(1).count("<li>") == 1
    assert "reef_c at north 40.00 m, east 5.00 m" in missed.group(1) and missed.group(1).count("<li>") == 1


@pytest.mark.slow
def test_a_full_disk_gets_the_live_page_without_figures(replayed: tuple[Path, dict[str, object], Path],
                                                   tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import errno

    import auvlink
    from auvlink.atomic import write_text
    from auvlink.pipeline import report

    def small_disk(path: Path, text: str) -> Path:  # a 1 MB file-size cap, as RLIMIT_FSIZE or a quota
        if len(text.encode()) > 1_000_000:
            raise OSError(errno.EFBIG, "File too large")
        return write_text(path, text)

    _, _, log = replayed
    result = auvlink.replay(log, classify=False).result
    monkeypatch.setattr(report, "write_text", small_disk)
    with pytest.raises(OSError, match="File too large"):  # replay: all or nothing, the command fails
        report.write_report(result, {"scores": None}, tmp_path)
    result.mode = "live"  # live writes what it can
    html = report.write_report(result, {"scores": None}, tmp_path).read_text()
    assert "Plotly" not in html and "interactive figures (map, 3D views, timings) are left out" in html
    assert "File too large" in html and 'id="detection-table"' in html and html.count("data:image/png") >= 2

    def read_only(path: Path, text: str) -> Path:
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(report, "write_text", read_only)
    with pytest.raises(PermissionError):  # anything but a full disk is not hidden
        report.write_report(result, {"scores": None}, tmp_path)


@pytest.mark.slow
def test_demo_json_is_one_object(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from small_mission import SCENE

    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--scene", str(scene), "--json"]) == 0
    captured = capsys.readouterr()
    doc = json.loads(captured.out)  # stdout holds the JSON object and nothing else
    assert doc["command"] == "demo" and doc["log"] == str(out / "mission.mcap")
    assert doc["counts"]["by_class"] == {"pipe": 1, "reef_c": 1} and doc["scores"]["detection_recall"] == 1.0
    assert doc["timings"]["simulation_s"] > 0 and Path(doc["outputs"]["report.html"]).is_file()
    assert "[1/2] simulating the mission" in captured.err  # the progress lines went to stderr


def test_a_run_with_nothing_still_renders(tmp_path: Path) -> None:
    import numpy as np

    from auvlink.pipeline.report import write_report
    from auvlink.pipeline.results import MissionResult
    from auvlink.pipeline.setup import MissionSetup

    empty = MissionResult(log=tmp_path / "gone.mcap", setup=MissionSetup(), detections=[], track=np.zeros((0, 3)))
    html = write_report(empty, {}, tmp_path).read_text()
    assert "No object was detected" in html and 'id="survey-map"' in html
    assert "The log has no ground truth" in html and "No device statistics" in html
