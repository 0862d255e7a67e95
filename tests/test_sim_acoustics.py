"""The simulator's acoustic profiles: the sonar model's own by default, ``ideal`` unchanged, the realistic model's
physics, real-frame statistics."""

from __future__ import annotations

import hashlib
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import ndimage, stats

from auvlink.errors import ConfigError
from auvlink.sim.acoustic_image import AcousticImager, speckle_table, spread_in_range, vertical_pattern
from auvlink.sim.acoustics import AcousticsTable, rendered_table, resolve
from auvlink.sim.azimuth_response import beam_mixing, spread_across_beams
from auvlink.sim.scene import Scene, default_scene_text, load_default_scene, loads_scene
from auvlink.sim.sonar_render import SonarRenderer, frame_rng

ARIS_SAMPLE = Path(__file__).resolve().parents[2] / "shared" / "data" / "aris" / "sample.aris"
#: sha256 of the default scene's frames at three survey poses (frame_rng(7, 0..2)) under the idealized model
#: (``profile = "ideal"``): the idealized model's frames stay these bytes
IDEAL_FRAMES_SHA256 = "60bcac8bc18afda871baa04d47f444baab4efcee0cfc9502c7f638cdfbaefcba"


def _flat(profile: str, **overrides: float | str) -> Scene:
    """The default scene without objects over a level smooth seabed, sonar at the body origin."""
    s = load_default_scene()
    table = AcousticsTable(profile=profile, **overrides)  # type: ignore[arg-type]
    return replace(s, objects=(), seabed=replace(s.seabed, slope_deg=0.0, roughness=0.0),
                   sonar=replace(s.sonar, lever_arm=(0.0, 0.0, 0.0)), acoustics=table)


def _level_pose(scene: Scene) -> np.ndarray:
    return np.array([0.0, 0.0, scene.seabed.depth - scene.survey.altitude])


