"""The decision over the network's probabilities and each object's evidence (classify.decision): it learns what the
evidence says where the network cannot tell, is stored and read back with a checkpoint and its inference export,
and the engine hands it what recon measured (auvlink.pipeline.object_labels.object_evidence)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from pointnet_helpers import trained_like

from auvlink.pipeline.object_labels import object_evidence
from classify.checkpoint import load_checkpoint, save_checkpoint
from classify.cloud_classifier import CloudClassifier
from classify.decision import EVIDENCE, FEATURES, DecisionModel, features, fit_decision, no_evidence
from classify.errors import CheckpointError
from classify.infer import Classifier
from classify.labels import CLUTTER
from classify.numpy_infer import NumpyClassifier, load_classifier
from classify.pointnet import PointNetConfig
from classify.training.dataset import CloudSet
from classify.training.decision_fit import DecisionSettings, decision_stage
from recon.cluster import DetectedObject
from recon.shadow import ShadowReading

NAMES = ("half_pipe", "pipe", CLUTTER)
TOPS = {"half_pipe": 0.3, "pipe": 0.6}


def _objects(n: int, seed: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Half pipes and pipes the network cannot tell apart (probabilities 0.45 / 0.45 / 0.1, jittered) whose shadow
    heights can (0.3 and 0.6 m, 5 cm of noise), and clutter the network half-suspects whose clouds are few points
    seen for an instant."""
    rng = np.random.default_rng(seed)
    y = rng.integers(0, 3, n)
    prob = np.column_stack([np.full(n, 0.45), np.full(n, 0.45), np.full(n, 0.10)])
    prob[y == 2] = [0.35, 0.35, 0.30]
    prob = prob * rng.uniform(0.9, 1.1, prob.shape)
    prob /= prob.sum(axis=1, keepdims=True)
    ev = no_evidence(n)
    col = {k: EVIDENCE.index(k) for k in EVIDENCE}
    ev[:, col["shadow_height_m"]] = np.where(y == 0, 0.3, 0.6) + rng.normal(0.0, 0.05, n)
    ev[y == 2, col["shadow_height_m"]] = np.nan
    ev[:, col["length_m"]], ev[:, col["width_m"]] = 3.0, 0.6
    ev[:, col["height_m"]] = ev[:, col["top_m"]] = np.where(y == 0, 0.5, 0.8)
    ev[:, col["n_points"]] = np.where(y == 2, rng.integers(20, 60, n), rng.integers(300, 900, n))
    ev[:, col["span_s"]] = np.where(y == 2, 0.1, 3.0)
    return prob, ev, y


def test_the_decision_learns_what_the_evidence_tells_and_the_network_cannot() -> None:
    prob, ev, y = _objects(600, 0)
    model = fit_decision(prob, ev, y, NAMES)
    tp, tev, ty = _objects(300, 1)
    q = model.probabilities(tp, tev)
    assert q.shape == (300, 3) and np.allclose(q.sum(axis=1), 1.0)
    assert np.mean(q.argmax(axis=1) == ty) > 0.95
    assert np.mean(tp.argmax(axis=1) == ty) < 0.6  # the network alone: a coin toss between the two


def test_features_have_one_column_per_class_and_named_input() -> None:
    prob, ev, _ = _objects(5, 2)
    x = features(prob, ev)
    assert x.shape == (5, len(NAMES) + len(FEATURES)) and np.isfinite(x).all()
    assert np.isfinite(features(prob, no_evidence(5))).all()  # nothing known: still inputs (flags off)


def test_a_decision_reads_back_from_its_metadata_and_refuses_another_network() -> None:
    prob, ev, y = _objects(200, 3)
    model = fit_decision(prob, ev, y, NAMES, fitted_on={"surveys": 3})
    back = DecisionModel.from_meta(model.to_meta().model_dump(), NAMES)
    assert np.array_equal(back.probabilities(prob, ev), model.probabilities(prob, ev))
    assert back.fitted_on == {"surveys": 3}
    with pytest.raises(ValueError, match="classes"):
        DecisionModel.from_meta(model.to_meta(), ("pipe", "half_pipe", CLUTTER))
    bad = model.to_meta().model_dump()
    bad["coef"] = bad["coef"][:2]
    with pytest.raises(ValueError, match="coef"):
        DecisionModel.from_meta(bad, NAMES)


