"""Simulated sensors: truth in noise-free mode, the documented noise, independent seeded streams, wire bytes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scenes import merge, obj, scene_toml

from auvlink.codecs import can_nav, didson, dsp1760, keller, paro, pd0, pd0_build
from auvlink.errors import ConfigError
from auvlink.sim.dvl import beam_directions
from auvlink.sim.emit import block_events, device_formats
from auvlink.sim.mission import Run, prepare
from auvlink.sim.noise import DvlNoise, NoiseConfig
from auvlink.sim.scene import loads_scene
from auvlink.sim.sensors import mean_body_rate, measure
from auvlink.sim.settings import SimSettings, loads_settings
from auvlink.sim.sonar_render import SonarRenderer
from recon.frames import bottom_track_to_vehicle, rdi_ship_to_body
from recon.nav import pressure_to_depth

# two short lines over a sphere on a 15 m seabed sloping 2 deg, across a current
TINY_SECTIONS = {"seabed": {"depth": 15.0, "slope_deg": 2.0, "slope_azimuth_deg": 45.0},
                 "objects": [obj("sphere", 8.0, 0.3)],
                 "survey": {"line_length": 12.0, "line_spacing": 3.0, "lines": 2, "altitude": 4.0},
                 "sonar": {"window_length": 8.0, "fps": 2.0}}
TINY = scene_toml(**TINY_SECTIONS, vehicle={"current": [0.1, 0.05]})
FLAT_LEVEL = scene_toml(**merge(TINY_SECTIONS, {"seabed": {"slope_deg": 0.0, "roughness": 0.0}}),
                        vehicle={"current": [0.1, 0.05], "roll_amplitude_deg": 0.0, "pitch_amplitude_deg": 0.0,
                                 "yaw_amplitude_deg": 0.0})
DECODE = {"pd0": pd0.decode, "dsp1760": dsp1760.decode, "paro": paro.decode, "keller": keller.decode,
          "can": can_nav.decode, "didson": didson.decode}


def _run(text: str = TINY, noise: bool | NoiseConfig | None = None, duration: float | None = None) -> Run:
    return prepare(loads_scene(text), duration=duration, noise=noise, settings=loads_settings(text))


def test_dvl_noise_free_is_the_inverse_of_recon_frames() -> None:
    run = _run(noise=False)
    d = run.measurements.dvl
    pose = run.trajectory.true_pose(d.t)
    lever = np.asarray(run.settings.sensors.dvl_lever_arm)
    v_true = pose.velocity_body + np.cross(pose.angular_rate_body, lever)
    # through the wire: PD0 keeps mm/s
    ens = [pd0.decode(pd0.encode(pd0_build.build(0, 0.0, bt_velocity_mps=row))) for row in d.bt_velocity]
    bt = np.array([e.bt_velocity_mps for e in ens])
    v = rdi_ship_to_body(bottom_track_to_vehicle(bt[:, :3]))
    np.testing.assert_allclose(v, v_true, atol=0.0005 + 1e-12)
    np.testing.assert_allclose(bt[:, 3], 0.0, atol=1e-12)
    assert d.valid.all()


def test_dvl_ranges_on_a_flat_seabed_flown_level() -> None:
    run = _run(FLAT_LEVEL, noise=False)
    d = run.measurements.dvl
    pose = run.trajectory.true_pose(d.t)
    on_line = pose.line >= 0
    # level flight over a flat seabed: every beam's vertical range is the transducer's altitude
    expected = pose.altitude - run.settings.sensors.dvl_lever_arm[2]
    np.testing.assert_allclose(d.range_m[on_line], np.repeat(expected[on_line, None], 4, axis=1), atol=1e-6)
    np.testing.assert_allclose(d.altitude[on_line], expected[on_line], atol=1e-6)


def test_beam_geometry_janus_20_degrees() -> None:
    b = beam_directions()
    np.testing.assert_allclose(np.linalg.norm(b, axis=1), 1.0)
    np.testing.assert_allclose(np.degrees(np.arccos(b[:, 2])), 20.0)
    assert b[0, 1] < 0 < b[1, 1] and b[2, 0] > 0 > b[3, 0]  # 1 port, 2 starboard, 3 forward, 4 aft


def test_dvl_noise_scale_and_dropouts() -> None:
    noise = NoiseConfig(dvl=DvlNoise(velocity_sigma=0.01, scale_error=0.002, dropout_probability=0.2))
    run = _run(noise=noise, duration=400.0)
    d = run.measurements.dvl
    pose = run.trajectory.true_pose(d.t)
    v_true = pose.velocity_body + np.cross(pose.angular_rate_body, np.asarray(run.settings.sensors.dvl_lever_arm))
    ok = d.valid
    assert 0.15 < 1 - ok.mean() < 0.25
    assert np.isnan(d.bt_velocity[~ok]).all() and np.isnan(d.range_m[~ok]).all()
    resid = d.velocity_body[ok] - 1.002 * v_true[ok]
    assert resid.std() == pytest.approx(0.01, rel=0.1)
    assert abs(resid.mean()) < 0.002
    # the scale error shows along the track: |v| is 1.002 x true on average
    ratio = np.linalg.norm(d.velocity_body[ok], axis=1).mean() / np.linalg.norm(v_true[ok], axis=1).mean()
    assert ratio == pytest.approx(1.002, abs=0.0015)


def test_gyro_rates_integrate_to_the_heading_change() -> None:
    run = _run(FLAT_LEVEL, noise=False)
    g = run.measurements.gyro
    pose = run.trajectory.true_pose(g.t)
    # each sample is the mean rate over (t_k - dt, t_k], as a FOG integrates it: away from the turn's
    # rate steps it is the rate at the interval's middle (to second order)
    dt = float(np.diff(g.t)[0])
    mid = run.trajectory.true_pose(g.t - 0.5 * dt).angular_rate_body
    smooth = np.abs(run.trajectory.true_pose(g.t - dt).angular_rate_body - pose.angular_rate_body).max(axis=1) < 1e-3
    assert (~smooth).sum() == 2  # the two intervals where the turn starts and ends
    np.testing.assert_allclose(g.rate[smooth], mid[smooth], atol=1e-6)
    # level flight: heading rate = r; the samples' sum is the heading change at every sample, exactly,
    # across the 180 deg turn between the two lines (where the rate steps)
    heading = np.concatenate([[0.0], np.cumsum(g.rate[1:, 2] * np.diff(g.t))])
    change = np.unwrap(pose.yaw) - pose.yaw[0]
    assert abs(change[-1]) > 3.0
    assert np.abs(heading - change).max() < 1e-9
    # point samples of the rate (what the simulator emitted before) miss up to rate x dt at each step
    point = np.concatenate([[0.0], np.cumsum(0.5 * (pose.angular_rate_body[1:, 2] + pose.angular_rate_body[:-1, 2])
                                             * np.diff(g.t))])
    steps = np.flatnonzero(np.abs(np.diff(pose.angular_rate_body[:, 2])) > 0.1)
    assert steps.size == 2 and abs(point[-1] - change[-1]) > 1e-5
    # accelerometers at rest in z: -g along body z when level
    assert np.all(np.abs(g.accel[:, 2] + 9.80665) < 1e-6)


@pytest.mark.slow
def test_gyro_noise_follows_the_datasheet_figures() -> None:
    run = _run(duration=600.0)
    g = run.measurements.gyro
    err = g.rate - mean_body_rate(run.trajectory, g.t, 1.0 / run.settings.sensors.gyro_hz)
    arw = math.radians(0.012) / 60.0 * math.sqrt(run.settings.sensors.gyro_hz)
    white = np.diff(err, axis=0) / math.sqrt(2.0)  # the slow bias cancels in differences
    assert white.std() == pytest.approx(arw, rel=0.05)
    bias = err.mean(axis=0)
    assert np.all(np.abs(bias) < 5 * math.radians(0.05) / 3600.0)


def test_pressure_gives_the_true_depth() -> None:
    run = _run(noise=False)
    p = run.measurements.pressure
    depth = pressure_to_depth(np.array([paro.decode(paro.encode(paro.build_reading(x))).pressure_pa
                                        for x in p.pressure_pa]))
    np.testing.assert_allclose(depth, p.depth_m, atol=1e-5)
    noisy = _run(duration=200.0).measurements.pressure
    sigma = noisy.pressure_pa - (101325.0 + 1025.0 * 9.80665 * noisy.depth_m)
    assert sigma.std() == pytest.approx(1e-4 * 2.0e6, rel=0.1)


def test_streams_are_independent_and_prefix_stable() -> None:
    scene = loads_scene(TINY)
    base = SimSettings()
    other = replace(base, noise=replace(base.noise, dvl=DvlNoise(velocity_sigma=0.05)))
    a, b = measure(scene, base, 10.0), measure(scene, other, 10.0)
    np.testing.assert_array_equal(a.gyro.rate, b.gyro.rate)
    np.testing.assert_array_equal(a.pressure.pressure_pa, b.pressure.pressure_pa)
    assert not np.array_equal(a.dvl.bt_velocity, b.dvl.bt_velocity)
    longer = measure(scene, base, 15.0)
    n = len(a.gyro.t)
    np.testing.assert_array_equal(longer.gyro.rate[:n], a.gyro.rate)
    np.testing.assert_array_equal(longer.dvl.bt_velocity[: len(a.dvl)], a.dvl.bt_velocity)


def test_settings_tables() -> None:
    s = loads_settings(TINY + '\n[sensors]\npressure = "keller"\ngyro_hz = 200\nstart = "2030-05-01T12:00:00Z"\n'
                       "[noise.dvl]\nvelocity_sigma = 0.01\n")
    assert s.sensors.pressure == "keller" and s.sensors.gyro_hz == 200.0
    assert s.sensors.start_ns == 1_903_867_200 * 10**9
    assert s.noise.enabled and s.noise.dvl.velocity_sigma == 0.01 and s.noise.dvl.scale_error == 0.001
    off = loads_settings("noise = false\n" + TINY)
    assert not off.noise.enabled and off.noise.dvl.dropout_probability == 0.0 and off.noise.gyro.arw == 0.0
    assert loads_settings(TINY + "[noise]\nenabled = false\n").noise == NoiseConfig.off()
    for bad, key in [("[sensors]\npressure = 'druck'\n", "sensors.pressure"),
                     ("[sensors]\ndvl_hz = 0\n", "sensors.dvl_hz"),
                     ("[noise.gyro]\narw = 1.0\n", "noise.gyro.arw"),
                     ("[noise.dvl]\ndropout_probability = 2.0\n", "noise.dvl.dropout_probability")]:
        with pytest.raises(ConfigError) as info:
            loads_settings(TINY + bad)
        assert info.value.key == key


@pytest.mark.parametrize("pressure", ["paro", "keller"])
def test_every_event_decodes_and_is_in_time_order(pressure: str) -> None:
    text = TINY + f'[sensors]\npressure = "{pressure}"\n'
    run = _run(text, duration=6.0)
    m = run.measurements
    events = block_events(m, 0.0, 3.0, SonarRenderer(run.scene)) + block_events(m, 3.0, 7.0,
                                                                                 SonarRenderer(run.scene))
    assert [e[:3] for e in events] == sorted(e[:3] for e in events)
    fmts = device_formats(m)
    seen = {e[3] for e in events}
    assert seen == {"dvl", "gyro", "pressure", "can", "sonar"}
    for _, _, _, device, raw, _ in events:
        assert DECODE[fmts[device]](raw) is not None
    names = {can_nav.decode(e[4]).name for e in events if e[3] == "can"}
    assert names == {"DVL_BT_VELOCITY", "DVL_ALTITUDE", "GYRO_RATE", "ATTITUDE", "PRESSURE", "DEPTH"}
    if pressure == "keller":
        recs = [keller.decode(e[4]) for e in events if e[3] == "pressure"]
        assert isinstance(recs[0], keller.KellerInitRequest) and isinstance(recs[1], keller.KellerInitResponse)
        readings = list(keller.iter_readings(recs))
        assert len(readings) == len(m.pressure.t)
        np.testing.assert_allclose([r.pressure_pa for r in readings], m.pressure.pressure_pa, rtol=1e-6)
