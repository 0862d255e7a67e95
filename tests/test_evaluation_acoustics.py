"""Acoustic conditions drawn with the random surveys (``auvlink eval --surveys N --acoustics SPACE``): the draws
cover the documented space, are reproducible, leave the survey draw of a seed unchanged, make valid scene tables
and become factor rows of the table and of ``surveys.json``; one small run end to end under ``random``."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.evaluation.acoustic_draw import (
    ACOUSTIC_BINS,
    ACOUSTIC_SPACE,
    PATTERNS,
    SONAR_PROFILES,
    acoustic_bin,
    by_acoustic_factor,
    draw_acoustics,
    models_of,
    profile_of,
)
from auvlink.evaluation.draw import draw_survey
from auvlink.evaluation.surveys import summarize
from auvlink.evaluation.tables import rows, text_table
from auvlink.sim.acoustics import PROFILE_VALUES, resolve
from auvlink.sim.scene import SIMULATED_MODELS, loads_scene

SCHEMA = Path(__file__).resolve().parents[1] / "docs" / "schemas" / "scene.schema.json"


def _random_draws(seed: int, n: int) -> list:
    """``n`` random draws, survey ``i`` flown with the ``i``-th simulated model in turn."""
    return [draw_acoustics("random", seed, i, 8.0, SIMULATED_MODELS[i % len(SIMULATED_MODELS)]) for i in range(n)]


def test_random_draws_cover_the_documented_ranges() -> None:
    draws = _random_draws(3, 400)
    for name, (lo, hi) in ACOUSTIC_SPACE.items():
        values = [getattr(a, name) for a in draws]
        assert all(lo - 1e-9 <= v <= hi + 1e-9 for v in values), name
        # 400 uniform draws reach within 3 % of the range of both ends
        assert min(values) < lo + 0.03 * (hi - lo) and max(values) > hi - 0.03 * (hi - lo), name
    assert {a.profile for a in draws} == set(SONAR_PROFILES)
    assert all(a.profile == profile_of(SIMULATED_MODELS[i % len(SIMULATED_MODELS)]) for i, a in enumerate(draws))
    assert {a.vertical_pattern for a in draws} == set(PATTERNS)
    # the sidelobe level and the gain offset span the ranges
    assert min(a.sidelobe_db for a in draws) < -34.0 and max(a.sidelobe_db for a in draws) > -16.0
    assert min(a.gain_db for a in draws) < -9.5 and max(a.gain_db for a in draws) > 9.5


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), index=st.integers(0, 500), window=st.floats(3.0, 30.0))
def test_a_draw_is_reproducible_and_its_pulse_is_1_to_4_bins(seed: int, index: int, window: float) -> None:
    a = draw_acoustics("random", seed, index, window)
    assert a == draw_acoustics("random", seed, index, window)
    assert a.pulse_m is not None and a.pulse_bins is not None
    assert 1.0 - 1e-3 <= a.pulse_m / (window / 512.0) <= 4.0 + 1e-3
    assert a.gain_jitter_db == 0.0  # the drawn gain offset is the survey's whole offset


def test_other_seeds_and_indices_draw_other_conditions() -> None:
    a = _random_draws(5, 6)
    assert len({x.sidelobe_db for x in a}) == 6
    assert a != _random_draws(6, 6)


@pytest.mark.parametrize("space", ["ideal", "random", "didson", "aris1800", "aris3000"])
def test_the_survey_draw_of_a_seed_is_the_one_of_the_code_before_acoustics(space: str) -> None:
    # values printed by draw_survey before the acoustic draw existed (commit 59815bb)
    expected = {(1, 0): (1758738352, 58.81, 43.61, 6.39, ("sphere", 25.075, 0.315, 253.0)),
                (7, 3): (524468721, 24.71, 42.62, 8.49, ("half_pipe", 1.209, 10.839, 90.3)),
                (7302, 5): (718511999, 51.61, 34.87, 8.87, ("pipe", 11.036, -10.398, 28.6))}
    for (seed, index), values in expected.items():
        draw_acoustics(space, seed, index, 8.0, (models_of(space) or ("didson",))[0])  # changes nothing
        d = draw_survey(seed, index)
        assert (d.seed, d.depth, d.tilt_deg, d.window_length, d.objects[0]) == values


def test_ideal_and_a_profile_write_only_their_name() -> None:
    ideal = draw_acoustics("ideal", 1, 0, 8.0)
    assert tomllib.loads(ideal.table_toml()) == {"acoustics": {"profile": "ideal"}}  # a scene without it is realistic
    assert ideal.factors() == {}
    scene = loads_scene(draw_survey(1, 0, small=True).scene_toml() + "\n" + ideal.table_toml())
    assert scene.acoustics is not None and resolve(scene.acoustics) is None  # the idealized model
    d = draw_acoustics("aris1800", 1, 0, 8.0, "aris1800")
    assert tomllib.loads(d.table_toml()) == {"acoustics": {"profile": "aris1800"}}
    assert d.factors() == {"profile": "aris1800"}
    with pytest.raises(ValueError, match="oculus"):
        draw_acoustics("oculus", 1, 0, 8.0)


def test_the_drawn_table_validates_and_the_simulator_renders_the_drawn_values() -> None:
    schema = json.loads(SCHEMA.read_text())
    for i in range(8):
        survey = draw_survey(41, i, small=True)
        a = draw_acoustics("random", 41, i, survey.window_length)
        text = survey.scene_toml() + "\n" + a.table_toml()
        jsonschema.validate(tomllib.loads(text), schema)
        resolved = resolve(loads_scene(text).acoustics)
        assert resolved is not None
        base = PROFILE_VALUES[a.profile]
        assert resolved.azimuth_width_beams == base["azimuth_width_beams"]  # not drawn: the profile's
        for key, value in a.overrides().items():
            assert getattr(resolved, key) == value, key


def test_acoustic_bins_hold_every_draw_and_the_edges() -> None:
    assert acoustic_bin("sidelobe_db", -35.0) == "-35--28"
    assert acoustic_bin("sidelobe_db", -15.0) == "-22--15"  # the last bin is closed
    assert acoustic_bin("interference_fraction", 0.005) == "0-0.01"
    assert acoustic_bin("profile", "didson") == "didson"
    for a in _random_draws(9, 50):
        for f, v in a.factors().items():
            labels = ACOUSTIC_BINS[f]
            label = acoustic_bin(f, v)
            assert label in labels if isinstance(v, str) else label.count("-") >= 1


def _record(index: int, space: str, correct: int) -> dict:
    a = draw_acoustics(space, 77, index, 8.0)
    dets = [{"class": "sphere", "position_ned": [10.0 * k, 0.0, 20.0], "size": [1.0, 1.0, 0.5]}
            for k in range(correct)]
    truth = [("sphere", 10.0 * k, 0.0) for k in range(2)]
    from auvlink.evaluation.survey_scores import score_survey

    d = draw_survey(77, index, small=True)
    return {"index": index, "factors": d.factors(), "acoustic_factors": a.factors(), "acoustics": a.to_dict(),
            "score": score_survey(dets, truth)}


def test_acoustic_factor_rows_appear_in_the_table_and_pool_the_right_surveys() -> None:
    records = [_record(i, "random", 2 if i % 2 else 1) for i in range(6)]
    result = summarize(records)
    for f in ACOUSTIC_BINS:
        bins = result["by_factor"][f]
        assert sum(r["surveys"] for r in bins) == 6, f
        assert sum(r["objects"] for r in bins) == 12, f
    by_profile = {r["bin"]: r for r in result["by_factor"]["profile"]}
    for p in SONAR_PROFILES:
        sel = [r for r in records if r["acoustics"]["profile"] == p]
        assert by_profile[p]["surveys"] == len(sel)
        if sel:
            found = sum(r["score"]["correct_1m"] for r in sel)
            assert math.isclose(by_profile[p]["recall_1m"], found / (2 * len(sel)))
    table = text_table(result)
    assert "sidelobe_db" in table and "interference_fraction" in table and "aris3000" in table
    assert json.loads(json.dumps(result["by_factor"]["pulse_bins"]))[0]["bin"] == "1-2"
    # ideal: no acoustic rows, the table of the survey factors alone
    plain = summarize([_record(i, "ideal", 2) for i in range(3)])
    assert not set(ACOUSTIC_BINS) & {r["factor"] for r in rows(plain)}
    assert by_acoustic_factor([], []) == {}


@pytest.mark.slow
def test_small_random_acoustics_survey_end_to_end(tmp_path: Path) -> None:
    from auvlink.evaluation.surveys import run_surveys

    result = run_surveys(1, 5, tmp_path, workers=1, progress=False, small=True, acoustics="random")
    rec = result["surveys"][0]
    a = draw_acoustics("random", 5, 0, draw_survey(5, 0, small=True).window_length)
    assert rec["acoustics"] == a.to_dict() and result["acoustics"] == "random"
    scene = tomllib.loads((tmp_path / "surveys" / "000" / "scene.toml").read_text())
    assert scene["acoustics"]["sidelobe_db"] == a.sidelobe_db
    saved = json.loads((tmp_path / "surveys.json").read_text())
    assert saved["by_factor"]["profile"][SONAR_PROFILES.index(a.profile)]["surveys"] == 1
    assert rec["sonar_frames"] > 0 and rec["score"]["objects"] == 2
    assert "--acoustics random" in saved["command"]
