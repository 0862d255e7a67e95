"""The class from the cloud and the shadow's height (classify.shadow_height), the solid classes' tops from the
meshes (classify.training.solid_tops) and the shipped checkpoint that carries them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from classify.cloud_classifier import DEFAULT_MODEL, CloudClassifier
from classify.inference_export import export_path, matching_export
from classify.shadow_height import FLOOR, SIGMA_FRACTION, SIGMA_M, height_weights, weighed

NAMES = ("reef_a", "sphere", "hemisphere", "pipe", "half_pipe", "box", "clutter")
TOPS = {"sphere": 1.0, "hemisphere": 0.5, "pipe": 0.6, "half_pipe": 0.3, "box": 0.6}


def _clf() -> CloudClassifier:
    return CloudClassifier(NAMES, 256, 2.0, "seabed", 0.6, shadow_tops=TOPS)


def test_a_low_shadow_names_the_half_pipe_a_pipe_cloud_resembles() -> None:
    prob = np.array([[0.0, 0.0, 0.0, 0.6, 0.35, 0.0, 0.05]], np.float32)
    clf = _clf()
    assert clf.decide(prob)[0][0] == "pipe"
    assert clf.decide(prob, shadow_heights=[math.nan])[0] == ("pipe", pytest.approx(0.6))  # not measured
    name, score = clf.decide(prob, shadow_heights=[0.31])[0]
    assert name == "half_pipe" and 0.8 < score <= 0.95  # the row keeps its object classes' total, 0.95
    assert clf.decide(prob, shadow_heights=[0.62])[0][0] == "pipe"


def test_a_confident_network_keeps_its_class_against_a_wrong_height() -> None:
    prob = np.array([[0.0, 0.0, 0.0, 0.0, 0.97, 0.01, 0.02]], np.float32)  # a half pipe at 97 %
    assert _clf().decide(prob, shadow_heights=[0.6])[0][0] == "half_pipe"  # odds over 1 / FLOOR: kept


def test_the_height_never_lifts_a_solid_class_over_an_open_one_or_touches_clutter() -> None:
    prob = np.array([[0.5, 0.0, 0.0, 0.0, 0.45, 0.0, 0.05], [0.1, 0.0, 0.0, 0.2, 0.0, 0.0, 0.7]], np.float32)
    out = _clf().decide(prob, allow_clutter=True, shadow_heights=[0.30, 0.6])
    assert out[0][0] == "reef_a"  # a reef's shadow is not its top: weight 1, the half pipe's at most 1
    assert out[1] == ("clutter", pytest.approx(0.7))  # the clutter rule reads the network's own probability


@given(h=st.floats(0.0, 3.0))
def test_weights_peak_at_each_class_top_and_stay_in_0_1(h: float) -> None:
    w = height_weights([h], NAMES, TOPS)[0]
    assert np.all((w >= 0) & (w <= 1))
    assert w[0] == 1.0 and w[-1] == 1.0  # reef, clutter: no top
    for i, n in enumerate(NAMES):
        if n in TOPS:
            s = SIGMA_M + SIGMA_FRACTION * TOPS[n]
            assert w[i] == pytest.approx(max(FLOOR, math.exp(-0.5 * ((h - TOPS[n]) / s) ** 2)))
    q = weighed(np.full((1, len(NAMES)), 1 / len(NAMES)), [h], NAMES, TOPS)
    assert q.sum() == pytest.approx(1.0)


def test_solid_classes_of_the_catalogue() -> None:
    from classify.training.dataset import catalog_meshes
    from classify.training.solid_tops import solid_tops

    names, mesh_for = catalog_meshes()
    tops = solid_tops([*names, "clutter"], mesh_for)
    assert tops == {"sphere": 1.0, "hemisphere": 0.5, "pipe": 0.6, "half_pipe": 0.3, "box": 0.6}


def test_the_shipped_model_and_its_export_carry_the_solid_tops() -> None:
    from classify.checkpoint import load_checkpoint

    ck = load_checkpoint(DEFAULT_MODEL)
    assert ck.calibration["shadow_tops_m"] == TOPS
    export, _ = matching_export(DEFAULT_MODEL)
    assert export is not None and export.meta.shadow_tops_m == TOPS, export_path(DEFAULT_MODEL)
