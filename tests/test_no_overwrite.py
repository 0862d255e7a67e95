"""No command replaces its own input (issue 34), and one run at a time holds an output folder.

Every command that writes refuses, with or without ``--force``, an output that is or would replace one
of its inputs (the log and its ``.partial``, ``--config``, ``--model``, ``--scene``): one line naming both
paths, exit status 2, before any work, the input untouched. Paths compare resolved, and by inode where
both exist (hard links). ``--out`` is locked for the run (:func:`auvlink.pipeline.run_guard.output_dir_lock`):
a second run is refused while the first holds it, the lock goes at the end (also on an error), a lock
file left by a dead process is taken over. The commands run through the real CLI on a real small log.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from small_mission import simulate_small

from auvlink.atomic import LOCK_NAME, partial_path
from auvlink.cli import main
from auvlink.pipeline.run_guard import REPLAY_OUTPUTS, output_dir_lock

ROOT = Path(__file__).resolve().parents[1]
LOOP_CONFIG = '[[devices]]\nname = "dvl"\nformat = "pd0"\nurl = "loop://"\n'
QUICK_S = 8.0  # s: a refusal comes before the log is read (a replay of the small log takes ~20 s here)


@pytest.fixture(scope="module")
def small_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_small(tmp_path_factory.mktemp("no-overwrite") / "small.mcap")


def refused(argv: list[str | Path], capsys: pytest.CaptureFixture[str], *needles: str | Path,
            code: int = 2) -> str:
    """Run the CLI; assert it exits ``code`` quickly with one ``auvlink: error:`` line holding ``needles``."""
    capsys.readouterr()
    t0 = time.monotonic()
    rc = main([str(a) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == code and len(err) == 1, (rc, err)
    assert err[0].startswith("auvlink: error: ") and time.monotonic() - t0 < QUICK_S
    for needle in needles:
        assert str(needle) in err[0], err[0]
    return err[0]


# -- replay ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["results.mcap", "summary.json", "detections.jsonl", "objects/object_001_pipe.ply"])
def test_replay_never_replaces_its_log_with_an_output(tmp_path: Path, small_log: Path, name: str,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "D"
    log = out / name
    log.parent.mkdir(parents=True)
    log.write_bytes(small_log.read_bytes())
    for force in ([], ["--force"]):
        refused(["replay", log, "--out", out, "--quiet", *force], capsys, log, out)
        assert log.read_bytes() == small_log.read_bytes()
    assert sorted(p.name for p in out.iterdir()) == [Path(name).parts[0]]  # no lock, nothing written


def test_replay_finds_an_input_through_links_and_other_paths(tmp_path: Path, small_log: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "D"
    out.mkdir()
    log = tmp_path / "m.mcap"
    log.write_bytes(small_log.read_bytes())
    os.link(log, out / "cloud.ply")  # a hard link at an output name: replacing it would drop the input's data
    refused(["replay", log, "--out", out, "--force"], capsys, log, "cloud.ply")
    (out / "cloud.ply").unlink()
    (out / "report.html").symlink_to(log)
    refused(["replay", log, "--out", out, "--force"], capsys, log, "report.html")
    (out / "report.html").unlink()
    alias = tmp_path / "alias"
    alias.symlink_to(out)
    inner = out / "results.mcap"
    inner.write_bytes(small_log.read_bytes())
    refused(["replay", alias / "results.mcap", "--out", out / ".." / "D", "--force"], capsys, "results.mcap")
    refused(["replay", log, "--out", alias, "--force", "--config", out / "summary.json"], capsys, "summary.json")
    refused(["replay", log, "--out", out, "--force", "--model", inner], capsys, inner)
    assert log.read_bytes() == inner.read_bytes() == small_log.read_bytes()


# -- live, demo, sim, record, log import/export, train, eval ---------------------------------------
def test_live_never_replaces_its_raw_log_or_config(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "loop.toml"
    cfg.write_text(LOOP_CONFIG)
    out = tmp_path / "DIR"
    refused(["live", cfg, "--out", out, "--log", out / "results.mcap", "--duration", "0.2"], capsys,
            out / "results.mcap", out)
    refused(["live", cfg, "--out", out, "--log", out / "objects" / "raw.mcap", "--force"], capsys, "raw.mcap")
    placed = out / "summary.json"
    out.mkdir()
    placed.write_text(LOOP_CONFIG)
    refused(["live", placed, "--out", out, "--force", "--duration", "0.2"], capsys, placed)
    refused(["live", cfg, "--out", tmp_path / "new", "--log", cfg, "--force"],
            capsys, cfg)  # the raw log over its own config
    assert placed.read_text() == cfg.read_text() == LOOP_CONFIG and not (tmp_path / "new").exists()
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]


def test_file_outputs_never_replace_an_input_or_its_partial(tmp_path: Path, small_log: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.mcap"
    scene = partial_path(out)  # the file sim writes while it runs
    scene.write_text("seed = 1\n")
    refused(["sim", "--out", out, "--scene", scene, "--force", "--quiet"], capsys, out, scene)
    cfg = partial_path(tmp_path / "r.mcap")
    cfg.write_text(LOOP_CONFIG)
    refused(["record", cfg, "--out", tmp_path / "r.mcap", "--force", "--duration", "0.1"], capsys, cfg)
    capture = partial_path(tmp_path / "i.mcap")
    capture.write_bytes(b"\x00" * 64)
    refused(["log", "import", capture, "--format", "pd0", "--out", tmp_path / "i.mcap", "--force"], capsys, capture)
    settings = partial_path(tmp_path / "m.pt")
    settings.write_text("[train]\n")
    refused(["train", "--out", tmp_path / "m.pt", "--config", settings, "--force", "--quick"], capsys, settings)
    assert scene.read_text() == "seed = 1\n" and cfg.read_text() == LOOP_CONFIG and capture.read_bytes() == bytes(64)
    assert not (tmp_path / "x.mcap").exists() and not (tmp_path / "m.pt").exists()


def test_folder_outputs_never_replace_an_input(tmp_path: Path, small_log: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "D"
    out.mkdir()
    scene = out / "report.html"
    scene.write_text("seed = 1\n")
    refused(["demo", "--out", out, "--scene", scene, "--force"], capsys, scene, out)
    (out / "mission.mcap").write_text("seed = 2\n")
    refused(["demo", "--out", out, "--scene", out / "mission.mcap", "--force"], capsys, "mission.mcap")
    exported = out / "gyro.csv"  # export writes <channel>.csv: a log of that name is replaced by its own export
    exported.write_bytes(small_log.read_bytes())
    refused(["log", "export", exported, "--out", out, "--force"], capsys, exported)
    sonar = out / "sonar" / "m.mcap"  # a channel's folder is replaced whole
    sonar.parent.mkdir()
    sonar.write_bytes(small_log.read_bytes())
    refused(["log", "export", sonar, "--out", out, "--force"], capsys, sonar)
    model = out / "eval.json"
    model.write_bytes(b"a checkpoint")
    refused(["eval", "--model", model, "--out", out, "--force", "--quick"], capsys, model)
    assert model.read_bytes() == b"a checkpoint" and exported.read_bytes() == sonar.read_bytes()
    assert sorted(p.name for p in out.iterdir()) == ["eval.json", "gyro.csv", "mission.mcap", "report.html", "sonar"]


def test_an_input_beside_the_outputs_is_kept_and_allowed(tmp_path: Path, small_log: Path) -> None:
    out = tmp_path / "D"
    out.mkdir()
    log = out / "mission.mcap"  # not a name export writes
    log.write_bytes(small_log.read_bytes())
    assert main(["log", "export", str(log), "--out", str(out), "--force", "--no-png", "--no-nav",
                 "--channels", "dvl"]) == 0
    assert log.read_bytes() == small_log.read_bytes()
    assert sorted(p.name for p in out.iterdir()) == ["dvl.csv", "mission.mcap"]


# -- the output folder's lock ----------------------------------------------------------------------
@pytest.mark.parametrize("command", ["replay", "export", "live", "demo", "batch"])
def test_a_held_folder_is_refused(tmp_path: Path, small_log: Path, command: str,
                                  capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "new"
    cfg = tmp_path / "loop.toml"
    cfg.write_text(LOOP_CONFIG)
    argv: dict[str, list[str | Path]] = {
        "replay": ["replay", small_log, "--out", out],
        "export": ["log", "export", small_log, "--out", out],
        "live": ["live", cfg, "--out", out, "--duration", "0.2"],
        "demo": ["demo", "--out", out],
        "batch": ["batch", small_log, "--out", out],
    }
    with output_dir_lock(out, force=False):  # another run's, as far as the command can tell (its own open file)
        line = refused(argv[command], capsys, f"{out} is in use by another auvlink run (pid {os.getpid()})", code=1)
        assert sorted(os.listdir(out)) == [LOCK_NAME]
    assert "--out" in line and not out.exists()  # the lock's folder, left empty, goes with it


def test_the_lock_goes_on_an_error_and_a_dead_holder_s_is_taken_over(tmp_path: Path, small_log: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    not_a_log = tmp_path / "junk.mcap"
    not_a_log.write_bytes(b"no log")
    capsys.readouterr()
    assert main(["log", "export", str(not_a_log), "--out", str(out), "--no-nav"]) == 1
    assert not out.exists()  # the folder it made, and its lock, are gone
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    out.mkdir()
    (out / LOCK_NAME).write_text(dead.stdout)  # a run killed with -9 leaves this (its lock went with it)
    assert main(["log", "export", str(small_log), "--out", str(out), "--no-png", "--no-nav", "--channels", "dvl"]) == 0
    assert sorted(os.listdir(out)) == ["dvl.csv"]


@pytest.mark.slow
def test_two_replays_into_one_new_folder(tmp_path: Path, small_log: Path) -> None:
    out = tmp_path / "out"
    first = subprocess.Popen([sys.executable, "-m", "auvlink", "replay", str(small_log), "--out", str(out), "--quiet"],
                             cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not (out / LOCK_NAME).exists():
            assert first.poll() is None and time.monotonic() < deadline, first.communicate()
            time.sleep(0.05)
        second = subprocess.run([sys.executable, "-m", "auvlink", "replay", str(small_log), "--out", str(out),
                                 "--force", "--quiet"], cwd=ROOT, capture_output=True, text=True, timeout=120)
        _, stderr = first.communicate(timeout=300)
    finally:
        if first.poll() is None:
            first.kill()
            first.communicate()
    assert second.returncode == 1 and second.stderr.strip().splitlines() == [
        f"auvlink: error: --out {out} is in use by another auvlink run (pid {first.pid}); wait for it to end, "
        "or give another --out"]
    assert first.returncode == 0, stderr
    names = set(os.listdir(out))
    assert names <= REPLAY_OUTPUTS and {"detections.jsonl", "results.mcap", "summary.json", "report.html"} <= names
    assert len((out / "detections.jsonl").read_text().splitlines()) == 2  # the first run's, whole
