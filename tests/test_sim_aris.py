"""The simulator flies an ARIS 1800 or 3000: frames through the real encoder into the log and onto the live port,
decoded by the ARIS codec, reconstructed by the pipeline."""

from __future__ import annotations

import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scenes import obj, scene_toml
from scipy.spatial.transform import Rotation

from auvlink.codecs import aris
from auvlink.codecs.sonar_frames import describe_frame
from auvlink.config import config_from_metadata, loads_config
from auvlink.framing.aris import ArisFramer
from auvlink.sim.aris_frame import build_frame, sampled_window
from auvlink.sim.device_server import LiveResult, serve
from auvlink.sim.mission import prepare, simulate_to_log
from auvlink.sim.scene import loads_scene
from auvlink.sim.sonar_render import SonarRenderer
from auvlink.sonar import describe
from auvlink.virtual import free_tcp_port
from logs_format.reader import MissionLogReader
from logs_format.replay import replay_samples

MODES = [("aris1800", "high"), ("aris1800", "low"), ("aris3000", "high"), ("aris3000", "low")]
#: the small mission's sonar as an ARIS; 1 s (10 frames) of it
SONAR = {"tilt_deg": 30.0, "spread_deg": 14.0, "window_start": 1.0, "window_length": 10.0, "fps": 10.0}


@pytest.mark.parametrize(("model", "mode"), MODES)
def test_simulated_aris_log_round_trips_the_renderer(tmp_path: Path, model: str, mode: str) -> None:
    """Every sonar message of an ARIS scene's log decodes with the ARIS codec to the image the renderer drew, with
    the header facts of the model's description, the scene's window as an ARIS samples it, and the pose."""
    scene = loads_scene(scene_toml(sonar={**SONAR, "model": model, "frequency_mode": mode}))
    log = tmp_path / "aris.mcap"
    simulate_to_log(scene, log, progress=False, duration=1.0, workers=1)
    run = prepare(scene, duration=1.0)
    s, sensors = run.measurements.sonar, run.settings.sensors
    drawn = SonarRenderer(run.scene).render_sequence(s.position, Rotation.from_matrix(s.r_wb), run.scene.seed,
                                                     first_frame=0)
    samples = [x for x in replay_samples(log) if x.device == "sonar"]
    assert len(samples) == len(s.t) == 10 and all(x.format == "aris" for x in samples)
    d = describe(model, mode)
    c = sensors.sound_speed
    for k, (sample, image) in enumerate(zip(samples, drawn, strict=True)):
        frame = aris.decode(sample.raw)
        assert np.array_equal(frame.image, image) and image.any()  # column 0 port-most, row 0 at the window start
        assert frame.image.shape == (d.samples, d.n_beams) == (512, d.n_beams)
        assert np.allclose(np.degrees(frame.azimuths_rad), d.bearings_deg, atol=1e-9)
        said = describe_frame(frame)
        assert (said.model, said.frequency_mode, said.frequency_hz) == (model, mode, d.frequency_hz)
        assert frame.field("FrequencyHiLow") == (mode == "high") and not frame.large_lens
        assert frame.samples_reordered and frame.sound_speed == c and frame.frame_index == k
        # the window: what the scene asked, within the header's whole microseconds, and what the renderer drew
        assert abs(frame.window_start_m - 1.0) <= 0.5e-6 * c / 2 + 1e-12
        assert abs(frame.window_length_m - 10.0) <= 512 * 0.5e-6 * c / 2
        assert frame.window_start_m == pytest.approx(run.scene.sonar.window_start, abs=1e-9)
        assert frame.window_length_m == pytest.approx(run.scene.sonar.window_length, abs=1e-9)
        assert frame.time == pytest.approx(sensors.start_ns * 1e-9 + s.t[k], abs=1e-6)
        assert sample.t_sensor == pytest.approx(frame.time, abs=1e-6)
        for got, want in ((frame.heading, s.heading[k]), (frame.pitch, s.pitch[k]), (frame.roll, s.roll[k])):
            assert got == pytest.approx(float(want), abs=1e-6)
        assert aris.encode(frame) == sample.raw
    with MissionLogReader(log) as reader:  # the channel and the stored vehicle say aris: replay decodes ARIS
        channel = reader.channels["sonar"]
        config = config_from_metadata(reader.metadata(decode_json=True))
    assert (channel.metadata["format"], channel.message_encoding) == ("aris", aris.WIRE_FORMAT.encoding), channel
    sonar_device = next(dev for dev in config.devices if dev.name == "sonar")
    assert sonar_device.format == "aris" and config.sonar is not None
    assert (config.sonar.model, config.sonar.frequency_mode) == (model, mode)