def _survey_poses(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    from auvlink.sim.trajectory import LawnmowerTrajectory

    tr = LawnmowerTrajectory.from_scene(scene)
    pose = tr.true_pose(np.array([60.0, 87.5, 219.5]))  # seabed only, reef_a, reef_c in view
    return pose.position, pose.rotation().as_matrix()


def _digest(scene: Scene) -> str:
    rd = SonarRenderer(scene)
    pos, mats = _survey_poses(scene)
    h = hashlib.sha256()
    for i, (p, m) in enumerate(zip(pos, mats, strict=True)):
        h.update(rd.image(rd.trace_matrix(p, m), frame_rng(scene.seed, i)).tobytes())
    return h.hexdigest()


# --- the default: the sonar model's own profile; ideal: the idealized model, byte for byte ---------------------
def test_ideal_is_the_idealized_model_byte_for_byte() -> None:
    explicit = loads_scene(default_scene_text() + '\n[acoustics]\nprofile = "ideal"\n')
    assert _digest(explicit) == IDEAL_FRAMES_SHA256


@pytest.mark.parametrize("model", [None, "aris3000"])
def test_a_scene_without_the_table_renders_its_sonar_models_own_profile(model: str | None) -> None:
    """No ``[acoustics]`` table: the images of ``profile = <the model's own>`` (the DIDSON's when the scene names no
    model), not those of ``ideal``."""
    text = default_scene_text()
    if model is not None:
        text = text.replace("[sonar]\n", f'[sonar]\nmodel = "{model}"\n', 1)
    scene = loads_scene(text)
    assert scene.acoustics is None
    own = scene.sonar.description.acoustic_profile
    assert own == (model or "didson")
    default = _digest(scene)
    assert default == _digest(loads_scene(text + f'\n[acoustics]\nprofile = "{own}"\n'))
    assert default != _digest(loads_scene(text + '\n[acoustics]\nprofile = "ideal"\n'))
    # a table that names no profile is the model's own profile with its overrides
    table = loads_scene(text + "\n[acoustics]\nsidelobe_db = -22.0\n")
    assert _digest(table) == _digest(loads_scene(text + f'\n[acoustics]\nprofile = "{own}"\nsidelobe_db = -22.0\n'))
    assert SonarRenderer(table).acoustics == resolve(AcousticsTable(profile=own, sidelobe_db=-22.0))  # type: ignore[arg-type]


# --- the table: validation -------------------------------------------------------------------
@pytest.mark.parametrize(("table", "key"), [
    ('profile = "didson"\nsidelobe = -20.0', "acoustics.sidelobe"),
    ('profile = "didson"\nsidelobe_db = 3.0', "acoustics.sidelobe_db"),
    ('profile = "oculus"', "acoustics.profile"),
    ('profile = "aris1800"\nvertical_pattern = "cosine"', "acoustics.vertical_pattern"),
    ('profile = "ideal"\npulse_m = 0.02', "acoustics.pulse_m"),  # the ideal profile takes no overrides
    ('profile = "didson"\nelevation_samples = 4.5', "acoustics.elevation_samples"),
])
def test_errors_name_the_key(table: str, key: str) -> None:
    with pytest.raises(ConfigError) as err:
        loads_scene(default_scene_text() + f"\n[acoustics]\n{table}\n")
    assert err.value.key == key
    assert key in str(err.value)


def test_published_schema_holds_the_table() -> None:
    """docs/schemas/scene.schema.json takes a realistic table and refuses an unknown key, like the loader."""
    import json
    import tomllib

    import jsonschema

    schema = json.loads((Path(__file__).resolve().parents[1] / "docs" / "schemas" / "scene.schema.json").read_text())
    doc = tomllib.loads(default_scene_text() + '\n[acoustics]\nprofile = "aris3000"\nsidelobe_db = -22.0\n')
    jsonschema.validate(doc, schema)
    doc["acoustics"]["side_lobe_db"] = -22.0
    with pytest.raises(jsonschema.ValidationError, match="side_lobe_db"):
        jsonschema.validate(doc, schema)


def test_profiles_resolve_with_overrides() -> None:
    p = resolve(AcousticsTable(profile="aris3000", sidelobe_db=-18.0))
    assert p is not None and p.sidelobe_db == -18.0 and p.absorption_db_per_m == 2.6
    assert resolve(AcousticsTable(profile="ideal")) is None
    with pytest.raises(ValueError, match="names no profile"):
        resolve(AcousticsTable())  # a table without a profile: rendered_table gives the scene's
    sonar = load_default_scene().sonar
    assert rendered_table(None, sonar) == AcousticsTable(profile="didson")
    assert rendered_table(AcousticsTable(gain_db=2.0), replace(sonar, model="aris1800")) == \
        AcousticsTable(profile="aris1800", gain_db=2.0)
    ideal = AcousticsTable(profile="ideal")
    assert rendered_table(ideal, sonar) is ideal


# --- randomness ------------------------------------------------------------------------------
def test_same_seed_same_bytes_and_seeds_differ() -> None:
    scene = replace(load_default_scene(), acoustics=AcousticsTable(profile="didson", interference_fraction=0.5))
    assert _digest(scene) == _digest(scene)
    assert _digest(scene) != _digest(replace(scene, seed=scene.seed + 1))
    gains = {SonarRenderer(replace(scene, seed=s)).imager.gain_db for s in range(5)}  # type: ignore[union-attr]
    assert len(gains) == 5 and all(abs(g) <= 3.0 for g in gains)


# --- continuity in elevation ------------------------------------------------------------------
def _seabed_column(scene: Scene, k: int | None = None) -> np.ndarray:
    rd = SonarRenderer(scene, rays_per_beam=k, speckle=False)
    hits = rd.trace(_level_pose(scene), 0.0, 0.0, 0.0)
    if rd.imager is None:
        return rd.intensity(hits)[:, 48]
    diffuse = np.full(hits.range.size, rd.imager.mu)
    cos2 = np.where(np.isfinite(hits.range), hits.intensity * hits.range**2 / rd.seabed_gain, 0.0)
    surface = np.full(hits.range.size, -1, np.int32)
    return rd.imager.expected(hits.range, cos2, diffuse, surface)[:, 48]


@pytest.mark.parametrize("k", [16, 64])
def test_level_seabed_is_a_continuous_band(k: int) -> None:
    col = _seabed_column(_flat("didson"), k)
    band = np.flatnonzero(col > col.max() * 1e-3)
    inside = col[band[0]:band[-1] + 1]
    assert band.size > 100 and np.all(inside > 0.0)
    dip = inside[1:-1] / np.minimum(inside[:-2], inside[2:])
    assert dip.min() > 0.9  # no comb: no bin darker than both its neighbours
    ideal = _seabed_column(_flat("ideal"))  # the ideal model's comb, which this test must see as one
    ib = np.flatnonzero(ideal > 0)
    assert np.any(ideal[ib[0]:ib[-1] + 1] == 0.0)


def test_energy_beyond_the_edge_moves_the_onset_as_the_pattern_predicts() -> None:
    """A gaussian pattern alone (no sidelobes, no pulse): the seabed level along the centre beam is
    ``mu sin^2 g / cos g * B(g - tilt)``; its -20 dB onset is where that formula puts it."""
    scene = _flat("didson", sidelobe_db=-80.0, azimuth_width_beams=0.2, pulse_m=0.0, vertical_extent=4.0)
    col = _seabed_column(scene)
    rd = SonarRenderer(scene, speckle=False)
    g, h = rd.geometry, scene.survey.altitude
    r = g.range_of_bin
    graze = np.arcsin(np.clip(h / r, 0.0, 1.0))
    taper = np.cos(np.clip((np.abs(graze - g.tilt) / (g.spread / 2) - 0.7) / 0.3, 0, 1) * math.pi / 2) ** 2
    model = np.where(r > h, rd.imager.mu * np.sin(graze) ** 2 / np.cos(graze), 0.0)  # type: ignore[union-attr]
    model *= vertical_pattern("gaussian", math.radians(14.0), graze - g.tilt) * taper
    predicted = int(np.argmax(model > model.max() * 0.01))
    measured = int(np.argmax(col > col.max() * 0.01))
    assert abs(measured - predicted) <= 2
    hard_edge = g.bin_of_range(np.array([h / math.sin(g.tilt + math.radians(7.0))]))[0]
    assert hard_edge - measured > 20  # energy beyond the nominal edge: the band starts nearer
    # the level itself, in 16-bin means (the integral is piecewise constant between elevation samples)
    lo = predicted + 10
    n = (480 - lo) // 16 * 16
    assert np.allclose(col[lo:lo + n].reshape(-1, 16).mean(axis=1), model[lo:lo + n].reshape(-1, 16).mean(axis=1),
                       rtol=0.1)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1), objects=st.integers(0, 3))
