"""The simulator flies an Oculus: pings through the real encoder into the log, read back by the pipeline's adaptor."""

from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from scenes import scene_toml

from auvlink.codecs import oculus
from auvlink.config import loads_config
from auvlink.errors import ConfigError
from auvlink.framing import oculus_defs
from auvlink.oculus_driver import OculusDriver
from auvlink.pipeline.nav_inputs import NavAdaptor, SonarPayload
from auvlink.pipeline.setup import MissionSetup, sonar_geometry
from auvlink.sim.device_server import LiveResult, serve
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.noise import SimError
from auvlink.sim.oculus_ping import ping_message, ping_rate_code
from auvlink.sim.scene import load_default_scene, loads_scene, with_sonar_model
from auvlink.sim.settings import SimSettings
from auvlink.sim.truth import vehicle_config
from auvlink.sim.vehicle_adapt import adapt
from auvlink.sonar import describe
from auvlink.virtual import free_tcp_port
from logs_format.fan import sonar_geometry as fan_geometry
from logs_format.replay import replay_samples

#: the small mission with an M750d (high mode); 5 m altitude, 30 deg tilt: the seabed from ~8 m, inside 6 + 4 m
SONAR = {"model": "oculus-m750d", "spread_deg": 12.0, "window_start": 6.0, "window_length": 4.0, "fps": 10.0}


def test_ping_message_round_trips_through_the_decoder() -> None:
    d = describe("oculus-m1200d", "high")
    image = np.random.default_rng(3).integers(0, 256, (300, d.n_beams), dtype=np.uint8)
    raw = ping_message(d, image, 3.0, ping_id=7, time_s=1.5, sound_speed=1480.0, fps=15.0,
                       attitude_rad=(0.1, -0.02, 0.03))
    ping = oculus.decode(raw)
    assert isinstance(ping, oculus.OculusPing)
    assert np.array_equal(ping.image, image) and ping.ping_id == 7 and ping.header.msg_version == 2
    assert np.allclose(np.degrees(ping.bearings_rad), d.bearings_deg, atol=1e-9)
    assert ping.range_resolution_m == pytest.approx(0.01) and ping.frequency_hz == 2.1e6
    assert ping.fire.range == 3.0 and ping.fire.master_mode == oculus_defs.FREQ_MODE_HIGH
    assert ping.fire.ping_rate == ping_rate_code(15.0) == 1 and ping.fire.flags & oculus_defs.FLAG_512_BEAMS
    assert ping.heading_deg == pytest.approx(np.degrees(0.1))
    with pytest.raises(ValueError, match="512"):
        ping_message(d, image[:, :256], 3.0, ping_id=0, time_s=0.0, sound_speed=1480.0, fps=10.0,
                     attitude_rad=(0.0, 0.0, 0.0))


def test_simulated_oculus_mission_reaches_recon(tmp_path: Path) -> None:
    """An Oculus scene's log holds SimplePingResults on the sonar channel; the pipeline's adaptor turns them into
    frames whose shape is the geometry the mission's stored configuration gives recon."""
    scene = loads_scene(scene_toml(sonar=SONAR))
    log = tmp_path / "oculus.mcap"
    simulate_to_log(scene, log, progress=False, duration=1.0, workers=1)
    samples = [s for s in replay_samples(log) if s.device == "sonar"]
    assert len(samples) == 10 and all(s.format == "oculus" for s in samples)
    ping = samples[0].record
    assert isinstance(ping, oculus.OculusPing)
    d = describe("oculus-m750d")
    assert ping.n_beams == 512 and ping.n_ranges == d.range_lines(10.0) == 4000  # from the transducer to 10 m
    assert ping.n_ranges * ping.range_resolution_m == pytest.approx(10.0)
    rows = ping.image.mean(axis=1)
    assert rows[3400:].mean() > rows[:3000].mean() + 1.0  # the seabed's returns past 8.5 m, water before 7.5 m
    payload = NavAdaptor().route(samples[0])
    assert payload is not None and isinstance(payload.payload, SonarPayload)
    frame = payload.payload
    setup = MissionSetup.from_config(vehicle_config(scene, SimSettings()))
    assert setup.sonar.description.model == "oculus-m750d"
    g = sonar_geometry(setup, frame.azimuths, frame.window)
    assert (g.n_bins, g.n_beams) == frame.image.shape == (4000, 512)


