"""``auvlink batch --scheduler``: a Dask scheduler and a worker started here as their own processes
(``dask scheduler`` / ``dask worker``, on 127.0.0.1 with ports the system picks) run the missions; the
outputs are those of the embedded local cluster's run."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from batch_helpers import site_logs

from auvlink.cli import main

pytestmark = [pytest.mark.timeout(240), pytest.mark.dask, pytest.mark.slow]


def _start(args: list[str], log: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen([sys.executable, "-m", *args], stdout=log.open("wb"), stderr=subprocess.STDOUT)


def _wait_for(cond: object, what: str, procs: list[subprocess.Popen[bytes]], timeout: float = 90.0) -> None:
    t_end = time.monotonic() + timeout
    while not cond():  # type: ignore[operator]
        for p in procs:
            assert p.poll() is None, f"{what}: a dask process exited with {p.returncode}"
        assert time.monotonic() < t_end, f"{what}: not ready after {timeout} s"
        time.sleep(0.2)


def _stop(procs: list[subprocess.Popen[bytes]]) -> None:
    """Workers first, each gone before the scheduler is stopped (a worker whose scheduler is already going waits
    for it until its own timeout)."""
    for p in reversed(procs):
        p.terminate()
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


@pytest.fixture
def scheduler(tmp_path: Path) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """A ``dask scheduler`` process on 127.0.0.1 (a port the system picks, read from its scheduler file)."""
    info = tmp_path / "scheduler.json"
    procs = [_start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(info)], tmp_path / "scheduler.log")]
    try:
        _wait_for(lambda: info.is_file() and info.stat().st_size > 0, "scheduler", procs)
        address = json.loads(info.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        yield address, procs
    finally:
        _stop(procs)


@pytest.fixture
def cluster(scheduler: tuple[str, list[subprocess.Popen[bytes]]],
            tmp_path: Path) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """The scheduler and one ``dask worker`` process (one thread, no nanny: the process that runs tasks)."""
    address, procs = scheduler
    worker = _start(["distributed.cli.dask_worker", address, "--host", "127.0.0.1", "--nthreads", "1",
                     "--no-nanny", "--no-dashboard", "--name", "test-worker"], tmp_path / "worker.log")
    procs.append(worker)
    from distributed import Client

    with Client(address, timeout="30s") as client:
        _wait_for(lambda: len(client.scheduler_info()["workers"]) == 1, "worker", procs)
    yield address, worker


def test_batch_through_an_existing_scheduler(cluster: tuple[str, subprocess.Popen[bytes]],
                                              tmp_path_factory: pytest.TempPathFactory, tmp_path: Path) -> None:
    address, worker = cluster
    logs = site_logs(tmp_path_factory)[1:]
    out = tmp_path / "site"
    assert main(["batch", *map(str, logs), "--out", str(out), "--scheduler", address, "--quiet"]) == 0
    run = json.loads((out / "batch.json").read_text())
    assert run["cluster"] == f"scheduler {address}" and run["workers"] == 1
    assert [m["status"] for m in run["missions"]] == ["done", "done"]
    # the missions ran in the worker process started above, not in this one
    assert {m["worker"].rsplit(":", 1)[1] for m in run["missions"]} == {str(worker.pid)}
    for log in logs:
        dets = (out / log.stem / "detections.jsonl").read_text().splitlines()
        assert len(dets) >= 3 and json.loads((out / log.stem / "batch.json").read_text())["detections"] == len(dets)
    gj = json.loads((out / "catalogue.geojson").read_text())
    assert len(gj["missions"]) == 2 and {f["properties"]["status"] for f in gj["features"]} == {"stable", "missing"}


def test_unreachable_scheduler_is_one_line(tmp_path: Path, tmp_path_factory: pytest.TempPathFactory,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    import socket

    import dask

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    log = site_logs(tmp_path_factory)[0]
    with dask.config.set({"distributed.comm.timeouts.connect": "3s"}):
        assert main(["batch", str(log), "--out", str(tmp_path / "o"), "--scheduler", f"tcp://127.0.0.1:{port}"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("auvlink: error: --scheduler") and "cannot connect" in err and "\n" not in err


def test_scheduler_without_workers_is_one_line(scheduler: tuple[str, list[subprocess.Popen[bytes]]],
                                              tmp_path: Path, tmp_path_factory: pytest.TempPathFactory,
                                              monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    from auvlink.pipeline import batch

    monkeypatch.setattr(batch, "WAIT_WORKERS_S", 2.0)
    address, _ = scheduler
    log = site_logs(tmp_path_factory)[0]
    assert main(["batch", str(log), "--out", str(tmp_path / "o"), "--scheduler", address]) == 1
    err = capsys.readouterr().err.strip()
    assert err == (f"auvlink: error: --scheduler {address}: no worker connected within 2 s; start some "
                   f"(dask worker {address} --nthreads 1)")
