"""File names from data (issue 34): any string gives one safe, non-empty name that stays inside its folder;
names are unique; object PLYs of hostile class names, log export of devices whose names clean alike, and batch
logs named ``..mcap`` / ``...mcap`` write only inside their output folder."""

from __future__ import annotations

import csv
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.codecs import dsp1760
from auvlink.errors import OutputError
from auvlink.pipeline.batch import make_tasks, mission_names
from auvlink.pipeline.outputs import DetectionStream, object_ply_name
from auvlink.pipeline.results import Detection
from auvlink.safe_names import MAX_NAME, UniqueNames, path_inside, safe_name, unique_names
from logs_format import MissionLogWriter, export_log

T0 = 1_700_000_000_000_000_000
HOSTILE = ["/../../somewhere/x", "a/b", "..", ".", "...", "", "\x00", "bad\nname\r\x1b[31m", "CON", "nul.txt",
           "C:\\Windows\\x", "~root", "-rf", "x" * 5000, "é🙂", " ", "a..b", ".hidden"]


def _inside(folder: Path, name: str) -> bool:
    root = os.path.realpath(folder)
    target = os.path.realpath(os.path.join(root, name))
    return os.path.commonpath([root, target]) == root and target != root


@settings(max_examples=400, deadline=None)
@given(st.text(max_size=300))
def test_any_string_gives_a_safe_name_inside_the_folder(tmp_path_factory: pytest.TempPathFactory, text: str) -> None:
    folder = tmp_path_factory.getbasetemp()
    name = safe_name(text)
    assert name and len(name) <= MAX_NAME and name not in (".", "..")
    assert not set(name) & {"/", "\\", "\0"} and name.isascii() and name.isprintable()
    assert ".." not in name and not name.startswith(".") and not name.endswith(".")
    assert _inside(folder, name) and path_inside(folder, name) == folder / name
    assert _inside(folder, f"objects/object_001_{name}.ply")
    assert safe_name(name) == name  # a safe name is kept as it is


@settings(max_examples=200, deadline=None)
@given(st.lists(st.text(max_size=40), max_size=30))
def test_unique_names_never_clash_even_without_case(keys: list[str]) -> None:
    names = unique_names(keys, reserved=["batch.json"])
    assert len(names) == len(keys)
    lowered = [n.lower() for n in names]
    assert len(set(lowered)) == len(lowered) and "batch.json" not in lowered
    assert all(n and safe_name(n) == n for n in names)


def test_safe_names_of_the_hostile_cases() -> None:
    names = [safe_name(t) for t in HOSTILE]
    assert names[:8] == ["somewhere_x", "a_b", "unnamed", "unnamed", "unnamed", "unnamed", "unnamed",
                         "bad_name_31m"]
    assert names[8:10] == ["_CON", "_nul.txt"]  # Windows device names
    assert len(names[13]) <= MAX_NAME and names[13] != safe_name("x" * 4999)  # cut, the hash keeps them apart
    assert names[16] == "a.b" and names[17] == "hidden"
    assert [safe_name(n) for n in ("reef_a", "half_pipe", "sonar.fls", "2025-05-01_mission")] == \
        ["reef_a", "half_pipe", "sonar.fls", "2025-05-01_mission"]  # ordinary names unchanged


def test_unique_names_are_stable_per_key_and_apart_by_suffix() -> None:
    names = UniqueNames()
    assert names.name_for("a/b", ".csv") == "a_b" and names.name_for("a_b", ".csv") == "a_b-2"
    assert names.name_for("a/b", ".csv") == "a_b"  # the same key again: the same name
    assert names.name_for("A_B", ".csv") == "A_B-3"  # no clash without case either (macOS, Windows)
    assert names.name_for("a_b", "") == "a_b"  # a folder "a_b" does not clash with the file "a_b.csv"


@pytest.mark.parametrize("name", ["../x.ply", "/etc/passwd", "objects/../../x", ".", ""])
def test_path_inside_refuses_a_way_out(tmp_path: Path, name: str) -> None:
    with pytest.raises(OutputError, match="outside"):
        path_inside(tmp_path / "out", name)


def test_path_inside_follows_links(tmp_path: Path) -> None:
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "objects").symlink_to(tmp_path)
    with pytest.raises(OutputError, match="outside"):
        path_inside(tmp_path / "out", "objects/x.ply")


def _detection(i: int, class_name: str) -> Detection:
    pts = np.random.default_rng(i).normal(size=(20, 3))
    return Detection(i, class_name, 0.9, (1.0, 2.0, 20.0), (1.0, 1.0, 0.5), 20, 1.7e9, 1.7e9 + 1, pts)


def test_detection_stream_writes_hostile_class_names_inside_out(tmp_path: Path) -> None:
    """The live writer (and the PLY name every writer uses) with class names from a hostile checkpoint."""
    out = tmp_path / "a" / "b" / "out"
    stream = DetectionStream(out)
    for i, name in enumerate(HOSTILE):
        stream(_detection(i, name))
    assert stream.error is None and stream.count == len(HOSTILE)
    written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert len(written) == len(HOSTILE) + 1 and "detections.jsonl" in written
    assert all(w == "detections.jsonl" or w.startswith("objects/object_") for w in written)
    assert sorted(p.name for p in tmp_path.rglob("*")) == sorted(
        ["a", "b", "out", "objects", *[Path(w).name for w in written]])  # nothing anywhere else
    assert object_ply_name(_detection(7, "/../../somewhere/x")) == "objects/object_007_somewhere_x.ply"
    assert object_ply_name(_detection(3, "reef_a")) == "objects/object_003_reef_a.ply"


