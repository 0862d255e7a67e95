"""Never destroy what a user has (issue 13): every command that writes refuses an existing output
without ``--force`` (the old bytes untouched), refuses to write over its own input, checks its output
before any work, writes under a temporary name renamed when whole, and meets a full disk with one
line, exit 1 and a log readable up to its last complete chunk. The commands run as subprocesses."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from live_helpers import ROOT, simulate, start, threads, vehicle_config

from auvlink.atomic import atomic_dir, atomic_path, check_output_dir, check_output_file, partial_path
from auvlink.errors import OutputError
from logs_format import MissionLogReader, MissionLogWriter

LOOP_CONFIG = '[[devices]]\nname = "dvl"\nformat = "pd0"\nurl = "loop://"\n'


def auvlink(*args: str | Path, cwd: Path = ROOT, limit: int | None = None,
            timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """``python -m auvlink ARGS``; ``limit``: a file-size limit in bytes in the child (EFBIG past it,
    as a full disk: SIGXFSZ ignored)."""
    def child() -> None:
        if limit is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return subprocess.run([sys.executable, "-m", "auvlink", *map(str, args)], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, preexec_fn=child,
                          env={**os.environ, "PYTHONUNBUFFERED": "1"})


def one_error_line(proc: subprocess.CompletedProcess[str], *needles: str, code: int = 1) -> str:
    """``code``: 1, or 2 for an output that would replace an input (InputOverwriteError)."""
    err = proc.stderr.strip().splitlines()
    assert proc.returncode == code and len(err) == 1, (proc.returncode, proc.stderr)
    assert err[0].startswith("auvlink: error: ") and "Traceback" not in proc.stderr
    for needle in needles:
        assert needle in err[0], err[0]
    return err[0]


@pytest.fixture(scope="module")
def small_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2-second simulated mission (every device, ground truth), made by the CLI."""
    out = tmp_path_factory.mktemp("log") / "mission.mcap"
    proc = auvlink("sim", "--out", out, "--duration", "2", "--no-noise", "--quiet")
    assert proc.returncode == 0, proc.stderr
    return out


def no_leftovers(folder: Path) -> None:
    assert not [p.name for p in folder.iterdir() if "partial" in p.name or p.name.endswith(".old")]


# -- existing outputs ----------------------------------------------------------------------------
@pytest.mark.slow
def test_sim_keeps_an_existing_log_unless_forced(tmp_path: Path, small_log: Path) -> None:
    out = tmp_path / "mission.mcap"
    out.write_bytes(b"a day of ship time")
    one_error_line(auvlink("sim", "--out", out, "--duration", "1", "--quiet"), "exists", "--force")
    assert out.read_bytes() == b"a day of ship time"
    proc = auvlink("sim", "--out", out, "--duration", "1", "--quiet", "--force")
    assert proc.returncode == 0, proc.stderr
    with MissionLogReader(out) as log:
        assert log.complete and sum(1 for _ in log.messages(channels=["sonar"])) == 10
    no_leftovers(tmp_path)


@pytest.mark.slow
def test_record_keeps_an_existing_log_unless_forced(tmp_path: Path, small_log: Path) -> None:
    cfg = tmp_path / "loop.toml"
    cfg.write_text(LOOP_CONFIG)
    out = tmp_path / "r.mcap"
    out.write_bytes(small_log.read_bytes())
    one_error_line(auvlink("record", cfg, "--out", out, "--duration", "0.2"), "exists", "--force")
    assert out.read_bytes() == small_log.read_bytes()
    one_error_line(auvlink("record", cfg, "--out", cfg, "--duration", "0.2", "--force"), "is the input", code=2)
    assert cfg.read_text() == LOOP_CONFIG
    proc = auvlink("record", cfg, "--out", out, "--duration", "0.2", "--force")
    assert proc.returncode == 0, proc.stderr
    with MissionLogReader(out) as log:
        assert log.complete and sum(1 for _ in log.messages()) == 0  # a fresh (empty) recording
    no_leftovers(tmp_path)