@settings(max_examples=60, deadline=None)
@given(start=st.floats(0.0, 50.0), length=st.floats(0.5, 60.0), c=st.floats(1300.0, 1700.0))
def test_sampled_window_is_what_the_header_says(start: float, length: float, c: float) -> None:
    """The window an ARIS samples is within half a microsecond of the one asked, and a frame over it decodes to it
    exactly; a window the header cannot say is refused."""
    d = describe("aris1800", "low")
    w = sampled_window(start, length, 512, c)
    half_c = float(np.float32(c)) / 2.0
    assert abs(w[0] - start) <= 0.5e-6 * half_c + 1e-9
    assert abs(w[1] - length) <= 512 * 0.5e-6 * half_c + 1e-9
    frame = aris.decode(aris.encode(build_frame(d, np.zeros((512, 48), np.uint8), w, frame_index=0, time_s=0.0,
                                                sound_speed=c, fps=10.0, attitude_rad=(0.0, 0.0, 0.0),
                                                water_temperature_c=10.0)))
    assert (frame.window_start_m, frame.window_length_m) == pytest.approx(w, abs=1e-9)
    if abs(w[1] - length) > 1e-6:
        with pytest.raises(ValueError, match="aris_scene"):
            build_frame(d, np.zeros((512, 48), np.uint8), (w[0], length), frame_index=0, time_s=0.0, sound_speed=c,
                        fps=10.0, attitude_rad=(0.0, 0.0, 0.0), water_temperature_c=10.0)


#: two objects off the track (a port/starboard mirror would move them 2 m across)
OFF_TRACK = [obj("pipe", 16.0, 1.0, 60.0), obj("reef_c", 30.0, -1.0, 0.0)]


@pytest.mark.slow
def test_aris1800_mission_replays_to_its_objects(tmp_path: Path) -> None:
    """The small mission flown with an ARIS 1800: replayed from its log, the pipeline finds both objects near
    their true positions and nothing else."""
    from auvlink.pipeline.process import run_log

    scene = loads_scene(scene_toml(sonar={**SONAR, "model": "aris1800"}, objects=OFF_TRACK))
    log = tmp_path / "aris1800.mcap"
    simulate_to_log(scene, log, progress=False, workers=1)
    result = run_log(log, progress=False, classify=False)
    assert result.recon_stats["frames_bad_shape"] == 0 and result.recon_stats["frames_processed"] > 200
    g = result.geometry
    assert g is not None and g.n_beams == 96
    truth = np.array([o["position"] for o in OFF_TRACK])
    found = np.array([d.position_ned[:2] for d in result.detections]).reshape(-1, 2)
    assert len(found) == 2, found
    dist = np.linalg.norm(found[:, None] - truth[None], axis=2)
    assert (dist.min(axis=0) < 0.6).all(), dist


@pytest.mark.live
def test_live_aris_frames_on_the_sonar_port(tmp_path: Path) -> None:
    """``auvlink sim --live`` with an ``aris`` sonar device: ARIS 3000 frames on its TCP port, as the DIDSON's."""
    port = free_tcp_port()
    config = loads_config(f'[[devices]]\nname = "sonar"\nformat = "aris"\nurl = "tcp://127.0.0.1:{port}"\n\n'
                          '[sonar]\ntilt_deg = 30.0\nspread_deg = 14.0\nwindow_start = 1.0\nwindow_length = 10.0\n'
                          'model = "aris3000"\n')
    scene = loads_scene(scene_toml())  # a DIDSON scene: the vehicle's ARIS wins
    stop, ready = threading.Event(), threading.Event()
    result: list[LiveResult] = []
    server = threading.Thread(target=lambda: result.append(serve(scene, config, duration=3.0, stop=stop, ready=ready)))
    server.start()
    frames: list[aris.ArisFrame] = []
    try:
        assert ready.wait(30.0)
        framer = ArisFramer()
        with socket.create_connection(("127.0.0.1", port), timeout=5.0) as client:
            client.settimeout(0.5)
            deadline = time.monotonic() + 10.0
            while len(frames) < 5 and time.monotonic() < deadline:
                try:
                    data = client.recv(1 << 16)
                except TimeoutError:
                    continue
                if not data:
                    break
                frames += [aris.decode(raw) for raw in framer.feed(data)]
    finally:
        stop.set()
        server.join(30.0)
    assert len(frames) >= 5 and framer.stats.dropped_bytes == 0
    d = describe("aris3000")
    c = 1500.0
    for frame in frames:
        assert frame.image.shape == (512, 128) and frame.system_type == 1 and frame.ping_mode == 9
        assert (frame.window_start_m, frame.window_length_m) == pytest.approx(sampled_window(1.0, 10.0, 512, c))
        assert np.allclose(np.degrees(frame.azimuths_rad), d.bearings_deg, atol=1e-9)
    assert [f.frame_index for f in frames] == list(range(frames[0].frame_index, frames[0].frame_index + len(frames)))
    assert all(f.heading is not None and f.pitch is not None for f in frames)  # the head's attitude is filled
    sonar = result[0].ports[0]
    assert sonar.format == "aris" and sonar.frames >= 5