def test_a_class_without_objects_is_never_the_decision() -> None:
    prob, ev, y = _objects(200, 4)
    keep = y != 1  # no pipe among the objects it is fitted on
    model = fit_decision(prob[keep], ev[keep], y[keep], NAMES)
    assert model.probabilities(prob, ev)[:, 1].max() < 1e-9


def test_the_classifier_decides_with_the_evidence_and_without_it_as_before() -> None:
    prob, ev, y = _objects(300, 5)
    model = fit_decision(prob, ev, y, NAMES)
    plain = CloudClassifier(NAMES, 64, 1.5, "seabed", 0.6, shadow_tops=TOPS)
    clf = CloudClassifier(NAMES, 64, 1.5, "seabed", 0.6, shadow_tops=TOPS, decision=model.to_meta())
    tp, tev, ty = _objects(200, 6)
    heights = tev[:, 0].tolist()
    assert clf.decide(tp, shadow_heights=heights) == plain.decide(tp, shadow_heights=heights)  # no evidence
    decided = [NAMES.index(c) for c, _ in clf.decide(tp, evidence=tev)]
    assert np.mean(np.array(decided) == ty) > 0.95
    assert all(c != CLUTTER for c, _ in clf.decide(tp, allow_clutter=False, evidence=tev))
    clf.set_clutter_threshold(math.inf)  # the clutter rule off (auvlink eval --clutter-sweep)
    assert all(c != CLUTTER for c, _ in clf.decide(tp, evidence=tev))
    with pytest.raises(CheckpointError, match=r"calibration\.decision"):
        CloudClassifier(("a", "b"), 64, 1.5, "seabed", 0.6, decision=model.to_meta())


def test_a_checkpoint_keeps_its_decision_through_the_export(tmp_path: Path) -> None:
    prob, ev, y = _objects(300, 7)
    model = fit_decision(prob, ev, y, NAMES)
    cfg = PointNetConfig(num_classes=3, width=0.125)
    path = save_checkpoint(tmp_path / "m.pt", trained_like(cfg, 0), NAMES, 64, {"scale_m": 1.5, "z_ref": "seabed"},
                           {}, {}, {"clutter_threshold": 0.6, "decision": model.to_meta().model_dump()})
    assert load_checkpoint(path).calibration["decision"]["class_names"] == list(NAMES)
    numpy_clf = load_classifier(path)
    assert isinstance(numpy_clf, NumpyClassifier) and numpy_clf.decision is not None
    torch_clf = Classifier.load(path)
    assert torch_clf.decision is not None
    tp, tev, _ = _objects(50, 8)
    assert numpy_clf.decide(tp, evidence=tev) == torch_clf.decide(tp, evidence=tev)


def test_the_stage_fits_on_survey_objects_and_reports_the_held_out_ones() -> None:
    prob, ev, y = _objects(400, 9)

    class Fixed(CloudClassifier):  # the network's probabilities are the synthetic ones, cloud by cloud
        def probabilities(self, clouds, batch_size=16, seabed_depths=None):  # type: ignore[no-untyped-def]
            return prob[[int(c[0, 0]) for c in clouds]].astype(np.float32)

    clf = Fixed(NAMES, 64, 1.5, "seabed", 0.6, shadow_tops=TOPS)
    pts = np.zeros((400, 4, 3), np.float32)
    pts[:, 0, 0] = np.arange(400) / 1.5  # cloud i carries its index (scaled back by scale_m)
    data = CloudSet(pts, y, NAMES, np.zeros(400), np.zeros(400), 1.5, "seabed")
    settings = replace(DecisionSettings(), surveys=4)
    model, metrics = decision_stage(clf, settings, lambda s, names: (data, ev))
    assert metrics["n_objects"] == 400 and metrics["settings"]["surveys"] == 4
    h = metrics["holdout"]
    assert 60 <= h["n_objects"] <= 140  # a quarter held out
    assert h["decision"]["accuracy"] > 0.9 > h["network_rule"]["accuracy"]
    assert model.fitted_on and model.fitted_on["seed"] == settings.seed