@pytest.mark.slow
def test_live_refuses_a_folder_holding_a_mission(tmp_path: Path, small_log: Path) -> None:
    cfg = tmp_path / "loop.toml"
    cfg.write_text(LOOP_CONFIG)
    out = tmp_path / "live-out"
    out.mkdir()
    (out / "mission.mcap").write_bytes(small_log.read_bytes())
    t0 = time.monotonic()
    one_error_line(auvlink("live", cfg, "--out", out, "--duration", "0.2"), "not empty", "mission.mcap", "--force")
    assert time.monotonic() - t0 < 5  # refused before the ports or the model
    assert (out / "mission.mcap").read_bytes() == small_log.read_bytes()
    assert sorted(p.name for p in out.iterdir()) == ["mission.mcap"]
    other = tmp_path / "kept.mcap"
    other.write_bytes(b"x")
    one_error_line(auvlink("live", cfg, "--out", tmp_path / "new", "--log", other), "exists", "--force")
    assert other.read_bytes() == b"x" and not (tmp_path / "new").exists()
    (out / "objects").mkdir()
    (out / "objects" / "object_007_box.ply").write_text("the last run's")
    (out / "notes.txt").write_text("mine")
    proc = auvlink("live", cfg, "--out", out, "--duration", "0.3", "--force", "--no-classify", "--no-report")
    assert proc.returncode == 0, proc.stderr
    assert (out / "notes.txt").read_text() == "mine" and list((out / "objects").iterdir()) == []
    with MissionLogReader(out / "mission.mcap") as log:
        assert log.complete and sum(1 for _ in log.messages()) == 0  # the new (empty: loop://) mission
    no_leftovers(out)


@pytest.mark.slow
def test_log_import_refuses_its_own_input_and_an_existing_log(tmp_path: Path, small_log: Path) -> None:
    src = tmp_path / "m.mcap"
    src.write_bytes(small_log.read_bytes())
    (tmp_path / "sub").mkdir()
    (tmp_path / "link.mcap").symlink_to(src)
    for out, cwd in [(src, ROOT), (Path("m.mcap"), tmp_path), (Path("sub/../m.mcap"), tmp_path),
                     (tmp_path / "link.mcap", ROOT)]:
        one_error_line(auvlink("log", "import", src, "--format", "pd0", "--out", out, "--force", cwd=cwd),
                       "is the input", code=2)
    one_error_line(auvlink("log", "import", "link.mcap", "--format", "pd0", "--out", "m.mcap", "--force",
                           cwd=tmp_path), "is the input", code=2)
    assert src.read_bytes() == small_log.read_bytes()
    capture = tmp_path / "dvl.pd0"
    with MissionLogReader(small_log) as log:
        capture.write_bytes(b"".join(m.data for m in log.messages(channels=["dvl"])))
    out = tmp_path / "dvl.mcap"
    out.write_bytes(b"older import")
    one_error_line(auvlink("log", "import", capture, "--format", "pd0", "--out", out), "exists", "--force")
    assert out.read_bytes() == b"older import"
    # a capture with no whole frame leaves the old log as it was, even with --force
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"\x00" * 1000)
    one_error_line(auvlink("log", "import", junk, "--format", "pd0", "--out", out, "--force"), "no whole frame")
    assert out.read_bytes() == b"older import"
    proc = auvlink("log", "import", capture, "--format", "pd0", "--out", out, "--force")
    assert proc.returncode == 0, proc.stderr
    with MissionLogReader(out) as log:
        assert sum(1 for _ in log.messages()) == 10  # 5 Hz DVL, 2 s
    no_leftovers(tmp_path)


# -- outputs checked before any work ---------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.parametrize("command", ["replay", "export"])
def test_replay_and_export_check_the_output_before_any_work(tmp_path: Path, small_log: Path, command: str) -> None:
    a_file = tmp_path / "a-file"
    a_file.write_text("mine")
    full = tmp_path / "full"
    full.mkdir()
    (full / "notes.txt").write_text("mine too")
    cases = [(a_file, "not a folder"), (a_file / "sub", "Not a directory"), (full, "not empty")]
    if os.geteuid() != 0:  # root ignores permission bits: the probe would pass
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o555)
        cases.append((ro / "out", "Permission denied"))
    for out, needle in cases:
        args = ["replay", small_log] if command == "replay" else ["log", "export", small_log]
        t0 = time.monotonic()
        proc = auvlink(*args, "--out", out)
        # a start-up and a refusal take < 2 s; the whole replay takes longer (the limit scales with the load
        # of a machine booked over its cores, where every start-up stretches)
        limit = 2.0 * max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))
        assert time.monotonic() - t0 < limit, "the output is checked before the replay runs"
        one_error_line(proc, needle)
        assert proc.stdout == ""
    assert a_file.read_text() == "mine" and sorted(p.name for p in full.iterdir()) == ["notes.txt"]
    no_leftovers(tmp_path)


