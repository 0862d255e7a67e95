"""Faults during a live run on virtual ports: a serial port closed and reopened, garbage in a serial
stream, a sonar socket that stalls. Each is reported (events in the summary and in the log), the run
carries on, the log keeps what came before, and the replay of the log still gives the live detections."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from live_helpers import TRUTH_NE, sim_process, sim_summary, start, threads, vehicle_config

from auvlink.pipeline.live import LiveRun
from auvlink.pipeline.process import run_log
from auvlink.pipeline.results import MissionResult
from auvlink.sim.faults import Fault, Injector
from logs_format import MissionLogReader
from logs_format.info import log_info

GARBAGE = np.random.default_rng(3).integers(0, 256, 400, dtype=np.uint8).tobytes()
FAULTS = (
    Fault("dvl", at_s=3.0, kind="close", duration_s=1.5),  # the DVL's serial port goes and comes back
    Fault("gyro", at_s=6.0, kind="garbage", data=GARBAGE),  # 400 random bytes inside the gyro stream
    Fault("sonar", at_s=10.5, kind="stall", duration_s=1.5),  # the sonar socket holds 15 frames, then bursts
)

pytestmark = [pytest.mark.live, pytest.mark.slow]


def injector() -> Injector:
    """The simulator's port hook (``tests/sim_serve.py`` makes it in the simulator's process)."""
    return Injector(FAULTS)


@pytest.fixture(scope="module")
def faulty_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, MissionResult]:
    tmp = tmp_path_factory.mktemp("faults")
    cfg = vehicle_config(tmp)
    out = tmp / "out"
    with threads() as pool:
        stop_live, ready = threading.Event(), threading.Event()
        live = LiveRun(cfg, out, stop=stop_live, ready=ready, backoff_max=0.2, sonar_queue=3)
        lt, lres, lerr = start(pool, live.run, stop_live, "live")
        assert ready.wait(30.0), lerr
        with sim_process(cfg, hook="test_live_faults:injector") as sim:  # the devices: another process
            sim_summary(sim, 40.0)
        stop_live.set()
        lt.join(30.0)
        assert not lerr and lres, lerr
    return out, lres[0]


def _events(out: Path, kind: str, device: str) -> list[dict[str, object]]:
    summary = json.loads((out / "summary.json").read_text())
    return [e for e in summary["events"] if e["kind"] == kind and e["device"] == device]


def test_a_serial_port_closed_mid_mission_is_reopened_and_the_log_marks_the_gap(
        faulty_run: tuple[Path, MissionResult]) -> None:
    out, result = faulty_run
    lost, back = _events(out, "port_lost", "dvl"), _events(out, "port_reopened", "dvl")
    assert lost and back and "dvl" in str(lost[0]["error"])
    # (the summary folds repeated events: an entry's first and its last; a first reopening can be the wait for
    # the simulator's ports at start-up, the last is the fault's)
    gap = float(back[-1].get("last", back[-1])["gap_s"])  # type: ignore
    assert 1.0 < gap < 3.0, back
    assert result.replay_stats["dvl"]["reopens"] >= 1
    log = out / "mission.mcap"
    with MissionLogReader(log) as reader:
        marks = [json.loads(m.data) for m in reader.messages(channels=["events"])]
        t_dvl = np.array([m.log_time_ns for m in reader.messages(channels=["dvl"])])
    assert any(m["kind"] == "port_lost" and m["device"] == "dvl" for m in marks)
    # DVL frames on both sides of the gap: nothing before it was lost
    t_lost = int(lost[0]["t_ns"])  # type: ignore[call-overload]
    assert (t_dvl < t_lost).sum() >= 5 and (t_dvl > t_lost + 1e9).sum() >= 5
    assert log_info(log)["channels"]["dvl"]["max_gap_s"] > 1.0  # `auvlink log info` shows it too


def test_garbage_in_a_serial_stream_is_counted_and_skipped(faulty_run: tuple[Path, MissionResult]) -> None:
    out, result = faulty_run
    gyro = result.replay_stats["gyro"]
    assert gyro["framer_dropped_bytes"] + gyro["decode_errors"] > 0, gyro
    # the port stayed up: lost only when the simulator closed every port at the end, like the pressure's
    assert gyro["samples"] > 1000
    assert len(_events(out, "port_lost", "gyro")) == len(_events(out, "port_lost", "pressure")) == 1


def test_a_stalled_sonar_socket_delays_then_bursts_and_the_run_carries_on(
        faulty_run: tuple[Path, MissionResult]) -> None:
    out, result = faulty_run
    dropped = _events(out, "frame_dropped", "sonar")
    # the burst of 15 frames overflows the 3-frame queue: whole frames dropped, counted, marked in the log
    n_dropped = sum(int(e["count"]) for e in dropped)  # type: ignore[call-overload]  # (folded into counts)
    assert result.drops.get("sonar", 0) == n_dropped >= 1
    frames = result.recon_stats["frames"] + n_dropped
    assert frames == result.replay_stats["sonar"]["samples"]  # nothing else lost
    silent, resumed = _events(out, "port_silent", "sonar"), _events(out, "port_resumed", "sonar")
    assert len(silent) == 1 and len(resumed) == 1 and 1.2 < float(resumed[0]["silent_s"]) < 3.0, resumed  # type: ignore[arg-type]
    assert not _events(out, "port_silent", "dvl")  # (the DVL's port was closed, not silent)
    assert log_info(out / "mission.mcap")["channels"]["sonar"]["max_gap_s"] > 1.2
    assert result.latency["frame_end_to_end"]["p50_ms"] < 200.0  # nobody waited for the stalled socket
    # the burst's frames kept (the queue's) are timed by their pings, not at their one arrival
    assert result.recon_stats["frames_timed_by_ping"] >= 1


def test_the_faulty_run_still_finds_the_objects_and_replays_to_the_same(
        faulty_run: tuple[Path, MissionResult]) -> None:
    out, live = faulty_run
    found = np.array([d.position_ned[:2] for d in live.detections]).reshape(-1, 2)
    assert len(found) == 2 and (np.linalg.norm(found - np.array(TRUTH_NE), axis=1) < 1.5).all(), found
    replay = run_log(out / "mission.mcap", progress=False)
    assert replay.drops == live.drops  # the frames live dropped are skipped, and said so
    assert [(d.id, d.class_name, d.n_points) for d in replay.detections] == \
        [(d.id, d.class_name, d.n_points) for d in live.detections]
    for a, b in zip(live.detections, replay.detections, strict=True):
        assert np.allclose(a.position_ned, b.position_ned, rtol=0, atol=1e-9)
    assert os.path.getsize(out / "detections.jsonl") > 0
