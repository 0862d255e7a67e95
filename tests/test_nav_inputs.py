"""The one sample -> navigation adaptor: live, replay and the batch path route every sample through
:class:`NavAdaptor`, and the same bytes give the same navigation through live ports and through replay;
replay decodes only the channels a stage consumes (the CAN bus is counted, not decoded), while
``log info`` and export still decode everything they report."""

from __future__ import annotations

import dataclasses
import socket
import threading
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from live_helpers import SCENE, start, threads, vehicle_config

from auvlink import formats
from auvlink.config import load_config
from auvlink.pipeline.collect import MissionData
from auvlink.pipeline.live import LiveRun
from auvlink.pipeline.nav_inputs import CONSUMED_FORMATS, NavAdaptor, nav_inputs
from auvlink.pipeline.process import run_log
from auvlink.records import Sample
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene
from auvlink.virtual import PtyPair
from logs_format import MissionLogReader, Replay, export_log, log_info

CONSUMED_DEVICES = {"dvl", "gyro", "pressure", "sonar"}


@pytest.fixture(scope="module")
def mission(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Counter[str]]:
    """A 3 s simulated mission (DVL, gyro, Paro, CAN, sonar) and its frame count per device."""
    path = tmp_path_factory.mktemp("nav_inputs") / "mission.mcap"
    simulate_to_log(loads_scene(SCENE), path, progress=False, duration=3.0, workers=1)
    with MissionLogReader(path) as reader:
        counts = Counter(m.channel for m in reader.messages() if m.format is not None)
    assert set(counts) == CONSUMED_DEVICES | {"can"} and counts["can"] > 0
    return path, counts


