"""``auvlink sim --live`` on virtual ports (pty serial, slcan on a pty, TCP sonar) -> the live loop ->
the same detections as replaying the log it recorded; frames are not dropped and stay fast."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from live_helpers import (
    SCENE,
    TRUTH_NE,
    classes_against_truth,
    sim_process,
    sim_summary,
    start,
    threads,
    vehicle_config,
)

from auvlink.pipeline.live import LiveRun
from auvlink.pipeline.process import run_log
from auvlink.pipeline.results import MissionResult

pytestmark = [pytest.mark.live, pytest.mark.slow]


@pytest.fixture(scope="module")
def live_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, MissionResult]:
    tmp = tmp_path_factory.mktemp("live")
    cfg = vehicle_config(tmp)
    out = tmp / "out"
    with threads() as pool:
        stop_live, ready = threading.Event(), threading.Event()
        live = LiveRun(cfg, out, stop=stop_live, ready=ready, backoff_max=0.2)
        lt, lres, lerr = start(pool, live.run, stop_live, "live")
        assert ready.wait(30.0), lerr
        with sim_process(cfg) as sim:  # the vehicle's devices: another process, as on a vehicle
            sim_summary(sim, 40.0)
        stop_live.set()
        lt.join(30.0)
        assert not lerr and lres, lerr
    return out, lres[0]


def load_factor() -> float:
    """How many times over the machine is booked (1-minute load per core, at least 1)."""
    return max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))


def test_live_finds_the_objects_in_time(live_run: tuple[Path, MissionResult]) -> None:
    out, _ = live_run
    dets = [json.loads(line) for line in (out / "detections.jsonl").read_text().splitlines()]
    found = np.array([d["position_ned"][:2] for d in dets]).reshape(-1, 2)
    truth = np.array(TRUTH_NE)
    # dead reckoning starts where the vehicle is when the live run first hears it (up to ~1 m along the
    # line after the simulator's start): the objects' absolute positions within 1.5 m, relative within 0.5 m
    assert len(dets) == 2 and (np.linalg.norm(found - truth, axis=1) < 1.5).all(), dets
    assert np.linalg.norm((found[1] - found[0]) - (truth[1] - truth[0])) < 0.5, dets
    got, want = classes_against_truth(dets, SCENE)
    assert got == want, f"detected classes {got}, the simulator placed {want}"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["mode"] == "live" and summary["drops"] == {}
    lat = summary["latency"]["frame_end_to_end"]
    # the 200 ms goal holds on a machine that is not booked over its cores (CI, the live benchmark); a
    # shared machine at load 10 on 2 cores stretches every latency, so the limit scales with the load
    assert lat["count"] >= 100 and lat["p99_ms"] <= 200.0 * load_factor(), lat
    for stage in ("navigation", "reconstruction", "clustering", "classification"):
        assert summary["latency"][stage]["p50_ms"] is not None
    # live writes the viewer file too: every channel decodes with the schemas it carries
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    with open(out / "results.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        topics = [c.topic for _, c, _, _ in reader.iter_decoded_messages()]
    assert topics.count("/objects/detections") == 2 and topics.count("/sonar/fan") >= 10 and "/tf" in topics


def test_replaying_the_live_log_gives_the_live_detections(live_run: tuple[Path, MissionResult], tmp_path: Path) -> None:
    out, live = live_run
    replay = run_log(out / "mission.mcap", progress=False)
    assert replay.engine == live.engine and replay.engine["frame_block"] == 1
    assert replay.recon_stats["frames_processed"] == live.recon_stats["frames_processed"]
    a, b = live.detections, replay.detections
    # the same objects, classes, scores and points; coordinates equal to the last bits (numpy's einsum
    # sums with SIMD paths that depend on memory alignment, which differs between two processes states)
    assert [(d.id, d.class_name, d.n_points, d.t_first, d.t_last) for d in a] == \
        [(d.id, d.class_name, d.n_points, d.t_first, d.t_last) for d in b] and len(a) == 2
    # the viewer's sonar frames: the same frames kept, the same highlight returns marked
    assert [(f.t, f.returns) for f in live.fan_frames] == [(f.t, f.returns) for f in replay.fan_frames]
    for x, y in zip(a, b, strict=True):
        assert abs(x.score - y.score) < 1e-5
        assert np.allclose(x.position_ned, y.position_ned, rtol=0, atol=1e-9)
        assert np.allclose(x.points, y.points, rtol=0, atol=1e-9)
