"""Sonar frames timed by their pings: a burst of frames delivered at once keeps the pings' spacing on the host
clock (:mod:`auvlink.pipeline.sensor_clock`), through the adaptor every pipeline path routes samples with."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from live_helpers import SCENE

from auvlink.pipeline.nav_inputs import CONSUMED_FORMATS, NavAdaptor
from auvlink.pipeline.sensor_clock import JUMP_S, WINDOW_S, SensorClock
from auvlink.records import Sample
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene
from logs_format import Replay

NS = 1_000_000_000
EPOCH = 1_767_225_600 * NS  # 2026-01-01


def _map(sensor_s: list[float], delay_s: list[float]) -> tuple[list[int], list[int]]:
    clock = SensorClock()
    receive = [EPOCH + round((s + d) * NS) for s, d in zip(sensor_s, delay_s, strict=True)]
    return receive, [clock.host_ns(r, EPOCH / NS + s) for r, s in zip(receive, sensor_s, strict=True)]


def test_a_burst_keeps_the_spacing_of_its_pings() -> None:
    """10 pings/s with a 5 ms link; pings 20-39 wait for a stall that ends at 4.2 s and arrive together."""
    sensor = [0.1 * k for k in range(60)]
    delay = [0.005] * 60
    for k in range(20, 40):
        delay[k] = 4.2 - sensor[k]
    receive, mapped = _map(sensor, delay)
    assert len({receive[k] for k in range(20, 40)}) == 1  # stamped by arrival: one instant
    np.testing.assert_allclose(np.diff(mapped) / NS, 0.1, atol=1e-6)  # by their pings: 0.1 s apart
    assert mapped[:20] == receive[:20]  # prompt frames keep their receive times


def test_the_least_delay_of_the_window_sets_the_offset() -> None:
    """Delays of 20-80 ms: every frame is timed 20 ms after its ping once a 20 ms frame has been seen, and the
    window forgets a least delay older than WINDOW_S of sensor time."""
    n = int(3 * WINDOW_S * 10)
    sensor = [0.1 * k for k in range(n)]
    rng = np.random.default_rng(3)
    delay = list(0.02 + 0.06 * rng.random(n))
    delay[5] = 0.001  # one frame that came faster than any after it
    receive, mapped = _map(sensor, delay)
    off = (np.array(mapped) - EPOCH) / NS - np.array(sensor)
    assert np.all(np.abs(off[5:int(WINDOW_S * 10)] - 0.001) < 1e-6)
    assert np.all(off[int(WINDOW_S * 10) + 10:] >= 0.02 - 1e-6)  # the 1 ms frame has left the window
    assert np.all(np.array(mapped) <= np.array(receive))


def test_a_clock_jump_starts_afresh_and_no_time_goes_back() -> None:
    clock = SensorClock()
    t = [clock.host_ns(EPOCH + k * NS // 10, 1000.0 + 0.1 * k) for k in range(10)]
    restarted = clock.host_ns(EPOCH + 11 * NS // 10, 3.0)  # the sonar restarted: its clock from power-up
    jumped = clock.host_ns(EPOCH + 12 * NS // 10, 3.1 + 2 * JUMP_S)  # its clock set forward
    assert clock.resets == 2
    assert restarted == EPOCH + 11 * NS // 10 and jumped == EPOCH + 12 * NS // 10
    assert t == sorted(t)


def test_a_frame_without_a_sensor_time_keeps_its_receive_time() -> None:
    clock = SensorClock()
    assert clock.host_ns(EPOCH, None) == EPOCH and clock.host_ns(EPOCH + 5, float("nan")) == EPOCH + 5


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(0.01, 0.5), st.floats(0.0, 3.0)), min_size=2, max_size=80))
def test_mapped_times_never_pass_receipt_nor_go_back(steps: list[tuple[float, float]]) -> None:
    """Any ping intervals and any transport delays (one stream: a frame never arrives before the one sent before
    it): a frame is never timed after its receipt, never before the frame before it, and never before its own ping
    plus the least delay of the frames so far."""
    sensor = np.cumsum([dt for dt, _ in steps])
    arrival = np.maximum.accumulate(sensor + np.array([d for _, d in steps]))
    delay = list(arrival - sensor)
    sensor = list(sensor)
    receive, mapped = _map(sensor, delay)
    assert all(m <= r for m, r in zip(mapped, receive, strict=True))
    assert mapped == sorted(mapped)
    least = np.minimum.accumulate(delay)
    floor = EPOCH + np.round((np.array(sensor) + least) * NS).astype(np.int64) - 1000  # float64 epoch s: ~0.2 us
    assert np.all(np.array(mapped, dtype=np.int64) >= floor)


@pytest.fixture(scope="module")
def sonar_samples(tmp_path_factory: pytest.TempPathFactory) -> list[Sample]:
    """The samples of a 3 s simulated mission's log (DIDSON frames stamped at their pings: receive = ping)."""
    path = tmp_path_factory.mktemp("sensor_clock") / "mission.mcap"
    simulate_to_log(loads_scene(SCENE), path, progress=False, duration=3.0, workers=1)
    with Replay(path, formats=CONSUMED_FORMATS) as rep:
        return list(rep.samples())