def test_the_elevation_integral_keeps_every_sample_energy(seed: int, objects: int) -> None:
    """Samples inside the window, on the seabed or on objects, in any order of range, between misses:
    the image holds exactly their energy (segments spread it, edges keep it), whatever the layout."""
    im = _imager()
    g = im.g
    draw = np.random.default_rng(seed)
    r = g.window_start + draw.random(g.n_rays) * g.n_bins * g.bin_width
    r[draw.random(g.n_rays) < 0.2] = np.inf  # misses (sky, beyond the window) return nothing
    e = np.where(np.isfinite(r), draw.random(g.n_rays), 0.0)
    surface = draw.integers(-1, objects, g.n_rays).astype(np.int32) if objects else np.full(g.n_rays, -1, np.int32)
    img = im.integrate(r, e, surface)
    assert img.shape == (g.n_bins, g.n_beams) and np.all(img >= 0.0)
    assert img.sum() == pytest.approx(e.sum(), rel=1e-9)
    assert np.allclose(img.sum(axis=0), e.reshape(g.k, g.n_beams).sum(axis=0), rtol=1e-9)  # per beam


# --- azimuth pattern and pulse ----------------------------------------------------------------
@pytest.mark.parametrize("sidelobe_db", [-20.0, -25.0, -35.0])
def test_sidelobes_spread_a_point_across_the_fan(sidelobe_db: float) -> None:
    e = np.zeros((512, 96))
    e[200, 40] = 1.0
    out = spread_across_beams(e, beam_mixing(96, 1.0, sidelobe_db))
    level = 10.0 * np.log10(out[200])
    assert np.abs(level[[38, 42]] - sidelobe_db).max() <= 2.0  # the first sidelobes, two beams off
    offset = np.abs(np.arange(96) - 40)
    far = offset >= 2
    expected = sidelobe_db - 20.0 * np.log10(offset[far] / 2.0)  # the 1/k^2 envelope, across the fan
    assert np.abs(level[far] - expected).max() <= 2.0 and level[95] > sidelobe_db - 40.0
    assert out[200, 40] == 1.0 and out[200, 41] == pytest.approx(2.0 ** -4)  # -3 dB at half a beam
    assert np.all(out[:200] == 0.0) and np.all(out[201:] == 0.0)


