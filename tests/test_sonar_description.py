"""The one sonar description (auvlink.sonar): data sheets, configurations, frames' own headers, every stage."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from auvlink.codecs import aris, didson, oculus
from auvlink.codecs.sonar_frames import describe_frame
from auvlink.config import config_from_metadata, loads_config
from auvlink.errors import ConfigError
from auvlink.evaluation.draw import draw_survey, draw_surveys, survey_sonar
from auvlink.pipeline.coverage import DEFAULT_HALF_FOV, onset_directions
from auvlink.sim.scene import SIMULATED_MODELS, SonarConfig, loads_scene
from auvlink.sim.sonar_geometry import RayFan
from auvlink.sonar import (
    DATA_SHEETS,
    DEFAULT_SONAR,
    DIDSON,
    Sonar,
    SonarDescription,
    arcsine_bearings,
    describe,
    linear_bearings,
)
from recon.seabed_memory import PLANE_BEAM_SPACING_DEG, TEXTURE_BEAM_SPACING_DEG, beam_step
from recon.sonar_geometry import SonarGeometry

VEHICLE = '''[[devices]]
name = "sonar"
format = "oculus"
url = "tcp://127.0.0.1:52100"

[sonar]
tilt_deg = 20.0
window_start = 0.5
window_length = 20.0
'''


def test_didson_is_the_default_fan_of_every_stage() -> None:
    """96 beams over +-14.5 deg, 14 deg vertical, 512 samples: the values each stage wrote before, bit for bit."""
    assert (DIDSON.n_beams, DIDSON.half_fov_deg, DIDSON.field_of_view_deg) == (96, 14.5, 29.0)
    assert (DIDSON.vertical_aperture_deg, DIDSON.samples, DIDSON.acoustic_profile) == (14.0, 512, "didson")
    assert DEFAULT_SONAR.description == DIDSON and DIDSON.is_linear
    old_sim = np.radians(np.linspace(-14.5, 14.5, 96))
    assert np.array_equal(didson.AZIMUTHS_RAD, old_sim)
    fan = RayFan(SonarConfig(tilt_deg=30.0, window_start=1.0, window_length=10.0, fps=10.0))
    assert np.array_equal(fan.azimuth, old_sim) and (fan.n_beams, fan.n_bins) == (96, 512)
    old_recon = np.linspace(-np.deg2rad(29.0) / 2, np.deg2rad(29.0) / 2, 96)
    assert np.array_equal(SonarGeometry().azimuths, old_recon)
    assert np.array_equal(SonarGeometry.of(DEFAULT_SONAR).azimuths, old_recon)
    assert SonarGeometry.of(DEFAULT_SONAR) == SonarGeometry()
    assert DEFAULT_HALF_FOV == math.radians(14.5)


@pytest.mark.parametrize(("model", "mode", "beams", "field", "vertical", "freq"), [
    ("oculus-m750d", "high", 512, 70.0, 12.0, 1.2e6), ("oculus-m750d", "low", 512, 130.0, 20.0, 750e3),
    ("oculus-m1200d", "high", 512, 60.0, 12.0, 2.1e6), ("oculus-m1200d", "low", 512, 130.0, 20.0, 1.2e6),
    ("didson", "low", 48, 29.0, 14.0, 1.1e6), ("aris1800", "high", 96, 27.625, 14.0, 1.8e6),
    ("aris3000", "high", 128, 29.41, 14.0, 3.0e6),
])
def test_data_sheets(model: str, mode: str, beams: int, field: float, vertical: float, freq: float) -> None:
    d = describe(model, mode)
    assert (d.n_beams, d.vertical_aperture_deg, d.frequency_hz) == (beams, vertical, freq)
    assert d.field_of_view_deg == pytest.approx(field, abs=0.01)


def test_aris_bearings_are_the_sdk_tables() -> None:
    assert np.array_equal(np.radians(describe("aris1800").bearings_deg), aris.ping_mode_azimuths_rad(3))
    assert np.allclose(np.radians(describe("aris3000").bearings_deg), aris.ping_mode_azimuths_rad(9), atol=1e-15)


def test_unknown_model_names_the_known_ones() -> None:
    with pytest.raises(KeyError, match="oculus-m750d"):
        describe("oculus-m75")


def real_ping(shared_data: Path) -> oculus.OculusPing:
    ping = oculus.decode((shared_data / "oculus" / "one_ping_8bit.raw").read_bytes())
    assert isinstance(ping, oculus.OculusPing)
    return ping


def test_oculus_bearing_table_is_the_real_pings(shared_data: Path) -> None:
    """The real ping (M1200d, 2.1 MHz, 256 beams over +-30 deg) sends exactly the sine-law table."""
    ping = real_ping(shared_data)
    real = np.round(np.degrees(ping.bearings_rad) * 100).astype(int)
    ours = np.round(np.asarray(describe("oculus-m1200d", "high", n_beams=256).bearings_deg) * 100).astype(int)
    assert np.array_equal(ours, real)
    spacing = np.diff(real)
    assert spacing.min() == 22 and spacing.max() == 26  # uneven: wider apart at the edges of the field


def test_description_from_the_oculus_header(shared_data: Path) -> None:
    ping = real_ping(shared_data)
    d = describe_frame(ping)
    assert (d.model, d.frequency_mode, d.n_beams) == ("oculus-m1200d", "high", 256)
    assert d.range_resolution_m == pytest.approx(0.0028421889710794315)
    assert d.frequency_hz == pytest.approx(2098880.6, abs=0.1)
    assert d.bearings_deg[0] == pytest.approx(-30.0) and d.bearings_deg[-1] == pytest.approx(30.0)
    assert d.range_lines(ping.n_ranges * ping.range_resolution_m) == ping.n_ranges


def test_description_from_aris_and_didson_headers(shared_data: Path) -> None:
    frame = aris.read_file((shared_data / "aris" / "sample.aris").read_bytes()).frames[0]
    d = describe_frame(frame)
    assert d.model in ("aris1800", "aris3000") and d.n_beams == frame.beam_count
    assert np.allclose(np.radians(d.bearings_deg), frame.azimuths_rad)
    built = didson.build(np.zeros((512, 96), np.uint8), 1.0, 10.0)
    assert describe_frame(didson.decode(didson.encode(built))) == DIDSON


def test_vehicle_config_names_the_model() -> None:
    cfg = loads_config(VEHICLE + 'model = "oculus-m750d"\nfrequency_mode = "low"\n')
    assert cfg.sonar is not None
    d = cfg.sonar.description
    assert (d.model, d.n_beams, d.field_of_view_deg, d.vertical_aperture_deg) == ("oculus-m750d", 512, 130.0, 20.0)
    assert cfg.sonar.geometry().description == d  # the pipeline's copy keeps the model
    stored = config_from_metadata({"vehicle_config": cfg.to_dict()})  # a log's stored configuration
    assert stored.sonar is not None and stored.sonar.description == d


@pytest.mark.parametrize(("line", "key", "hint"), [
    ('model = "oculus-m75"\n', "sonar.model", "oculus-m1200d"),
    ('modle = "oculus-m750d"\n', "sonar.modle", "model"),
    ('frequency_mode = "mid"\n', "sonar.frequency_mode", "'high' or 'low'"),
])
def test_wrong_sonar_key_names_the_key_and_the_fix(line: str, key: str, hint: str) -> None:
    with pytest.raises(ConfigError) as err:
        loads_config(VEHICLE + line)
    assert f"'{key}'" in str(err.value) and hint in str(err.value)


def test_recon_geometry_of_an_oculus() -> None:
    sonar = Sonar(tilt_deg=20.0, window_start=0.5, window_length=10.0, model="oculus-m750d")
    g = SonarGeometry.of(sonar)
    assert (g.n_beams, g.n_bins) == (512, 4096)  # 0 to 10.5 m at 2.5 mm, capped at the image's 4096 lines
    assert (g.window_start, g.window_length) == (0.0, 10.5)  # an Oculus' range lines start at the transducer
    assert np.allclose(np.degrees(g.azimuths), sonar.description.bearings_deg)


beam_counts = st.integers(64, 1024)
half_fields = st.floats(5.0, 65.0)
laws = st.sampled_from([linear_bearings, arcsine_bearings])


@settings(max_examples=30, deadline=None)
@given(n=beam_counts, half=half_fields, law=laws, vertical=st.floats(10.0, 20.0))
def test_any_table_reaches_every_stage_alike(n: int, half: float, law: object, vertical: float) -> None:
    """Any beam count 64-1024, uneven or even, apertures up to 130 deg, vertical 10-20 deg: the simulator's rays
    and recon's beams have the same azimuths, column for column, and the coverage chord spans the field."""
    bearings = law(half, n)  # type: ignore[operator]
    d = SonarDescription(model="test", frequency_mode="high", frequency_hz=1e6, bearings_deg=bearings,
                         vertical_aperture_deg=vertical, beam_width_deg=0.5, max_range_m=30.0, samples=256)
    assert d.n_beams == n and d.half_fov_deg == pytest.approx(half, abs=0.01)
    config = SonarConfig(tilt_deg=25.0, spread_deg=vertical, window_start=1.0, window_length=10.0, fps=5.0)
    fan = RayFan(config, rays_per_beam=2, description=d)
    ray_azimuth = np.arctan2(fan.dir_s[:, 1], fan.dir_s[:, 0])[: fan.n_beams]
    g = SonarGeometry.of(config, azimuths=np.radians(bearings), n_bins=d.range_lines(10.0))
    assert (g.n_beams, g.n_bins) == (fan.n_beams, fan.n_bins) == (n, 256)
    assert np.allclose(ray_azimuth, g.azimuths, atol=1e-12)
    dirs_s = Rotation.from_euler("y", -config.tilt).inv().apply(
        onset_directions(config.tilt, config.spread, math.radians(d.half_fov_deg)))
    assert np.degrees(np.arctan2(dirs_s[[0, -1], 1], dirs_s[[0, -1], 0])) == pytest.approx(
        [-d.half_fov_deg, d.half_fov_deg])