def test_the_engine_hands_over_what_recon_measured() -> None:
    pts = np.array([[0.0, 0.0, 19.5], [1.0, 0.2, 19.9], [0.5, 0.1, 20.0]] * 10)
    reading = ShadowReading(0.52, (0.3, 0.4, 0.52), (0.1, 0.15, 0.2), 40, 300)
    o = DetectedObject(id=3, centroid=pts.mean(axis=0), extent=np.ptp(pts, axis=0), points=pts, n_points=30,
                       t_first=10.0, t_last=12.5, seabed_depth=20.0, shadow_height=0.52, shadow=reading)
    ev = dict(zip(EVIDENCE, object_evidence(o), strict=True))
    assert ev["shadow_height_m"] == 0.52 and ev["n_points"] == 30 and ev["span_s"] == 2.5
    assert (ev["length_m"], ev["width_m"], ev["height_m"]) == pytest.approx((1.0, 0.2, 0.5))
    assert ev["top_m"] == pytest.approx(0.5)  # 20 m seabed, the shallowest points at 19.5 m
    assert (ev["footprint_q90_m"], ev["ring_q50_m"], ev["ring_tops"]) == (0.52, 0.1, 300)
    unmeasured = object_evidence(replace(o, shadow_height=math.nan, shadow=ShadowReading(), seabed_depth=math.nan))
    assert np.isnan(unmeasured[[EVIDENCE.index("shadow_height_m"), EVIDENCE.index("top_m")]]).all()


@pytest.mark.slow
@pytest.mark.train
def test_fit_decision_writes_a_checkpoint_whose_export_decides_with_the_evidence(tmp_path: Path) -> None:
    """``auvlink train --fit-decision``: the networks and calibration kept, the decision model fitted on the
    surveys' objects (here from their cache files) stored in the checkpoint and its export."""
    from auvlink.cli import main
    from auvlink.evaluation.survey_clouds import cache_key

    names = ("sphere", "hemisphere", "box", "pipe", "half_pipe", "reef_a", "reef_b", "reef_c", CLUTTER)
    cfg = PointNetConfig(num_classes=len(names), width=0.125)
    start = save_checkpoint(tmp_path / "start.pt", trained_like(cfg, 1), names, 64,
                            {"scale_m": 1.5, "z_ref": "seabed", "n_points": 128}, {}, {"heldout": {"accuracy": 0.5}},
                            {"clutter_threshold": 0.6, "shadow_tops_m": {"sphere": 1.0}})
    (tmp_path / "cache" / "surveys").mkdir(parents=True)
    rng = np.random.default_rng(0)
    for i in range(3):
        key = cache_key(5, "ideal" if i == 2 else "random", "didson", 128, 1.5, "seabed")  # ideal_every = 3
        labels = np.array([names[(i * 9 + k) % 9] for k in range(30)])
        ev = no_evidence(30)
        ev[:, 0] = rng.uniform(0.2, 1.0, 30)
        ev[:, EVIDENCE.index("n_points")] = rng.integers(30, 900, 30)
        np.savez(tmp_path / "cache" / "surveys" / f"{key}-{i:04d}.npz",
                 clouds=rng.normal(0.0, 0.3, (30, 128, 3)).astype(np.float32), labels=labels,
                 shadow_heights=ev[:, 0], heading_deg=np.zeros(30), tilt_deg=np.full(30, 30.0), evidence=ev)
    settings = tmp_path / "s.toml"
    settings.write_text("[decision]\nsurveys = 3\nseed = 5\nideal_every = 3\nworkers = 1\n")
    out = tmp_path / "decided.pt"
    args = ["train", "--fit-decision", str(start), "--config", str(settings), "--out", str(out), "--quiet",
            "--cache", str(tmp_path / "cache")]
    assert main(args) == 0
    ck = load_checkpoint(out)
    assert ck.calibration["clutter_threshold"] == 0.6 and ck.calibration["shadow_tops_m"] == {"sphere": 1.0}
    assert ck.metrics["heldout"] == {"accuracy": 0.5}
    assert ck.metrics["decision"]["n_objects"] == 90 and ck.metrics["decision"]["settings"]["surveys"] == 3
    assert ck.calibration["decision"]["fitted_on"]["seed"] == 5
    clf = load_classifier(out)
    assert isinstance(clf, NumpyClassifier) and clf.decision is not None
    before = out.read_bytes()
    assert main(args) == 1  # an existing --out is replaced only with --force
    assert out.read_bytes() == before
    assert main([*args[:-3], "--out", str(tmp_path / "x.pt"), "--decision-surveys", "0"]) == 1  # nothing to fit on