def test_the_adaptor_times_a_burst_of_real_frames_by_their_pings(sonar_samples: list[Sample]) -> None:
    """Real DIDSON frames whose receipt a stall bunched (the second half of them received with the last one) get
    the event times they had when they arrived one by one; the payload keeps each frame's receive time."""
    frames = [s for s in sonar_samples if s.format == "didson"]
    assert len(frames) >= 10
    half = len(frames) // 2
    late = frames[-1].t_host_ns
    bunched = frames[:half] + [Sample(s.device, s.format, late, s.raw, s.record, s.t_sensor) for s in frames[half:]]
    adaptor = NavAdaptor()
    burst = [adaptor.route(s) for s in bunched]
    times = np.array([e.t_ns - EPOCH for e in burst], dtype=np.int64)  # type: ignore[union-attr]
    np.testing.assert_allclose(times, [s.t_host_ns - EPOCH for s in frames], atol=1000)  # to float64's 0.2 us
    assert [e.payload.received_ns for e in burst] == [s.t_host_ns for s in bunched]  # type: ignore[union-attr]
    assert adaptor.sonar_clocks["sonar"].resets == 0


def test_an_oculus_v2_ping_is_timed_by_its_start_time() -> None:
    """An Oculus V2 ping carries its start time in s since power-up (not the epoch): the clock maps it alike."""
    from auvlink.codecs import oculus
    from auvlink.sim.oculus_ping import ping_message
    from auvlink.sonar import describe

    desc = describe("oculus-m750d", "low")
    image = np.zeros((64, desc.n_beams), np.uint8)
    adaptor = NavAdaptor()
    times = []
    for k in range(8):
        raw = ping_message(desc, image, 10.0, ping_id=k, time_s=100.0 + 0.1 * k, sound_speed=1500.0, fps=10.0,
                           attitude_rad=(0.0, 0.0, 0.0))
        rec = oculus.decode(raw)
        received = EPOCH + (k * NS // 10 if k < 4 else 8 * NS // 10)  # pings 4-7 stalled, received together
        ev = adaptor.route(Sample("sonar", "oculus", received, raw, rec, None))
        assert ev is not None
        times.append(ev.t_ns - EPOCH)
    np.testing.assert_allclose(np.diff(times) / NS, 0.1, atol=1e-6)
    assert times[:4] == [k * NS // 10 for k in range(4)]


def test_replay_of_a_log_gives_the_same_frame_times(sonar_samples: list[Sample]) -> None:
    """The simulator stamps a frame's receipt at its ping: every frame keeps its recorded time exactly."""
    adaptor = NavAdaptor()
    for s in sonar_samples:
        ev = adaptor.route(s)
        if ev is not None and ev.kind == "sonar":
            assert ev.t_ns == s.t_host_ns