@pytest.mark.slow
def test_write_outputs_of_a_replay_with_hostile_class_names(small_mission_run: object, tmp_path: Path) -> None:
    """A real replay's result (the small mission), its detections renamed as a hostile checkpoint would name
    them (such a checkpoint is refused on load, tests/test_checkpoint_validation.py): every file of
    :func:`write_outputs` lands inside the output folder."""
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.process import run_log

    log = small_mission_run.log  # type: ignore[attr-defined]
    result = run_log(log, progress=False)
    assert result.detections
    result.detections = [replace(d, class_name=HOSTILE[k % 8]) for k, d in enumerate(result.detections)]
    out = tmp_path / "deep" / "er" / "out"
    summary = write_outputs(result, out)
    assert summary["detections"] == len(result.detections)
    assert not (tmp_path / "somewhere").exists() and not (tmp_path / "deep" / "somewhere").exists()
    outside = [p for p in tmp_path.rglob("*") if out not in p.parents and p != out and p not in out.parents]
    assert outside == []
    plys = sorted(p.name for p in (out / "objects").iterdir())
    assert len(plys) == len(result.detections) and all(p.startswith("object_") for p in plys)


def _gyro(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-4 * i, 0.0, 0.0), (0.0, 0.0, -9.8), sequence=i))


def test_log_export_keeps_devices_whose_names_clean_alike_apart(tmp_path: Path) -> None:
    """Two devices ``fog a`` and ``fog/a`` both clean to ``fog_a``: two files, each with its own rows."""
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path) as log:
        for i in range(10):
            log("fog a", "dsp1760", T0 + i * 10_000_000, _gyro(i))
        for i in range(4):
            log("fog/a", "dsp1760", T0 + i * 10_000_000 + 1, _gyro(20 + i))
        for i in range(3):
            log("../../up", "dsp1760", T0 + i * 10_000_000 + 2, _gyro(40 + i))
    out = tmp_path / "export"
    res = export_log(path, out)
    assert sorted(p.name for p in out.iterdir()) == ["fog_a-2.csv", "fog_a.csv", "up.csv"]
    assert sorted(res.csv_rows.values()) == [3, 4, 10]
    seqs = {}
    for f in out.iterdir():
        with open(f) as fh:
            seqs[f.name] = sorted(int(r["sequence"]) for r in csv.DictReader(fh))
    assert sorted(map(tuple, seqs.values())) == [tuple(range(10)), (20, 21, 22, 23), (40, 41, 42)]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["export", "m.mcap"]


def test_batch_mission_names_stay_in_the_batch_layout(tmp_path: Path) -> None:
    """Logs named ``..mcap`` and ``...mcap`` (and ones named as the batch's own files) get mission folders
    inside ``--out`` that are not its files."""
    logs = []
    for name in ("..mcap", "...mcap", "batch.json.mcap", "catalogue.csv.mcap", "a.mcap"):
        p = tmp_path / "logs" / name
        p.parent.mkdir(exist_ok=True)
        p.write_bytes(b"\x89MCAP0\r\n")
        logs.append(p)
    logs.append(tmp_path / "other" / "a.mcap")
    names = mission_names(logs)
    assert names == ["logs-mission", "logs-mission-2", "batch.json-2", "catalogue.csv-2", "logs-a", "other-a"]
    assert {"batch.json", "catalogue.csv", "catalogue.geojson"}.isdisjoint(n.lower() for n in names)
    out = tmp_path / "out"
    tasks = make_tasks(logs, out, model=None, classify=False, report=False, config=None, force=False)
    for t in tasks:
        folder = Path(t.out)
        assert folder.parent == out.absolute() and _inside(out, folder.name), t.out


@pytest.mark.slow
@pytest.mark.dask
def test_batch_of_logs_named_dot_dot_stays_in_its_layout(small_mission_log: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """``auvlink batch`` of real logs named ``..mcap`` and ``...mcap`` (once ``DIR/.`` and ``DIR/..``): each
    mission in a folder of its own inside ``--out``, nothing written beside it."""
    import shutil

    from auvlink.cli import main

    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("..mcap", "...mcap"):
        shutil.copyfile(small_mission_log, logs / name)
    out = tmp_path / "site"
    assert main(["batch", str(logs / "..mcap"), str(logs / "...mcap"), "--out", str(out), "--workers", "1",
                 "--quiet", "--no-report", "--json"]) == 0, capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["logs", "site"]
    assert sorted(p.name for p in logs.iterdir()) == ["...mcap", "..mcap"]
    missions = sorted(p.name for p in out.iterdir() if p.is_dir())
    assert missions == ["logs-mission", "logs-mission-2"]
    for m in missions:
        assert (out / m / "detections.jsonl").is_file() and (out / m / "batch.json").is_file()