@pytest.mark.slow
def test_export_with_force_replaces_its_files_and_keeps_the_others(tmp_path: Path, small_log: Path) -> None:
    out = tmp_path / "export"
    (out / "sonar").mkdir(parents=True)
    (out / "sonar" / "frame_999999.png").write_bytes(b"stale")
    (out / "gyro.csv").write_text("stale")
    (out / "notes.txt").write_text("mine")
    proc = auvlink("log", "export", small_log, "--out", out, "--force", "--max-sonar", "2", "--every", "1")
    assert proc.returncode == 0, proc.stderr
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "gyro.csv").read_text().startswith("t_host_s")
    assert sorted(p.name for p in (out / "sonar").iterdir()) == ["frame_000000.png", "frame_000001.png", "frames.csv"]
    no_leftovers(tmp_path)


@pytest.mark.slow
def test_demo_train_and_eval_refuse_existing_outputs(tmp_path: Path) -> None:
    demo = tmp_path / "demo-out"
    demo.mkdir()
    (demo / "report.html").write_text("last week's")
    one_error_line(auvlink("demo", "--out", demo), "not empty", "--force")
    model = tmp_path / "model.pt"
    model.write_bytes(b"five minutes of training")
    one_error_line(auvlink("train", "--out", model, "--quick"), "exists", "--force")
    one_error_line(auvlink("eval", "--out", demo, "--quick"), "not empty", "--force")
    assert model.read_bytes() == b"five minutes of training" and (demo / "report.html").read_text() == "last week's"


# -- a full disk (a file-size limit in the child: writes past it fail with EFBIG) ------------------
@pytest.mark.slow
def test_sim_on_a_full_disk_is_one_line_and_leaves_the_old_log(tmp_path: Path, small_log: Path) -> None:
    out = tmp_path / "m.mcap"
    out.write_bytes(small_log.read_bytes())
    proc = auvlink("sim", "--out", out, "--duration", "3", "--quiet", "--force", limit=200_000)
    one_error_line(proc, "File too large", str(out))
    assert out.read_bytes() == small_log.read_bytes()  # derived output: all or nothing
    no_leftovers(tmp_path)


@pytest.mark.slow
def test_replay_and_export_on_a_full_disk_are_one_line_and_write_nothing(tmp_path: Path, small_log: Path) -> None:
    one_error_line(auvlink("log", "export", small_log, "--out", tmp_path / "e", limit=20_000), "File too large")
    one_error_line(auvlink("replay", small_log, "--out", tmp_path / "r", "--quiet", limit=20_000),
                   "File too large")
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.mark.slow
def test_record_on_a_full_disk_keeps_the_log_readable(tmp_path: Path) -> None:
    cfg = vehicle_config(tmp_path)
    out = tmp_path / "rec.mcap"
    limit = 1_500_000  # bytes: the "disk" fills after a few seconds of mission
    cmd = [sys.executable, "-m", "auvlink", "record", str(cfg), "--out", str(out), "--duration", "30",
           "--flush-interval", "0.5"]

    def child() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    with threads() as pool:
        stop_sim = threading.Event()
        start(pool, lambda: simulate(cfg, stop_sim), stop_sim, "sim")
        deadline = time.monotonic() + 20
        while not (tmp_path / "ports" / "can").exists() and time.monotonic() < deadline:
            time.sleep(0.05)  # record opens the ports once: the simulator serves them first
        time.sleep(0.5)
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                                preexec_fn=child, env={**os.environ, "PYTHONUNBUFFERED": "1"})
        try:
            stdout, stderr = proc.communicate(timeout=60)  # it stops by itself when the disk is full
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    err = stderr.strip().splitlines()
    assert proc.returncode == 1 and len(err) == 1, (stdout, stderr)
    assert "File too large" in err[0] and "Traceback" not in stderr
    assert 0 < out.stat().st_size <= limit and not partial_path(out).exists()
    with MissionLogReader(out) as reader:
        n = sum(1 for _ in reader.messages())
        assert not reader.complete
    assert n > 100  # the chunks written before the disk filled


