"""``auvlink batch`` trusts neither its inputs nor its own folder (issue 34).

Its own ``--out`` is never searched for missions (``batch D --out D/site`` twice: the same missions, a
catalogue that does not grow); a file that is not MCAP is refused after 8 bytes, before any checksum (a
sparse 4 GiB file); a mission past ``--mission-timeout`` is reported as timed out and the worker goes
on; a ``--scheduler`` that is no address (``''`` included) is one line before any work; a mission folder
whose outputs or record were edited, deleted or corrupted is processed again; ``batch.json`` says so
when a run fails. Real logs (:mod:`batch_helpers`, :mod:`small_mission`) and the real CLI.
"""

from __future__ import annotations

import json
import os
import socket
import sys
import threading
import time
from pathlib import Path

import pytest
from batch_helpers import site_logs
from small_mission import simulate_small

from auvlink.cli import main
from auvlink.errors import AuvlinkError
from auvlink.pipeline import batch_guard
from auvlink.pipeline.batch import discover_logs, settings_of
from auvlink.pipeline.batch_guard import FALLBACK_GRACE_S, MissionTimeout, check_scheduler_address, time_limit
from auvlink.pipeline.batch_mission import MissionTask, run_mission
from auvlink.pipeline.mission_deadline import check as check_deadline
from auvlink.pipeline.mission_deadline import deadline

pytestmark = pytest.mark.timeout(400)

GIB4 = 4 << 30  # bytes: the sparse non-MCAP file (reading it whole takes seconds; its first 8 bytes, none)


def _missions(out: Path) -> dict[str, dict[str, object]]:
    return {str(m["mission"]): m for m in json.loads((out / "batch.json").read_text())["missions"]}


def _task(log: Path, out: Path, timeout_s: float | None = None) -> MissionTask:
    return MissionTask(log.stem, str(log), str(out / log.stem), settings_of(None, False, False, None),
                       classify=False, report=False, timeout_s=timeout_s)


# -- without a cluster -----------------------------------------------------------------------------
def test_discovery_skips_the_batch_s_own_folder(tmp_path: Path) -> None:
    logs = tmp_path / "D"
    (logs / "site" / "m1").mkdir(parents=True)
    own = logs / "site" / "m1" / "results.mcap"  # an output of an earlier run
    own.write_bytes(b"x")
    mission = logs / "m1.mcap"
    mission.write_bytes(b"x")
    assert discover_logs([logs], exclude=logs / "site") == [mission]
    assert discover_logs([logs], exclude=tmp_path / "D" / ".." / "D" / "site") == [mission]
    with pytest.raises(AuvlinkError, match="outputs, not missions"):
        discover_logs([own], exclude=logs / "site")
    with pytest.raises(AuvlinkError, match=r"outside --out .*outputs, not missions"):
        discover_logs([logs / "site"], exclude=logs / "site")


def test_a_large_file_that_is_no_log_is_refused_before_its_checksum(tmp_path: Path) -> None:
    big = tmp_path / "big.mcap"
    with open(big, "wb") as f:
        f.truncate(GIB4)  # sparse: 4 GiB of zeros on no disk
    t0 = time.perf_counter()
    out = run_mission(_task(big, tmp_path / "site"))
    assert out.status == "failed" and "not an MCAP mission log" in out.error
    assert out.log_bytes == GIB4 and time.perf_counter() - t0 < 1.0, "refused on its first bytes, not hashed"
    assert not (tmp_path / "site").exists()


def test_a_block_stops_itself_at_its_next_check_after_the_limit() -> None:
    t0 = time.perf_counter()
    with pytest.raises(MissionTimeout), time_limit(0.2):
        while True:  # the replay loop's checks (auvlink.pipeline.mission_deadline)
            check_deadline()
            time.sleep(0.005)
    assert 0.19 < time.perf_counter() - t0 < 0.2 + FALLBACK_GRACE_S / 2, "stopped by its own check"
    check_deadline()  # no deadline left on this thread
    with time_limit(5.0), deadline(0.01):  # nested: the earlier one holds
        time.sleep(0.02)
        with pytest.raises(MissionTimeout):
            check_deadline()
    check_deadline()


