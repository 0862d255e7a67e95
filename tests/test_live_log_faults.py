"""The mission log of a live run fails: an unwritable path (one clear line, nothing opened) and a full
disk mid-mission (emulated with a file-size limit): the run stops cleanly with one clear line, DIR is
written, and the log replays up to its last complete chunk."""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from live_helpers import ROOT, simulate, start, threads, vehicle_config

from auvlink.cli import main
from logs_format import MissionLogReader

pytestmark = [pytest.mark.live, pytest.mark.slow]

LIMIT = 1_500_000  # bytes: the "disk" fills after a few seconds of mission


def test_an_unwritable_log_path_is_one_line_and_opens_nothing(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    cfg = vehicle_config(tmp_path)
    (tmp_path / "afile").write_text("not a folder")
    code = main(["live", str(cfg), "--out", str(tmp_path / "out"), "--log", str(tmp_path / "afile" / "x.mcap")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1, err
    assert err[0].startswith("auvlink: error: cannot create log") and "Not a directory" in err[0]


def _limit_file_size() -> None:  # in the child: writes past LIMIT fail with EFBIG, as on a full disk
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT, LIMIT))


def test_a_full_disk_stops_the_run_cleanly_and_keeps_what_was_written(tmp_path: Path) -> None:
    cfg = vehicle_config(tmp_path)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "auvlink", "live", str(cfg), "--out", str(out), "--duration", "40",
           "--backoff-max", "0.2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            preexec_fn=_limit_file_size, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert proc.stdout is not None
        assert "Ctrl-C stops" in proc.stdout.readline()  # the ports are being opened
        with threads() as pool:
            stop_sim = threading.Event()
            start(pool, lambda: simulate(cfg, stop_sim), stop_sim, "sim")
            stdout, stderr = proc.communicate(timeout=60)  # it stops by itself when the disk is full
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 1, (stdout, stderr)
    err = stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("auvlink: error: writing the mission log"), err
    assert "File too large" in err[0] and "stopped cleanly" in err[0]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["log_loss"] and summary["recon"]["frames"] > 0 and summary["unwritten"] == []
    assert "report:" in stdout and (out / "report.html").stat().st_size > 0  # DIR written all the same
    log = out / "mission.mcap"
    assert 0 < log.stat().st_size <= LIMIT and not (out / "mission.mcap.partial").exists()
    with MissionLogReader(log) as reader:
        n = sum(1 for _ in reader.messages())
        assert not reader.complete
    assert n > 100  # the chunks written before the disk filled replay


def test_sigterm_flushes_the_log_and_the_output_folder(tmp_path: Path) -> None:
    cfg = vehicle_config(tmp_path)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "auvlink", "live", str(cfg), "--out", str(out), "--backoff-max", "0.2"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        assert proc.stdout is not None
        assert "Ctrl-C stops" in proc.stdout.readline()
        with threads() as pool:
            stop_sim = threading.Event()
            st, _, _ = start(pool, lambda: simulate(cfg, stop_sim), stop_sim, "sim")
            st.join(6.0)  # mid-mission (the pipe object at N 10 m is behind, the reef ahead)
            proc.send_signal(signal.SIGTERM)
            stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, stderr
    assert "report:" in stdout and (out / "report.html").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["mode"] == "live" and summary["recon"]["frames_processed"] > 20 and not summary["log_loss"]
    assert len((out / "detections.jsonl").read_text().splitlines()) == summary["detections"] >= 1
    with MissionLogReader(out / "mission.mcap") as reader:
        assert reader.complete  # the last chunk and the summary were written
        assert sum(1 for _ in reader.messages(channels=["sonar"])) >= summary["recon"]["frames"]