@pytest.mark.live
def test_live_oculus_pings_only_once_fired(tmp_path: Path) -> None:
    """``auvlink sim --live`` with an oculus device: a client that sends nothing gets nothing; the real driver,
    which sends SimpleFire on open, gets the simulated pings on the data port."""
    port = free_tcp_port()
    config = loads_config(f'[[devices]]\nname = "sonar"\nformat = "oculus"\nurl = "tcp://127.0.0.1:{port}"\n\n'
                          '[sonar]\ntilt_deg = 30.0\nspread_deg = 12.0\nwindow_start = 6.0\nwindow_length = 4.0\n'
                          'model = "oculus-m750d"\n')
    scene = loads_scene(scene_toml())  # a DIDSON scene: the vehicle's oculus model wins
    stop, ready = threading.Event(), threading.Event()
    result: list[LiveResult] = []
    server = threading.Thread(target=lambda: result.append(serve(scene, config, duration=4.0, stop=stop, ready=ready)))
    server.start()
    try:
        assert ready.wait(30.0)
        with socket.create_connection(("127.0.0.1", port), timeout=5.0) as silent:
            silent.settimeout(0.8)
            with pytest.raises(TimeoutError):
                silent.recv(1)  # not fired: the sonar stays silent
        pings: list[oculus.OculusPing] = []
        with OculusDriver("sonar", f"tcp://127.0.0.1:{port}").open() as driver:
            deadline = time.monotonic() + 10.0
            while len(pings) < 5 and time.monotonic() < deadline:
                pings += [s.record for s in driver.read(0.2) if isinstance(s.record, oculus.OculusPing)]
        assert len(pings) >= 5 and all(p.n_beams == 512 and p.n_ranges == 4000 for p in pings)
        assert np.allclose(np.degrees(pings[0].bearings_rad), describe("oculus-m750d").bearings_deg, atol=1e-9)
    finally:
        stop.set()
        server.join(30.0)
    sonar = result[0].ports[0]
    assert sonar.format == "oculus" and sonar.frames >= 5 and sonar.dropped >= 1  # held back before the fire


def test_oculus_device_needs_an_oculus_model() -> None:
    config = loads_config('[[devices]]\nname = "sonar"\nformat = "oculus"\nurl = "tcp://127.0.0.1:5999"\n')
    with pytest.raises(SimError, match="model"):
        adapt(loads_scene(scene_toml()), SimSettings(), config)


def test_a_sonar_device_speaks_its_models_format() -> None:
    """An ARIS model is served by an ``aris`` device, not a ``didson`` one (the error names the model)."""
    vehicle = '[sonar]\ntilt_deg = 30.0\nwindow_start = 1.0\nwindow_length = 10.0\nmodel = "aris1800"\n'
    device = '[[devices]]\nname = "sonar"\nformat = "{}"\nurl = "tcp://127.0.0.1:5999"\n\n'
    with pytest.raises(SimError, match="aris1800"):
        adapt(loads_scene(scene_toml()), SimSettings(), loads_config(device.format("didson") + vehicle))
    scene, _ = adapt(loads_scene(scene_toml()), SimSettings(), loads_config(device.format("aris") + vehicle))
    assert scene.sonar.model == "aris1800"


def test_report_fan_reads_an_oculus_ping() -> None:
    """The report's fan pictures (logs_format.fan) take an Oculus ping's ranges and bearing table."""
    d = describe("oculus-m750d", "low")
    image = np.zeros((200, d.n_beams), np.uint8)
    ping = oculus.decode(ping_message(d, image, 20.0, ping_id=1, time_s=0.0, sound_speed=1500.0, fps=10.0,
                                      attitude_rad=(0.0, 0.0, 0.0)))
    geom = fan_geometry(ping)
    assert geom is not None
    _, ranges, azimuths = geom
    assert ranges.shape == (200,) and ranges[-1] == pytest.approx(19.9)
    assert np.degrees(azimuths[[0, -1]]) == pytest.approx([-65.0, 65.0])


def test_demo_scene_flown_with_another_sonar() -> None:
    """``auvlink demo --sonar MODEL``'s scene: the model and its data-sheet vertical spread, the rest kept."""
    base = load_default_scene()
    scene = with_sonar_model(base, "oculus-m1200d")
    assert (scene.sonar.model, scene.sonar.spread_deg) == ("oculus-m1200d", 12.0)
    assert (scene.sonar.tilt_deg, scene.sonar.window_start, scene.objects) == (
        base.sonar.tilt_deg, base.sonar.window_start, base.objects)
    assert with_sonar_model(base, "aris3000").sonar.model == "aris3000"
    with pytest.raises(ConfigError, match="aris3000"):
        with_sonar_model(base, "sidescan")  # type: ignore[arg-type]
    demo = subprocess.run([sys.executable, "-m", "auvlink", "demo", "--sonar", "sidescan", "--out", "unused"],
                          capture_output=True, text=True, check=False)
    assert demo.returncode == 2 and "--sonar" in demo.stderr


def test_oculus_pings_reach_recon_pooled_to_its_sampling(tmp_path: Path) -> None:
    """Replayed, an M750d's 512 x 4000 pings are pooled to recon's sampling (recon.image_pooling) and every ping
    is reconstructed: none refused for its shape."""
    from auvlink.pipeline.process import run_log

    scene = loads_scene(scene_toml(sonar=SONAR))
    log = tmp_path / "oculus.mcap"
    simulate_to_log(scene, log, progress=False, duration=3.0, workers=1)
    result = run_log(log, progress=False)
    g = result.geometry
    assert g is not None and (g.n_bins, g.n_beams) == (500, 256)  # 4000 lines / 8, 512 beams / 2
    assert g.bin_size == pytest.approx(8 * 0.0025) and g.window_start == 0.0  # lines from the transducer on
    recon = result.recon_stats
    assert recon["frames_bad_shape"] == 0 and recon["frames_processed"] == 30, recon