# -- the module itself -----------------------------------------------------------------------------
def test_atomic_path_and_dir_commit_only_when_whole(tmp_path: Path) -> None:
    target = tmp_path / "a.json"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("crash")
    assert target.read_text() == "old"
    with atomic_path(target) as tmp:
        assert tmp.suffix == ".json" and tmp.parent == tmp_path
        tmp.write_text("new")
    assert target.read_text() == "new"
    umask = os.umask(0o022)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    folder = tmp_path / "out"
    with pytest.raises(RuntimeError), atomic_dir(folder) as tmp:
        (tmp / "x").write_text("half")
        raise RuntimeError("crash")
    assert not folder.exists()
    with atomic_dir(folder) as tmp:
        (tmp / "x").write_text("1")
    assert (folder / "x").read_text() == "1" and folder.stat().st_mode & 0o777 == 0o777 & ~umask
    (folder / "objects").mkdir()
    (folder / "objects" / "stale.ply").write_text("last run")
    (folder / "keep.txt").write_text("mine")
    with atomic_dir(folder) as tmp:  # an existing folder (--force): entries move in, objects/ swapped whole
        assert tmp.parent == folder
        (tmp / "objects").mkdir()
        (tmp / "objects" / "new.ply").write_text("this run")
        (tmp / "x").write_text("2")
    assert sorted(p.name for p in folder.iterdir()) == ["keep.txt", "objects", "x"]
    assert [p.name for p in (folder / "objects").iterdir()] == ["new.ply"] and (folder / "x").read_text() == "2"
    no_leftovers(tmp_path)


def test_check_output_refuses_a_leftover_partial_log(tmp_path: Path) -> None:
    out = tmp_path / "m.mcap"
    partial_path(out).write_bytes(b"a cut-off recording")
    for force in (False, True):
        with pytest.raises(OutputError, match=r"m\.mcap\.partial exists"):
            check_output_file(out, force=force)
    with pytest.raises(OutputError, match="is a folder"):
        check_output_file(tmp_path, force=True)
    check_output_dir(tmp_path / "new" / "deeper", force=False)


def test_the_writer_renames_when_closed_and_a_crash_leaves_the_partial(tmp_path: Path) -> None:
    out = tmp_path / "m.mcap"
    log = MissionLogWriter(out, flush_interval=0)
    log("gyro", "dsp1760", 1_000, b"\xfe\x81\xff\x55" + bytes(32))
    log.flush()
    assert not out.exists() and partial_path(out).stat().st_size > 0
    with MissionLogReader(partial_path(out)) as reader:  # what a kill -9 leaves: readable, findable
        assert sum(1 for _ in reader.messages()) == 1
    log.close()
    assert out.exists() and not partial_path(out).exists()
    with MissionLogReader(out) as reader:
        assert reader.complete


CLOSE_ON_A_FULL_DISK = """
import os, resource, signal, sys
from logs_format import MissionLogWriter
from logs_format.profile import LogError
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
log = MissionLogWriter(sys.argv[1], flush_interval=0, compression="none")
for i in range(300):
    log("gyro", "dsp1760", 1_000_000 * (i + 1), bytes(1000))
log.flush()  # the chunk on disk: the disk is full from here (the summary section, in the buffer, fails)
size = os.path.getsize(getattr(log, "partial", sys.argv[1])) + 16
resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
try:
    log.close()
except LogError as exc:
    print("LogError:", exc)
"""


def test_the_writer_closing_on_a_full_disk_raises_one_log_error(tmp_path: Path) -> None:
    out = tmp_path / "m.mcap"
    proc = subprocess.run([sys.executable, "-c", CLOSE_ON_A_FULL_DISK, str(out)], capture_output=True, text=True,
                          cwd=ROOT, timeout=60)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr  # no OSError from close
    assert proc.stdout.startswith("LogError: writing") and "File too large" in proc.stdout
    assert not partial_path(out).exists()  # a recording: kept under its name, cut
    with MissionLogReader(out) as reader:
        assert [m.log_time_ns for m in reader.messages()] == [1_000_000 * (i + 1) for i in range(300)]
        assert not reader.complete