def test_time_limit_stops_the_block_and_only_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(batch_guard, "FALLBACK_GRACE_S", 0.0)  # a block that never checks: the last resort
    t0 = time.perf_counter()
    with pytest.raises(MissionTimeout), time_limit(0.3):
        while True:  # a Python loop: interrupted at its next bytecode
            pass
    assert 0.25 < time.perf_counter() - t0 < 3.0
    with time_limit(5.0):
        sum(range(1000))
    time.sleep(0.1)  # nothing pending for this thread afterwards
    assert not [t for t in threading.enumerate() if t.name == "mission-time-limit"]


def test_time_limit_never_cuts_an_import_in_two(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(batch_guard, "FALLBACK_GRACE_S", 0.0)
    (tmp_path / "slow_import_t34.py").write_text("import time\ntime.sleep(0.6)\nWHOLE = True\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "slow_import_t34", raising=False)
    with pytest.raises(MissionTimeout), time_limit(0.1):
        import slow_import_t34  # noqa: F401 (the import the limit falls in)

        while True:
            pass
    assert sys.modules["slow_import_t34"].WHOLE  # imported whole; the limit struck after it
    monkeypatch.delitem(sys.modules, "slow_import_t34")


class _HeldStart(threading.Thread):
    """A thread whose start is held until ``gate`` opens: its parent waits inside ``Thread.start`` meanwhile."""

    def __init__(self, gate: threading.Event) -> None:
        super().__init__(target=lambda: None, daemon=True)
        self.gate = gate
        self.ran = False

    def _bootstrap(self) -> None:  # the new thread's first Python code
        self.gate.wait()
        self.ran = True
        super()._bootstrap()  # type: ignore[misc]


def test_time_limit_never_strikes_a_thread_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(batch_guard, "FALLBACK_GRACE_S", 0.0)
    gate = threading.Event()
    opened = threading.Timer(0.5, gate.set)
    child = _HeldStart(gate)
    t0 = time.perf_counter()
    opened.start()
    with pytest.raises(MissionTimeout), time_limit(0.05):
        child.start()  # held 0.5 s, ten times the limit: the exception waits for it (module doc)
        while True:
            pass
    assert time.perf_counter() - t0 >= 0.5 and child.ran
    child.join(5.0)
    assert not child.is_alive()


@pytest.mark.slow
def test_a_mission_past_its_limit_is_timed_out_and_the_worker_goes_on(tmp_path: Path) -> None:
    log = simulate_small(tmp_path / "small.mcap")
    t0 = time.perf_counter()
    # 20 ms: less than any replay of the mission takes, also in a process that has already imported
    # everything (a test worker that ran other replays replays this mission in well under a second)
    late = run_mission(_task(log, tmp_path / "site", timeout_s=0.02))
    assert late.status == "failed" and late.error.startswith("timed out after 0.02 s (--mission-timeout)")
    assert time.perf_counter() - t0 < 15 and not (tmp_path / "site" / "small").exists()
    done = run_mission(_task(log, tmp_path / "site", timeout_s=600))  # the same worker thread, the next mission
    assert done.status == "done" and done.detections, done.error
    assert (tmp_path / "site" / "small" / "detections.jsonl").is_file()


@pytest.mark.parametrize("address", ["", " ", "localhost:8786", "tcp://", "tcp://host", "tcp://host:port",
                                     "tcp://:8786", "tcp://host:0", "tcp://host:70000", "carrier-pigeon://h:1"])
def test_a_bad_scheduler_address_is_one_line_before_any_work(tmp_path: Path, address: str,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "m.mcap"
    log.write_bytes(b"x")
    capsys.readouterr()
    t0 = time.monotonic()
    assert main(["batch", str(log), "--out", str(tmp_path / "site"), "--scheduler", address]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"auvlink: error: --scheduler {address!r}"), err
    assert "tcp://host:8786" in err[0] and time.monotonic() - t0 < 5  # no cluster was started, no connect tried
    assert not (tmp_path / "site").exists()
    with pytest.raises(AuvlinkError):
        check_scheduler_address(address)
    assert check_scheduler_address("tcp://10.0.0.5:8786") == "tcp://10.0.0.5:8786"


def test_mission_timeout_must_be_positive(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "m.mcap"
    log.write_bytes(b"x")
    for bad in ("0", "-5", "nan"):
        assert main(["batch", str(log), "--out", str(tmp_path / "site"), "--mission-timeout", bad]) == 1
        assert "--mission-timeout must be > 0" in capsys.readouterr().err


@pytest.mark.dask
def test_a_failed_run_updates_batch_json(tmp_path: Path) -> None:
    import dask

    out = tmp_path / "site"
    out.mkdir()
    stale = {"format": "auvlink-batch/1", "missions": [{"mission": "last-week", "status": "done"}]}
    (out / "batch.json").write_text(json.dumps(stale))
    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    log = tmp_path / "m.mcap"
    log.write_bytes(b"x")  # never read: the run fails before any mission
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):
        assert main(["batch", str(log), "--out", str(out), "--scheduler", f"tcp://127.0.0.1:{port}", "--quiet"]) == 1
    run = json.loads((out / "batch.json").read_text())
    assert "cannot connect" in run["error"] and run["counts"] == {"failed": 1}
    assert [(m["mission"], m["status"], m["error"]) for m in run["missions"]] == [(log.stem, "failed", "not run")]
    assert not (out / ".auvlink.lock").exists()


# -- on a local cluster ----------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.dask
def test_batch_into_its_own_input_folder_twice_and_tampered_missions(
        tmp_path: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    logs = site_logs(tmp_path_factory)[:2]
    data = tmp_path / "D"
    data.mkdir()
    for p in logs:
        os.symlink(p, data / p.name)
    big = data / "huge.mcap"
    with open(big, "wb") as f:
        f.truncate(GIB4)
    out = data / "site"
    argv = ["batch", str(data), "--out", str(out), "--workers", "2", "--quiet", "--no-classify", "--no-report"]
    assert main(argv) == 1  # huge.mcap fails; the others complete
    first = _missions(out)
    assert {k: v["status"] for k, v in first.items()} == {**{p.stem: "done" for p in logs}, "huge": "failed"}
    assert "not an MCAP mission log" in str(first["huge"]["error"]) and float(str(first["huge"]["wall_s"])) < 2
    catalogue = json.loads((out / "catalogue.geojson").read_text())
    assert len(catalogue["missions"]) == 2

    assert main(argv) == 1  # again: its own results.mcap files are not missions
    second = _missions(out)
    assert second.keys() == first.keys() and [second[p.stem]["status"] for p in logs] == ["skipped"] * 2
    assert json.loads((out / "catalogue.geojson").read_text())["features"] == catalogue["features"]

    edited, recorded = (out / p.stem for p in logs)
    lines = (edited / "detections.jsonl").read_text().splitlines()
    (edited / "detections.jsonl").write_text("\n".join(lines[:-1]) + "\n")  # an object removed by hand
    (edited / "summary.json").unlink()
    rec = json.loads((recorded / "batch.json").read_text())
    (recorded / "batch.json").write_text(json.dumps({**rec, "detections": 99}))  # an edited record
    assert main(argv) == 1
    third = _missions(out)
    assert [third[p.stem]["status"] for p in logs] == ["done"] * 2, third  # processed again, not fatal
    assert (edited / "detections.jsonl").read_text().splitlines() == lines and (edited / "summary.json").is_file()
    assert json.loads((recorded / "batch.json").read_text())["detections"] == rec["detections"]
    (recorded / "batch.json").write_text("{not json")  # a corrupt record
    assert main(argv) == 1
    assert [_missions(out)[p.stem]["status"] for p in logs] == ["skipped", "done"]
    assert json.loads((out / "catalogue.geojson").read_text())["features"] == catalogue["features"]