@settings(max_examples=50, deadline=None)
@given(n=beam_counts, half=half_fields)
def test_sine_law_table_is_symmetric_and_wider_at_the_edges(n: int, half: float) -> None:
    b = np.asarray(arcsine_bearings(half, n))
    assert np.all(np.diff(b) > 0) and np.allclose(b, -b[::-1], atol=1e-9)
    step = np.diff(b)
    assert step[0] > step[n // 2 - 1]
    assert np.allclose(np.diff(np.sin(np.radians(b))), 2 * math.sin(math.radians(half)) / (n - 1))


def test_bad_tables_are_refused() -> None:
    good = describe("oculus-m750d")
    with pytest.raises(ValueError, match="strictly increasing"):
        SonarDescription(**{**good.__dict__, "bearings_deg": good.bearings_deg[::-1]})
    with pytest.raises(ValueError, match="beyond"):
        SonarDescription(**{**good.__dict__, "bearings_deg": linear_bearings(70.0, 64)})
    with pytest.raises(ValueError, match="beams"):
        SonarDescription(**{**good.__dict__, "bearings_deg": linear_bearings(30.0, 2000)})


def test_every_data_sheet_builds() -> None:
    for model, mode in DATA_SHEETS:
        d = describe(model, mode)
        assert d.model == model and d.range_lines(10.0) >= 512


@settings(max_examples=40, deadline=None)
@given(n=beam_counts, half=half_fields, law=laws)
def test_seabed_samples_per_degree_do_not_depend_on_the_beam_count(n: int, half: float, law: object) -> None:
    """Recon's seabed sampling strides (recon.seabed_memory.beam_step) keep samples about 1.2 / 0.6 deg apart for
    any fan; the DIDSON keeps its every 4th / every 2nd beam."""
    az = np.radians(law(half, n))  # type: ignore[operator]
    for spacing in (PLANE_BEAM_SPACING_DEG, TEXTURE_BEAM_SPACING_DEG):
        step = beam_step(az, spacing)
        assert step >= 1 and abs(step * 2 * half / (n - 1) - spacing) <= max(spacing / 2, 2 * half / (n - 1))
    didson_az = np.radians(DIDSON.bearings_deg)
    assert (beam_step(didson_az, PLANE_BEAM_SPACING_DEG), beam_step(didson_az, TEXTURE_BEAM_SPACING_DEG)) == (4, 2)


def test_random_surveys_draw_the_sonar_model_too() -> None:
    """``sonar="random"`` flies one simulated model per survey from its own stream: the survey's other factors are
    the DIDSON draw's; the swath and the scene follow the model's fan and vertical aperture (19 draws of seed 9100
    hold all five models)."""
    draws = [draw_survey(9100, i, sonar="random") for i in range(19)]
    assert {d.sonar for d in draws} == set(SIMULATED_MODELS)
    for i, d in enumerate(draws):
        base = draw_survey(9100, i)
        assert (d.depth, d.tilt_deg, d.speed, d.heading_deg) == (base.depth, base.tilt_deg, base.speed,
                                                                  base.heading_deg)
        scene = loads_scene(d.scene_toml())
        assert scene.sonar.description.model == d.sonar
        assert scene.sonar.spread_deg == describe(d.sonar).vertical_aperture_deg
        if d.sonar.startswith("oculus"):
            assert d.swath > base.swath  # 60-70 deg fans against the DIDSON's 29
        elif d.sonar.startswith("aris"):  # the DIDSON's vertical aperture, the SDK table's half field
            ratio = math.sin(math.radians(describe(d.sonar).half_fov_deg)) / math.sin(math.radians(14.5))
            assert d.swath == pytest.approx(base.swath * ratio, abs=2e-3)


def test_survey_sonar_names_the_models() -> None:
    assert {d.sonar for d in draw_surveys(3, 9100, small=True, sonar="oculus-m1200d")} == {"oculus-m1200d"}
    assert survey_sonar(1, 0, "aris3000") == "aris3000"
    with pytest.raises(ValueError, match="oculus-m750d"):
        survey_sonar(1, 0, "sidescan")
