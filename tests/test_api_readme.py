"""The Python API examples of docs/API.md and the README run as written, on a small simulated mission.

Every ```python block of docs/API.md is executed in order, in one namespace, and the README's "Python API"
section likewise in its own, in a folder holding ``mission.mcap`` (the small mission) and ``dvl.pd0`` (its DVL
frames, a raw capture); what they print is checked against the mission. The facade stays lazy.
"""

from __future__ import annotations

import contextlib
import io
import re
import subprocess
import sys
from pathlib import Path

import pytest
from small_mission import TRUTH

from logs_format import MissionLogReader

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
API_DOC = ROOT / "docs" / "API.md"


def python_blocks(text: str) -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)


def readme_api_blocks() -> list[str]:
    section = re.search(r"^## Python API\n(.*?)(?=^## )", README.read_text(), re.S | re.M)
    assert section, "README has no '## Python API' section"
    blocks = python_blocks(section.group(1))
    assert blocks, "the README's Python API section has no python block"
    return blocks


def run_blocks(path: Path, blocks: list[str]) -> list[str]:
    namespace: dict[str, object] = {"__name__": "docs"}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        for block in blocks:
            exec(compile(block, str(path), "exec"), namespace)  # the documented examples, verbatim
    return out.getvalue().splitlines()


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory, small_mission_log: Path) -> Path:
    root = tmp_path_factory.mktemp("api")
    (root / "mission.mcap").symlink_to(small_mission_log)  # the session's log, read only
    with MissionLogReader(small_mission_log) as r:  # the DVL channel's raw frames: a capture as `auvlink record` got it
        (root / "dvl.pd0").write_bytes(b"".join(m.data for m in r.messages(channels=["dvl"])))
    return root


@pytest.mark.slow  # replays or reads the small mission
def test_api_doc_examples_run(folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(folder)
    blocks = python_blocks(API_DOC.read_text())
    assert len(blocks) >= 4, "docs/API.md should show read, open_log, replay and mcap's reader"
    lines = run_blocks(API_DOC, blocks)
    assert lines[0] == "134 ensembles, 0 undecodable", lines[:3]  # 26.7 s of DVL pings at 5 Hz
    assert lines[1].startswith("['can', 'dvl', 'gyro', 'pressure', 'sonar'") and lines[2] == "complete"
    assert lines[3] == "['ground_truth', 'software', 'vehicle_config']"
    assert re.fullmatch(r"\d{19} didson \(\d+, \d+\)", lines[4]), lines[4]
    dets = lines[5:-2]
    assert {d.split()[1] for d in dets} == set(TRUTH) and lines[-2].startswith("2 objects;"), lines
    assert lines[-1] == "dvl Pd0Ensemble", lines[-1]


@pytest.mark.slow  # replays or reads the small mission
def test_readme_api_example_runs(folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(folder)
    lines = run_blocks(README, readme_api_blocks())
    assert lines[0].startswith("['can', 'dvl', 'gyro', 'pressure', 'sonar'") and lines[0].endswith("] complete")
    dets = lines[1:-1]
    assert {d.split()[1] for d in dets} == set(TRUTH) and lines[-1] == "2 objects", lines


@pytest.mark.slow  # replays or reads the small mission
def test_replay_stops_when_the_consumer_breaks(folder: Path) -> None:
    import threading

    import auvlink
    from auvlink.errors import AuvlinkError

    run = auvlink.replay(folder / "mission.mcap", classify=False)
    first = next(run)
    run.close()
    assert first.class_name == "unknown"
    assert not any(t.name == "auvlink-replay" for t in threading.enumerate())
    with pytest.raises(AuvlinkError, match="stopped before its end"):
        run.result  # noqa: B018


@pytest.mark.slow  # replays or reads the small mission
def test_read_needs_a_format_for_a_raw_capture(folder: Path) -> None:
    import auvlink
    from auvlink.errors import AuvlinkError

    with pytest.raises(AuvlinkError, match=r"read\(path, format='pd0'\)"):
        auvlink.read(folder / "dvl.pd0")
    with pytest.raises(AuvlinkError, match="no such file"):
        auvlink.read(folder / "nope.pd0", "pd0")
    assert sum(1 for _ in auvlink.read(folder / "mission.mcap")) > 4000  # a log needs no format


def test_import_auvlink_stays_light() -> None:
    code = ("import sys, auvlink; heavy = [m for m in ('auvlink.api', 'auvlink.pipeline', 'scipy', 'torch') "
            "if m in sys.modules]; print(heavy); auvlink.open_log; print('auvlink.api' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.split("\n")[:2] == ["[]", "True"], done.stdout


@pytest.mark.slow  # replays or reads the small mission
def test_a_run_nobody_holds_stops(folder: Path) -> None:
    import gc
    import threading

    import auvlink

    run = auvlink.replay(folder / "mission.mcap", classify=False, buffer=1)
    next(run)
    thread = next(t for t in threading.enumerate() if t.name == "auvlink-replay")
    del run
    gc.collect()
    thread.join(timeout=30)
    assert not thread.is_alive()
