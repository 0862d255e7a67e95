"""A flapping instrument (issue 34): a device that accepts a TCP connection and closes it at once.

Reconnects wait as :class:`auvlink.transports.backoff.Backoff` says (a bounded rate), and the port events
fold into counts (:class:`auvlink.pipeline.events.EventFolder`), so ``summary.json`` stays small. The live
tests use a real TCP server on 127.0.0.1 that accepts and closes every connection.
"""

from __future__ import annotations

import contextlib
import json
import random
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from auvlink.driver import Driver
from auvlink.pipeline.events import MAX_ENTRIES, EventFolder
from auvlink.pipeline.ports import PortReader
from auvlink.transports.backoff import Backoff
from auvlink.transports.tcp import TcpClientTransport

RUN_S = 3.0


def test_waits_double_to_the_cap_within_their_jitter_and_reset_only_after_a_stable_connection() -> None:
    b = Backoff(0.1, 5.0, rng=random.Random(7))
    steps = [0.1, 0.2, 0.4, 0.8, 1.6, 3.2, 5.0, 5.0, 5.0]
    for step in steps:
        wait = b.next_wait()
        assert step / 2 <= wait <= step
    b.connection_lasted(0.01)  # dropped at once: the step stays at the cap
    assert b.step_s == 5.0
    b.connection_lasted(5.0)
    assert b.step_s == 0.1
    waits = [Backoff(rng=random.Random(s)).next_wait() for s in range(200)]
    assert len({round(w, 6) for w in waits}) > 150  # jittered: devices that failed together spread out
    assert Backoff.most_attempts(0.1, 5.0, RUN_S) == 6  # 0.05 + 0.1 + 0.2 + 0.4 + 0.8 <= 3 < ... + 1.6


def test_repeated_events_fold_into_counts_and_distinct_ones_are_capped() -> None:
    folder = EventFolder()
    for i in range(20_000):
        folder.add({"t_ns": i, "device": "sonar", "kind": "port_lost", "error": "connection closed by the peer"})
        folder.add({"t_ns": i, "device": "sonar", "kind": "port_reopened", "gap_s": 0.1 * i})
    entries = folder.to_list()
    assert [(e["kind"], e["count"]) for e in entries] == [("port_lost", 20_000), ("port_reopened", 20_000)]
    assert entries[1]["t_ns"] == 0 and entries[1]["last_t_ns"] == 19_999 and entries[1]["last"]["gap_s"] > 1999
    folder.add({"t_ns": 1, "device": "sonar", "kind": "port_lost", "error": "another error"})  # another text
    assert len(folder.to_list()) == 3
    for i in range(10 * MAX_ENTRIES):
        folder.add({"t_ns": i, "device": f"d{i}", "kind": "port_silent", "silent_s": 1.0})
    entries = folder.to_list()
    assert len(entries) == MAX_ENTRIES + 1 and entries[-1]["kind"] == "events_dropped"
    assert entries[-1]["dropped"] == 10 * MAX_ENTRIES - (MAX_ENTRIES - 3)
    assert len(json.dumps(entries)) < 40_000
    assert [EventFolder.logs({"kind": "port_lost"}, n) for n in (1, 10, 11, 16, 17, 0)] == [
        True, True, False, True, False, False]
    assert EventFolder.logs({"kind": "frame_dropped"}, 12345)  # replay skips exactly the frames live dropped


@contextlib.contextmanager
def accept_and_close() -> Iterator[tuple[int, list[float]]]:
    """A TCP server on 127.0.0.1 that accepts every connection and closes it at once; yields its port and
    the monotonic times of the connections it accepted."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.05)
    accepted: list[float] = []
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            except OSError:
                return
            accepted.append(time.monotonic())
            conn.close()

    thread = threading.Thread(target=serve, name="accept-and-close")
    thread.start()
    try:
        yield server.getsockname()[1], accepted
    finally:
        stop.set()
        thread.join(5.0)
        server.close()


@pytest.mark.live
def test_a_port_reader_reconnects_at_a_bounded_rate_to_a_device_that_drops_every_connection() -> None:
    folder = EventFolder()

    def on_event(ev: dict[str, object]) -> None:
        folder.add(ev)

    with accept_and_close() as (port, accepted):
        stop = threading.Event()
        reader = PortReader(Driver("sonar", "didson", f"tcp://127.0.0.1:{port}"), lambda s: None, stop,
                            on_event=on_event)
        reader.start()
        time.sleep(RUN_S)
        stop.set()
        reader.join(10.0)
    assert not reader.thread.is_alive()
    bound = Backoff.most_attempts(0.1, 5.0, RUN_S) + 1  # (+1: the read racing the close)
    assert 3 <= len(accepted) <= bound, len(accepted)  # today's code: thousands
    kinds = {(e["kind"], e["count"]) for e in folder.to_list()}
    assert ("port_lost", reader.failures) in kinds and ("port_reopened", reader.reopens) in kinds, kinds


@pytest.mark.live
def test_a_tcp_client_with_reconnect_retries_at_a_bounded_rate() -> None:
    with accept_and_close() as (port, accepted):
        with TcpClientTransport(f"tcp://127.0.0.1:{port}?reconnect=1&timeout=1") as client:
            end = time.monotonic() + RUN_S
            while time.monotonic() < end:
                assert client.read(0.05) == b""
        reconnects = client.reconnects
    assert 2 <= len(accepted) <= Backoff.most_attempts(0.1, 5.0, RUN_S) + 1, len(accepted)
    assert reconnects == len(accepted) - 1


@pytest.mark.live
def test_a_live_run_on_a_flapping_device_keeps_summary_json_small(tmp_path: Path) -> None:
    from auvlink.pipeline.live import LiveRun
    from logs_format import MissionLogReader

    with accept_and_close() as (port, accepted):
        cfg = tmp_path / "vehicle.toml"
        cfg.write_text(f'[[devices]]\nname = "sonar"\nformat = "didson"\nurl = "tcp://127.0.0.1:{port}"\n')
        live = LiveRun(cfg, tmp_path / "out", duration=RUN_S, classify=False)
        live.run()
    summary_path = tmp_path / "out" / "summary.json"
    summary = json.loads(summary_path.read_text())
    assert summary_path.stat().st_size < 4_000, summary_path.stat().st_size  # today's code: MBs (was 7 MB in 5 s)
    assert len(accepted) <= Backoff.most_attempts(0.1, 5.0, RUN_S + 1.0) + 1, len(accepted)
    lost = [e for e in summary["events"] if e["kind"] == "port_lost"]
    assert len(lost) == 1 and lost[0]["count"] == summary["devices"]["sonar"]["port_failures"] >= 2
    with MissionLogReader(tmp_path / "out" / "mission.mcap") as reader:
        marks = [json.loads(m.data) for m in reader.messages(channels=["events"])]
    assert sum(m["kind"] == "port_lost" for m in marks) == lost[0]["count"]  # few: each one logged
