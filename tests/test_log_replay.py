"""Replay: the live framers and codecs again, deterministic, paced in real time, x N or fast; a
recording from virtual ports replays into the same decoded samples the live drivers produced."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import pytest

from auvlink import formats
from auvlink.codecs import dsp1760, pd0
from auvlink.driver import Driver
from auvlink.records import Sample
from auvlink.virtual import PtyPair
from logs_format import (
    LogMessage,
    MissionLogReader,
    MissionLogWriter,
    Replay,
    paced,
    replay_frames,
    replay_samples,
)

T0 = 1_700_000_000_000_000_000


def gyro(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-4 * i, -2e-4, 3e-5), (0.1, 0.0, -9.8), sequence=i))


def pd0_frames(shared_data: Path, n: int = 60) -> list[bytes]:
    framer = formats.get("pd0").framer()
    frames = framer.feed((shared_data / "rdi" / "RDI_withBT.000").read_bytes()[: 581 * n + 100])
    assert len(frames) >= n - 1
    return frames


def key(s: Sample) -> tuple[Any, ...]:
    fmt = formats.get(s.format)
    assert fmt.to_json is not None
    return (s.device, s.format, s.t_host_ns, s.raw, s.t_sensor, repr(fmt.to_json(s.record)))


def make_log(path: Path, seconds: float = 2.0, rate: float = 100.0) -> int:
    n = int(seconds * rate)
    with MissionLogWriter(path, chunk_size=2048, flush_interval=0) as log:
        for i in range(n):
            log("fog", "dsp1760", T0 + round(i * 1e9 / rate), gyro(i))
    return n


def test_replay_decodes_through_the_live_path(tmp_path: Path, shared_data: Path) -> None:
    """Real PD0 ensembles and gyro frames: replayed samples equal decoding the frames directly."""
    path = tmp_path / "m.mcap"
    ens = pd0_frames(shared_data)
    with MissionLogWriter(path, chunk_size=8192) as log:
        for i, raw in enumerate(ens):
            log("dvl", "pd0", T0 + i * 200_000_000, raw)
        for i in range(len(ens) * 40):
            log("fog", "dsp1760", T0 + i * 5_000_000 + 1, gyro(i))
    with Replay(path) as rep:
        samples = list(rep.samples())
        stats = rep.stats()
    assert [s.raw for s in samples if s.device == "dvl"] == ens
    pd0 = formats.get("pd0")
    assert pd0.to_json is not None
    direct = [pd0.to_json(pd0.decode(r)) for r in ens]
    assert [pd0.to_json(s.record) for s in samples if s.device == "dvl"] == direct
    assert all(s.t_sensor == pd0.sensor_time(pd0.decode(s.raw)) for s in samples if s.device == "dvl")
    fog = [s for s in samples if s.device == "fog"]
    assert [s.record.sequence for s in fog] == [i % 128 for i in range(len(fog))]
    assert [s.t_host_ns for s in samples] == sorted(s.t_host_ns for s in samples)
    assert stats["dvl"]["samples"] == len(ens) and stats["dvl"]["framer_frames"] == len(ens)
    assert stats["fog"]["decode_errors"] == 0


def test_replay_is_deterministic(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path, chunk_size=512, flush_interval=0) as log:
        for i in range(300):  # equal times across devices and chunks
            log(f"fog{i % 3}", "dsp1760", T0 + (i // 3) * 1_000_000, gyro(i))
        log("bad", "dsp1760", T0 + 5, b"\xfe\x81\xff\x55" + bytes(32))  # CRC wrong: decode error
    runs = [[key(s) for s in replay_samples(path)] for _ in range(3)]
    assert runs[0] == runs[1] == runs[2]
    assert len(runs[0]) == 300
    with Replay(path) as rep:
        list(rep.samples())
        assert rep.stats()["bad"]["samples"] == 0  # the framer rejects it before the codec


def test_replay_skips_unknown_formats_and_json(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path) as log:
        log("fog", "dsp1760", T0, gyro(0))
        log("weird", "no-such-format", T0 + 1, b"xyz")
        log.add_json("nav/pose", "t", {"type": "object"}, T0 + 2, {"a": 1})
    with Replay(path) as rep:
        assert [s.device for s in rep.samples()] == ["fog"]
        assert rep.skipped == {"weird": 1}
    assert [m.channel for m in replay_frames(path)] == ["fog", "weird", "nav/pose"]


def test_pacing_schedule_with_a_fake_clock() -> None:
    now = [100.0]
    sleeps: list[float] = []

    def sleep(dt: float) -> None:
        sleeps.append(dt)
        now[0] += dt

    msgs = [LogMessage("a", "dsp1760", T0 + k * 500_000_000, 0, 0, b"", 1) for k in range(5)]
    out = []
    for m in paced(msgs, speed=2.0, clock=lambda: now[0], sleep=sleep):
        out.append((m.log_time_ns, now[0]))
    assert [t for _, t in out] == pytest.approx([100.0, 100.25, 100.5, 100.75, 101.0])
    now[0] = 0.0
    sleeps.clear()
    assert len(list(paced(msgs, speed=None, clock=lambda: now[0], sleep=sleep))) == 5
    assert sleeps == []


@pytest.mark.parametrize("speed", [5.0, 20.0])
def test_pacing_x_n_in_real_time(tmp_path: Path, speed: float) -> None:
    path = tmp_path / "m.mcap"
    make_log(path, seconds=2.0, rate=50.0)  # spans 1.98 s of log time
    t0 = time.monotonic()
    n = sum(1 for _ in replay_samples(path, speed=speed))
    wall = time.monotonic() - t0
    assert n == 100
    expected = 1.98 / speed
    assert expected * 0.9 <= wall <= expected + 0.4


def test_fast_mode_is_fast(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    n = make_log(path, seconds=100.0, rate=100.0)
    t0 = time.monotonic()
    assert sum(1 for _ in replay_samples(path)) == n
    assert time.monotonic() - t0 < 10.0  # 100 s of log, >= 10x real time even on a loaded machine


def test_record_virtual_ports_then_replay_gives_the_live_samples(tmp_path: Path, shared_data: Path) -> None:
    """Two devices on pty pairs, read by drivers on their own threads, logged; the replayed samples
    equal the live ones (device, t_host_ns, raw bytes, sensor time and decoded record)."""
    path = tmp_path / "rec.mcap"
    ens = pd0_frames(shared_data, 40)
    gyro_frames = [gyro(i) for i in range(400)]
    live: list[Sample] = []
    lock = threading.Lock()
    stop = threading.Event()

    def keep(sample: Sample) -> None:
        with lock:
            live.append(sample)

    def pump(drv: Driver) -> None:
        while not stop.is_set():
            drv.read(timeout=0.05)

    with PtyPair() as dvl_port, PtyPair() as fog_port, MissionLogWriter(path, flush_interval=0.2) as log, \
            Driver("dvl", "pd0", dvl_port.device_path) as dvl, \
            Driver("fog", "dsp1760", fog_port.device_path) as fog:
        threads = []
        for drv in (dvl, fog):
            drv.add_raw_listener(log, sensor_time=True)
            drv.add_listener(keep)
            threads.append(threading.Thread(target=pump, args=(drv,)))
        for t in threads:
            t.start()
        try:
            for i, g in enumerate(gyro_frames):
                fog_port.write(g)
                if i % 10 == 0:
                    raw = ens[i // 10]
                    dvl_port.write(raw[:100])  # split across reads: the framer joins it
                    dvl_port.write(raw[100:])
                time.sleep(0.001)
            deadline = time.monotonic() + 5.0
            while len(live) < len(gyro_frames) + len(ens) and time.monotonic() < deadline:
                time.sleep(0.02)
        finally:
            stop.set()
            for t in threads:
                t.join()
    assert len(live) == len(gyro_frames) + len(ens)
    replayed = list(replay_samples(path))
    by_time = sorted(live, key=lambda s: (s.t_host_ns, s.device))
    assert sorted(map(key, replayed)) == sorted(map(key, by_time))
    assert [s.raw for s in replayed if s.device == "fog"] == gyro_frames
    assert [s.raw for s in replayed if s.device == "dvl"] == ens
    assert [s.t_host_ns for s in replayed] == sorted(s.t_host_ns for s in replayed)
    # publish_time is the sensor's clock where the format has one (PD0 ensemble RTC), else log time
    with MissionLogReader(path) as reader:
        msgs = list(reader.messages())
    ens_times = []
    for raw in ens:
        t_sensor = pd0.decode(raw).sensor_time
        assert t_sensor is not None
        ens_times.append(round(t_sensor * 1e9))
    assert [m.publish_time_ns for m in msgs if m.channel == "dvl"] == ens_times
    assert all(m.publish_time_ns == m.log_time_ns for m in msgs if m.channel == "fog")