@pytest.mark.parametrize("pulse_bins", [2.0, 3.5, 6.0])
def test_pulse_smears_a_point_over_its_length(pulse_bins: float) -> None:
    e = np.zeros((512, 4))
    e[100, 1] = 1.0
    out = spread_in_range(e, pulse_bins)
    lit = np.flatnonzero(out[:, 1] > 1e-12)
    assert lit[0] == 100  # the leading edge stays at the true range
    assert lit[-1] - lit[0] + 1 == math.ceil(pulse_bins)
    assert out[:, 1].sum() == pytest.approx(1.0)
    assert out[100, 1] == pytest.approx(1.0 / pulse_bins)


def test_a_point_echo_through_the_whole_model_takes_the_configured_pulse_and_sidelobes() -> None:
    """One sample returns (all others miss): the expected image holds it over ``pulse_m`` of range from
    its true range on its beam, and at ``sidelobe_db`` two beams off."""
    im = _imager(pulse_m=0.06, sidelobe_db=-22.0)
    g = im.g
    r = np.full(g.n_rays, np.inf)
    ray = 32 * g.n_beams + 50  # the centre elevation, beam 50
    r[ray] = g.range_of_bin[200]
    img = im.expected(r, np.full(g.n_rays, 1.0), np.full(g.n_rays, 1e-3), np.full(g.n_rays, -1, np.int32))
    lit = np.flatnonzero(img[:, 50] > img[:, 50].max() * 1e-6)
    assert lit[0] == 200 and lit[-1] == 200 + math.ceil(0.06 / g.bin_width) - 1
    assert 10.0 * np.log10(img[200, 52] / img[200, 50]) == pytest.approx(-22.0, abs=2.0)


# --- speckle, TVG error ------------------------------------------------------------------------
@pytest.mark.parametrize(("looks", "texture"), [(1.0, 0.0), (2.0, 0.0), (1.0, 2.0)])
def test_speckle_tables_have_unit_mean(looks: float, texture: float) -> None:
    table = speckle_table(looks, texture).astype(float)
    assert table.mean() == pytest.approx(1.0, abs=0.02)
    assert np.all(np.diff(table) >= 0.0)  # quantiles, ascending
    if looks == 1.0 and texture == 0.0:  # Rayleigh amplitude: exponential intensity
        q = (np.arange(65536) + 0.5) / 65536.0
        assert np.allclose(table, -np.log1p(-q), rtol=1e-5, atol=1e-9)


def test_k_texture_has_a_heavier_tail_than_rayleigh() -> None:
    assert speckle_table(1.0, 2.0)[-66] > 1.3 * speckle_table(1.0, 0.0)[-66]  # the 99.9th percentile


def test_tvg_error_tilts_the_level_along_range() -> None:
    im = _imager(tvg_error_db_per_m=-2.0)
    exact = _imager()
    n = im.g.n_rays
    r = np.where(np.arange(n) % 2 == 1, 9.0, 3.0)  # the centre elevation's rays: indices 32 * 96 + (0, 1)
    args = (r, np.full(n, 0.5), np.full(n, 1e-3), np.zeros(n, bool))
    ratio = (im.sample_energy(*args) / exact.sample_energy(*args))[32 * 96:32 * 96 + 2]
    assert 10.0 * np.log10(ratio[1] / ratio[0]) == pytest.approx(-12.0)