@pytest.fixture
def can_decodes(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """Every call of the CAN codec's decode, counted."""
    calls: list[int] = []
    wire = formats.get("can")

    def decode(raw: bytes) -> Any:
        calls.append(1)
        return wire.decode(raw)

    monkeypatch.setitem(formats._LOADED, "can", dataclasses.replace(wire, decode=decode))
    yield calls


@pytest.fixture
def routed(monkeypatch: pytest.MonkeyPatch) -> list[tuple[int, str, str | None]]:
    """Every sample any :class:`NavAdaptor` routes: (adaptor id, device, event kind or None)."""
    calls: list[tuple[int, str, str | None]] = []
    route = NavAdaptor.route

    def spy(self: NavAdaptor, s: Sample) -> Any:
        ev = route(self, s)
        calls.append((id(self), s.device, None if ev is None else ev.kind))
        return ev

    monkeypatch.setattr(NavAdaptor, "route", spy)
    return calls


def _sample(device: str, fmt: str, record: Any, t_ns: int = 5_000_000_000) -> Sample:
    """The sample of ``record`` after a round trip through its wire format (encode, then decode)."""
    wire = formats.get(fmt)
    return Sample(device, fmt, t_ns, b"", wire.decode(wire.encode(record)))


def test_each_consumed_format_gives_its_event_in_si_units() -> None:
    from auvlink.codecs import dsp1760, dsp3000, keller, paro, pd0_build

    a = NavAdaptor()
    ens = pd0_build.build(1, 1.7e9, heading_rad=0.5, pitch_rad=0.01, roll_rad=-0.02, coordinate_system="earth",
                          bt_velocity_mps=(0.5, -0.25, 0.125, 0.0), bt_range_m=(5.0, 5.5, 6.0, 6.5))
    ev = a.route(_sample("dvl", "pd0", ens))
    assert ev is not None and ev.kind == "dvl" and ev.seq == 1
    assert ev.payload.velocity == (0.5, -0.25, 0.125) and ev.payload.valid and ev.payload.frame == "earth"
    assert ev.payload.altitude == pytest.approx(5.75) and ev.payload.heading == pytest.approx(0.5, abs=1e-3)
    two_ranges = pd0_build.build(2, 1.7e9, bt_velocity_mps=(0.5, 0.0, 0.0, 0.0),
                                 bt_range_m=(5.0, 5.0, float("nan"), float("nan")))
    ev = a.route(_sample("dvl", "pd0", two_ranges))
    assert ev is not None and np.isnan(ev.payload.altitude)  # fewer than 3 beams: no altitude
    assert a.route(_sample("dvl", "pd0", pd0_build.build(3, 1.7e9))) is None  # no bottom track: no event
    ev = a.route(_sample("fog", "dsp1760", dsp1760.build((0.0, 0.0, 0.02), (0.0, 0.0, 9.8), sequence=1)))
    assert ev is not None and ev.kind == "gyro" and ev.payload == pytest.approx((0.0, 0.0, 0.02), abs=1e-7)
    assert a.gyro_kind == "rate"
    ev = a.route(_sample("fog", "dsp3000_incremental", dsp3000.build(1e-4, mode="incremental")))
    assert ev is not None and ev.payload == pytest.approx((0.0, 0.0, 1e-4), rel=1e-4) and a.gyro_kind == "delta"
    ev = a.route(_sample("p", "paro", paro.build_reading(2.0e5)))
    assert ev is not None and ev.kind == "depth" and ev.payload == pytest.approx(2.0e5, rel=1e-6)
    assert a.route(_sample("p", "keller", keller.build_pressure_response(1, 3.0e5))) is None  # no request
    assert a.route(_sample("p", "keller", keller.KellerReadRequest(1, 1))) is None
    ev = a.route(_sample("p", "keller", keller.build_pressure_response(1, 3.0e5)))
    assert ev is not None and ev.kind == "depth" and ev.payload == pytest.approx(3.0e5, rel=1e-6)
    from auvlink.codecs import can_nav

    assert a.route(_sample("can", "can", can_nav.build(can_nav.message_names()[0]))) is None
    assert a.counts == {"dvl": 3, "fog": 2, "p": 4, "can": 1} and a.seq == 6


def test_navigation_takes_instrument_ship_or_earth_velocities_only() -> None:
    from auvlink.pipeline.nav_inputs import Event, velocity_frame
    from recon.errors import GeometryError

    assert [velocity_frame(f) for f in ("instrument", "ship", "earth")] == ["instrument", "ship", "earth"]
    a = NavAdaptor()
    ev = a.route(Sample("dvl", "pd0", 0, b"", _beam_ensemble()))
    assert isinstance(ev, Event)
    with pytest.raises(GeometryError, match=r"'beam' coordinates.*EX command"):
        a.nav_inputs([ev], 0)


def _beam_ensemble() -> Any:
    from auvlink.codecs import pd0_build

    wire = formats.get("pd0")
    return wire.decode(wire.encode(pd0_build.build(1, 1.7e9, coordinate_system="beam",
                                                   bt_velocity_mps=(0.1, 0.1, 0.1, 0.1), bt_range_m=(5.0,) * 4)))


def test_replay_decodes_only_the_consumed_channels(mission: tuple[Path, Counter[str]], can_decodes: list[int]
                                                   ) -> None:
    path, counts = mission
    with Replay(path, formats=CONSUMED_FORMATS) as rep:
        got = Counter(s.device for s in rep.samples())
        stats = rep.stats()
    assert got == Counter({d: counts[d] for d in CONSUMED_DEVICES})
    assert set(rep.decoders) == CONSUMED_DEVICES and rep.not_decoded == {"can": counts["can"]}
    assert stats["can"] == {"name": "can", "format": "can", "samples": 0, "decode_errors": 0,
                            "not_decoded": counts["can"]}
    assert all(stats[d]["samples"] == counts[d] and stats[d]["not_decoded"] == 0 for d in CONSUMED_DEVICES)
    assert can_decodes == []  # the CAN codec never ran
    with Replay(path) as rep:  # no consumer named: every channel is decoded
        assert Counter(s.device for s in rep.samples()) == counts
    assert len(can_decodes) == counts["can"]


def test_log_info_and_export_still_decode_everything(mission: tuple[Path, Counter[str]], can_decodes: list[int],
                                                     tmp_path: Path) -> None:
    path, counts = mission
    info = log_info(path)
    assert len(can_decodes) == counts["can"] and info["channels"]["can"]["decode_errors"] == 0
    result = export_log(path, tmp_path / "export", png=False)
    assert len(can_decodes) == 2 * counts["can"] and result.csv_rows["can"] == counts["can"]


def test_the_pipeline_replay_never_decodes_what_no_stage_consumes(
        mission: tuple[Path, Counter[str]], can_decodes: list[int], routed: list[tuple[int, str, str | None]]
) -> None:
    path, counts = mission
    result = run_log(path, classify=False, progress=False)
    assert can_decodes == [] and result.replay_stats["can"]["not_decoded"] == counts["can"]
    assert Counter(d for _, d, _ in routed) == Counter({d: counts[d] for d in CONSUMED_DEVICES})
    assert len({a for a, _, _ in routed}) == 1  # one engine, one adaptor


def test_batch_and_streaming_get_the_same_navigation_inputs(mission: tuple[Path, Counter[str]]) -> None:
    """The engine's per-block inputs, joined, are the batch path's whole-mission inputs (one adaptor, one
    conversion, not two copies)."""
    path, _ = mission
    data = MissionData()
    events = []
    adaptor = NavAdaptor()
    with Replay(path, formats=CONSUMED_FORMATS) as rep:
        for s in rep.samples():
            data.add(s)
            ev = adaptor.route(s)
            if ev is not None:
                events.append(ev)
    assert data.t0_ns == events[0].t_ns
    blocks = [nav_inputs(events[k : k + 97], data.t0_ns) for k in range(0, len(events), 97)]
    for kind, batch in zip(("dvl", "gyro", "depth"), data.nav_inputs(), strict=True):
        parts = [getattr(b, kind) for b in blocks if getattr(b, kind) is not None]
        for name in ("t", "velocity", "valid", "altitude", "heading", "pitch", "roll", "value", "pressure_pa"):
            if hasattr(batch, name):
                joined = np.concatenate([np.asarray(getattr(p, name)) for p in parts])
                np.testing.assert_array_equal(joined, np.asarray(getattr(batch, name)), err_msg=f"{kind}.{name}")
        assert data.n(kind) == sum(len(np.asarray(p.t)) for p in parts) > 0


def _wait(cond: Any, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.05)
    return cond()


@pytest.mark.live
def test_live_ports_and_replay_route_the_same_samples_through_the_adaptor(
        mission: tuple[Path, Counter[str]], routed: list[tuple[int, str, str | None]], tmp_path: Path) -> None:
    """The mission's bytes written on real ports (ptys, a TCP socket) to ``LiveRun``, and the mission
    replayed: the same samples reach the adaptor, the same events come out, the same navigation."""
    path, counts = mission
    cfg = vehicle_config(tmp_path)  # its CAN port is never served: live carries on without it
    sonar_port = int(next(d.url for d in load_config(cfg).devices if d.name == "sonar").rsplit(":", 1)[1])
    ports = {d: PtyPair(tmp_path / "ports" / d).open() for d in ("dvl", "gyro", "pressure")}
    server = socket.create_server(("127.0.0.1", sonar_port))
    live = LiveRun(cfg, tmp_path / "out", stop=threading.Event(), ready=threading.Event(), classify=False,
                   sonar_queue=10_000, backoff_max=0.2)
    try:
        with threads() as pool:
            lt, lres, lerr = start(pool, live.run, live.stop, "live")
            assert live.ready is not None and live.ready.wait(30.0), lerr
            server.settimeout(30.0)
            conn, _ = server.accept()
            with conn, MissionLogReader(path) as reader:
                time.sleep(0.3)  # the serial readers open their ports
                for msg in reader.messages():
                    if msg.channel == "sonar":
                        conn.sendall(msg.data)
                    elif msg.channel in ports:
                        ports[msg.channel].write(msg.data)
                want = {d: counts[d] for d in CONSUMED_DEVICES}
                assert _wait(lambda: {d: live._delivered.get(d, 0) for d in want} == want, 30.0), live._delivered
                live.stop.set()
                lt.join(30.0)
            assert not lerr and lres, lerr
    finally:
        server.close()
        for p in ports.values():
            p.close()
    live_calls = list(routed)
    routed.clear()
    replay = run_log(path, classify=False, progress=False)
    assert len({a for a, _, _ in live_calls}) == 1 and len({a for a, _, _ in routed}) == 1
    assert Counter((d, k) for _, d, k in live_calls) == Counter((d, k) for _, d, k in routed)
    assert lres[0].recon_stats["nav_samples"] == replay.recon_stats["nav_samples"]
    assert lres[0].recon_stats["frames"] == replay.recon_stats["frames"] == counts["sonar"]
