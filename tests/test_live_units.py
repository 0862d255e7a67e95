"""Units of the live loop: the bounded sonar queue drops whole frames and says so; a supervised port
is reopened with exponential backoff and publishes a watermark that never goes back."""

from __future__ import annotations

import itertools
import threading
import time
from pathlib import Path

import pytest
from live_helpers import vehicle_config

from auvlink.driver import Driver
from auvlink.errors import TransportOperationError
from auvlink.pipeline.live import LiveRun
from auvlink.pipeline.ports import PortReader
from auvlink.records import Sample
from auvlink.transports.base import Transport

pytestmark = pytest.mark.live


def test_a_full_sonar_queue_drops_whole_frames_and_counts_them(tmp_path: Path) -> None:
    live = LiveRun(vehicle_config(tmp_path), tmp_path / "out", sonar_queue=2)
    frames = [Sample("sonar", "didson", 1000 + min(i, 1), b"", None) for i in range(5)]  # 4 read together
    for s in frames:
        live._deliver(s)
    for i in range(50):  # navigation samples have their own, large queue
        live._deliver(Sample("gyro", "dsp1760", 2000 + i, b"", None))
    assert live.sonar_q.qsize() == 2 and live.nav_q.qsize() == 50
    assert live.drops == {"sonar": 3}
    dropped = [e for e in live.events if e["kind"] == "frame_dropped"]
    # the frames read together share a receive time: their ordinal in the device's stream tells them apart
    # (the summary folds the drops into one counted entry: the first and the last; the log gets each one)
    assert [(e["frame_t_ns"], e["sample_index"], e["count"], e["last"]) for e in dropped] == [
        (1001, 2, 3, {"frame_t_ns": 1001, "sample_index": 4})]
    assert [live.sonar_q.get_nowait().t_host_ns for _ in range(2)] == [1000, 1001]  # the oldest kept, whole


def test_replay_skips_exactly_the_frames_live_dropped_among_frames_read_together(tmp_path: Path) -> None:
    from auvlink.codecs import dsp1760
    from auvlink.config import load_config
    from auvlink.pipeline.ports import EVENT_SCHEMA, EVENT_SCHEMA_NAME, EVENT_TOPIC
    from auvlink.pipeline.process import run_log
    from logs_format.writer import MissionLogWriter

    log = tmp_path / "burst.mcap"
    t0 = 1_000_000_000
    with MissionLogWriter(log) as w:
        w.add_vehicle_config(load_config(vehicle_config(tmp_path)))
        for i in range(6):  # 6 gyro frames, the last 4 received in one read (one time)
            raw = dsp1760.encode(dsp1760.build((0.0, 0.0, 0.01), (0.0, 0.0, 9.8), sequence=i))
            w("gyro", "dsp1760", t0 + min(i, 2) * 1000, raw)
        for k in (3, 5):  # live dropped the 4th and the 6th: same receive time as the 3rd and 5th it kept
            w.add_json(EVENT_TOPIC, EVENT_SCHEMA_NAME, EVENT_SCHEMA, t0 + 5000,
                       {"t_ns": t0 + 5000, "device": "gyro", "kind": "frame_dropped", "frame_t_ns": t0 + 2000,
                        "sample_index": k})
    result = run_log(log, classify=False, progress=False)
    assert result.drops == {"gyro": 2}  # not 4: the time alone would skip the kept frames of that read too
    assert result.recon_stats["nav_samples"]["gyro"] == 4


class Flaky(Transport):
    """Delivers one PD6 line per read; the port 'goes' on reads 3 and 4 opens fail twice."""

    schemes = ("flaky",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.reads = 0
        self.opens = 0

    def _open(self) -> None:
        self.opens += 1
        if 2 <= self.opens <= 3:
            raise OSError("no such device")

    def _close(self) -> None:
        pass

    def _read(self, timeout: float | None) -> bytes:
        self.reads += 1
        if self.reads == 3:
            raise TransportOperationError(f"{self.url}: device gone")
        time.sleep(0.01)
        return b":BS,   +100,   -20,   +5,A\r\n"

    def _write(self, data: bytes) -> None:
        pass


def test_a_lost_port_is_reopened_with_backoff_and_the_watermark_moves_on() -> None:
    stop = threading.Event()
    got: list[Sample] = []
    events: list[dict[str, object]] = []
    drv = Driver("dvl", "pd6", Flaky("flaky://dvl"))
    reader = PortReader(drv, got.append, stop, on_event=events.append, backoff_initial=0.05, backoff_max=0.1)
    marks: list[int] = []
    reader.start()
    try:
        t_end = time.monotonic() + 5.0
        while time.monotonic() < t_end and reader.reopens < 1:
            marks.append(reader.watermark_ns)
            time.sleep(0.005)
        time.sleep(0.1)
    finally:
        stop.set()
        reader.join(5.0)
    assert not reader.thread.is_alive()
    kinds = [e["kind"] for e in events]
    assert kinds[:2] == ["port_lost", "port_reopened"], kinds  # (failed reopenings are not repeated)
    gap = next(float(e["gap_s"]) for e in events if e["kind"] == "port_reopened")  # type: ignore[arg-type]
    assert 0.1 <= gap < 1.0  # two failed opens: 0.05 + 0.1 s of backoff at least
    assert reader.reopens == 1 and reader.failures == 1 and drv.transport.opens == 4  # type: ignore[attr-defined]
    assert len(got) >= 3 and all(s.record is not None for s in got)
    assert all(b >= a for a, b in itertools.pairwise(marks))  # never goes back
    assert reader.watermark_ns == 2**63 - 1  # a stopped reader holds nobody up


class SlowToOpen(Transport):
    """Fails its first open (the reader then waits its backoff), then takes 0.3 s to open (slcan's sleep)."""

    schemes = ("slow",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.opens = 0

    def _open(self) -> None:
        self.opens += 1
        if self.opens == 1:
            raise OSError("no such device")
        time.sleep(0.3)

    def _close(self) -> None:
        pass

    def _read(self, timeout: float | None) -> bytes:
        time.sleep(0.01)
        return b":BS,   +100,   -20,   +5,A\r\n"

    def _write(self, data: bytes) -> None:
        pass


def test_a_port_waiting_to_reopen_or_opening_holds_nobody_up() -> None:
    from auvlink.clock import now_ns

    stop = threading.Event()
    got: list[Sample] = []
    drv = Driver("dvl", "pd6", SlowToOpen("slow://dvl"))
    reader = PortReader(drv, got.append, stop, backoff_initial=0.3, backoff_max=0.3)
    lags: list[float] = []
    reader.start()
    try:
        t_end = time.monotonic() + 3.0
        while time.monotonic() < t_end and len(got) < 5:
            now = now_ns()
            lags.append((now - reader.holds_from(now)) * 1e-9)
            time.sleep(0.005)
    finally:
        stop.set()
        reader.join(5.0)
    assert drv.transport.opens == 2 and len(got) >= 5  # type: ignore[attr-defined]
    # 0.3 s of backoff, then 0.3 s inside open: a consumer was never held back by more than a read cycle
    assert len(lags) > 50 and max(lags) < 0.2, max(lags)
    assert all(s.t_host_ns >= got[0].t_host_ns for s in got)