def test_a_positive_tvg_error_on_far_samples_stays_finite() -> None:
    """A ray grazing a distant seabed (1e5 m) under +2 dB/m: no overflow, a finite image (it was NaN grey)."""
    im = _imager(tvg_error_db_per_m=2.0)
    n = im.g.n_rays
    r = np.where(np.arange(n) % 2 == 1, 1e5, 5.0)
    with np.errstate(over="raise", invalid="raise"):
        energy = im.sample_energy(r, np.full(n, 0.5), np.full(n, 1e-3), np.zeros(n, bool))
    assert np.isfinite(energy).all()

# --- gain, interference -----------------------------------------------------------------------
def _imager(**overrides: float | str) -> AcousticImager:
    scene = _flat("didson", gain_jitter_db=0.0, **overrides)
    rd = SonarRenderer(scene)
    assert rd.imager is not None
    return rd.imager


def test_gain_offset_shifts_the_mean_by_its_db() -> None:
    energy = np.full((512, 96), 10.0 ** (-3.5))  # -35 dB: mid-display, never clipped
    a = _imager().display(energy, np.random.default_rng(5)).astype(float)
    b = _imager(gain_db=6.0).display(energy, np.random.default_rng(5)).astype(float)
    shift_db = (b.mean() - a.mean()) * 60.0 / 256.0
    assert shift_db == pytest.approx(6.0, abs=0.1)


def test_interference_in_its_fraction_of_frames() -> None:
    im = _imager(interference_fraction=0.2, interference_db=-10.0)
    energy = np.full((512, 96), 1e-6)
    n = 400
    hit = sum(int((np.median(im.display(energy, frame_rng(9, i)), axis=1) > 180).any()) for i in range(n))
    assert abs(hit / n - 0.2) < 3.0 * math.sqrt(0.2 * 0.8 / n)
    none = _imager(interference_fraction=0.0, interference_db=-10.0)
    assert not any((np.median(none.display(energy, frame_rng(9, i)), axis=1) > 180).any() for i in range(50))


# --- statistics against real ARIS frames ------------------------------------------------------
def frame_statistics(img: np.ndarray) -> dict[str, float]:
    """Speckle and range statistics of an 8-bit seabed image ``[range, beam]``: local grey-level std
    (median over 51 x 5 windows), skewness of the locally normalized grey levels, p95 - p5 of the
    grey levels, fraction of zeros."""
    x = img.astype(float)
    m = ndimage.uniform_filter(x, (51, 5))
    s = np.sqrt(np.maximum(ndimage.uniform_filter(x * x, (51, 5)) - m * m, 0.0))[30:-30, 3:-3]
    z = ((x - m)[30:-30, 3:-3] / np.maximum(s, 1e-9)).ravel()
    p5, p95 = np.percentile(x, [5, 95])
    return {"local_std": float(np.median(s)), "skew": float(stats.skew(z)), "p95_p5": float(p95 - p5),
            "zeros": float((x == 0).mean())}


#: tolerances against the ARIS sample (docs/ACOUSTICS.md): local grey std within 25 %, the skewness
#: negative (log-compressed speckle) and within 0.5, no zeros inside the seabed band
@pytest.mark.skipif(not ARIS_SAMPLE.exists(), reason="../shared/data/aris/sample.aris is not here")
@pytest.mark.parametrize("profile", ["didson", "aris1800", "aris3000"])
def test_speckle_statistics_match_the_aris_sample(profile: str) -> None:
    from auvlink.codecs.aris import read_file

    real = [frame_statistics(f.image) for f in read_file(ARIS_SAMPLE.read_bytes()).frames]
    ref = {k: float(np.mean([r[k] for r in real])) for k in real[0]}
    scene = _flat(profile)
    rd = SonarRenderer(scene)
    sim = frame_statistics(rd.render(_level_pose(scene), 0.0, 0.0, 0.0, frame_rng(1, 0))[320:])
    assert sim["local_std"] == pytest.approx(ref["local_std"], rel=0.25)
    assert sim["skew"] < 0.0 and abs(sim["skew"] - ref["skew"]) < 0.5
    assert sim["zeros"] == ref["zeros"] == 0.0
