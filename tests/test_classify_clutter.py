"""The classifier's "not an object": clutter clouds synthesized from the simulator's rough seabed through recon's
own seabed removal and clustering, the decision rule (calibrated threshold), checkpoints without the class, and
the engine that counts clutter instead of reporting it (a real replay of a small simulated mission)."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from auvlink.evaluation.clutter_sweep import write_calibrated
from auvlink.sim.scene import CLASSES
from classify.checkpoint import load_checkpoint, save_checkpoint
from classify.infer import DEFAULT_MODEL, Classifier
from classify.labels import CLUTTER, with_clutter
from classify.pointnet import PointNet, PointNetConfig
from classify.training.clutter_synth import clutter_clouds, synthesize_clutter
from classify.training.config import load_train_settings
from classify.training.scan_synth import energy_first_return
from recon.reconstructor import ReconConfig
from recon.target_envelope import MAX_OBJECT_EXTENT_M

torch.set_num_threads(1)
SETTINGS = replace(load_train_settings().synthesis, seed=31)


def _dense_reference(t_hit: np.ndarray, cos_a: np.ndarray, hit: np.ndarray, threshold: float, bin_m: float,
                     min_run: int, r0: float = 6.0) -> np.ndarray:
    """The first formulation of energy_first_return (every ray against every ray of its cell)."""
    p_n, k, n_beams = t_hit.shape
    out = np.full((p_n, n_beams), np.inf)
    pi, bi = np.nonzero(hit.any(axis=1))
    if pi.size == 0:
        return out
    h = hit[pi, :, bi]
    t = np.where(h, t_hit[pi, :, bi], r0)
    e = np.where(h, cos_a[pi, :, bi] ** 2 * (r0 / t) ** 2 / k, 0.0)
    b = np.where(h, np.floor(t / bin_m), -10.0)
    diff = b[:, None, :] - b[:, :, None]
    ok = h.copy()
    for d in range(max(1, min_run)):
        ok &= np.where(diff == d, e[:, None, :], 0.0).sum(axis=2) >= threshold
    out[pi, bi] = np.where(ok, b * bin_m + 0.5 * bin_m, np.inf).min(axis=1)
    return out


def test_energy_first_return_matches_the_dense_formulation() -> None:
    rng = np.random.default_rng(3)
    for _ in range(150):
        p, k, b = (int(v) for v in rng.integers([1, 2, 1], [16, 33, 12]))
        t = np.round(rng.uniform(3.0, 4.0, (p, k, b)) / 0.02) * 0.02 + rng.uniform(0.0, 0.019, (p, k, b))
        cos_a, hit = rng.uniform(0.0, 1.0, (p, k, b)), rng.random((p, k, b)) < 0.6
        thr, run = float(rng.uniform(0.001, 0.05)), int(rng.integers(1, 4))
        got, want = energy_first_return(t, cos_a, hit, thr, 0.02, run), _dense_reference(t, cos_a, hit, thr, 0.02, run)
        np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
        np.testing.assert_allclose(got[np.isfinite(got)], want[np.isfinite(want)])


@pytest.mark.slow
def test_clutter_clusters_look_like_recon_clutter() -> None:
    """Clusters of rough seabed patches as recon leaves them: low (recon's threshold keeps them above the
    texture grid, the too-low test drops those under 0.15 m), no wider than recon's largest object, at least its
    cluster size; the same seed gives the same clouds. Measured on real rough surveys (seed 21, 16 clutter
    detections): 26-292 points, 0.3-4.4 m across, 95th-percentile height 0.14-0.43 m."""
    cfg = ReconConfig()
    found: list[tuple[np.ndarray, float]] = []
    for i in range(80):  # with the span rule of recon.highlight ~1 patch in 6 leaves a cluster (6 by the ~50th)
        got, heading, tilt = clutter_clouds(SETTINGS, np.random.default_rng([77, i]), cfg)
        assert 0.0 <= heading < 360.0 and 20.0 <= tilt <= 45.0
        found += got
        if len(found) >= 6:
            break
    assert len(found) >= 6, len(found)
    for pts, depth in found:
        h = depth - pts[:, 2]
        wide = float(np.max(np.ptp(pts[:, :2], axis=0)))
        assert len(pts) >= cfg.cluster.min_cluster_points and wide <= MAX_OBJECT_EXTENT_M
        assert 0.1 <= float(np.percentile(h, 95)) <= 0.8, np.percentile(h, 95)
    a, _ = synthesize_clutter(SETTINGS, 3)
    b, _ = synthesize_clutter(SETTINGS, 3)
    assert a.shape == (3, SETTINGS.n_points, 3) and a.dtype == np.float32 and np.array_equal(a, b)


def _tiny_checkpoint(path: Path, names: tuple[str, ...], calibration: dict[str, float] | None = None) -> Path:
    torch.manual_seed(0)
    model = PointNet(PointNetConfig(num_classes=len(names), width=0.1)).eval()
    return save_checkpoint(path, model, names, 64, {"scale_m": 1.5, "z_ref": "seabed"}, calibration=calibration)


def test_decision_rule_and_old_checkpoints(tmp_path: Path) -> None:
    """``clutter`` only at or above the calibrated threshold (and where allowed), else the best object class; a
    checkpoint of 8 outputs (no ``calibration`` key) loads, classifies and never says clutter."""
    names = with_clutter(CLASSES, True)
    clf = Classifier.load(_tiny_checkpoint(tmp_path / "nine.pt", names, {"clutter_threshold": 0.6}),
                          device=torch.device("cpu"))
    assert clf.clutter_index == 8 and clf.clutter_threshold == 0.6 and clf.object_classes == tuple(CLASSES)
    prob = np.zeros((3, 9), np.float32)
    prob[0, [8, 2]] = 0.7, 0.3  # clutter above the threshold
    prob[1, [8, 2]] = 0.55, 0.45  # the most probable, but below the threshold: the best object class
    prob[2, [8, 5]] = 0.9, 0.1
    assert clf.decide(prob, [True, True, False]) == [(CLUTTER, pytest.approx(0.7)), ("reef_c", pytest.approx(0.45)),
                                                   ("pipe", pytest.approx(0.1))]
    old = _tiny_checkpoint(tmp_path / "eight.pt", tuple(CLASSES))
    raw = torch.load(old, weights_only=True)
    del raw["calibration"]  # as written before the clutter class existed
    torch.save(raw, old)
    ck = load_checkpoint(old)
    assert ck.class_names == tuple(CLASSES) and ck.calibration == {}
    clf8 = Classifier.load(old, device=torch.device("cpu"))
    assert clf8.clutter_index is None and clf8.object_classes == tuple(CLASSES)
    cloud = np.random.default_rng(0).normal(size=(200, 3)) * [0.5, 0.5, 0.2] + [10.0, 5.0, 19.5]
    label, score = clf8.classify(cloud, 20.0)
    assert label in CLASSES and 0.0 < score <= 1.0
    assert all(c in CLASSES for c, _ in clf8.decide(np.eye(8, dtype=np.float32)))


@pytest.mark.slow
def test_engine_counts_clutter_and_does_not_report_it(small_mission_log: Path, tmp_path: Path) -> None:
    """The real replay path (framers, codecs, engine, recon, the shipped model) of a small mission with the
    shipped model's threshold moved: at 0 every cluster is clutter, counted in the stats and summary.json and
    never reported; at 1 none is (no cluster is certainly clutter), and both objects are reported."""
    from auvlink.pipeline.outputs import write_outputs
    from auvlink.pipeline.process import run_log

    ck = load_checkpoint(DEFAULT_MODEL)
    assert CLUTTER in ck.class_names, "the shipped model has no clutter output"
    runs = {}
    for name, thr in (("all", 0.0), ("none", 1.0)):  # a threshold is a probability, in [0, 1]
        model = write_calibrated(None, tmp_path / f"{name}.pt", thr, "test")  # the threshold the engine applies
        seen: list[str] = []
        result = run_log(small_mission_log, model=model, progress=False,
                         on_detection=lambda d, s=seen: s.append(d.class_name))
        summary = write_outputs(result, tmp_path / name)
        lines = (tmp_path / name / "detections.jsonl").read_text().splitlines()
        runs[name] = (result, summary, lines, seen)
    result, summary, lines, seen = runs["all"]
    assert result.detections == [] and lines == [] and seen == []
    assert summary["recon"]["rejected_clutter"] == 2 and summary["recon"]["rejected_not_objects"]["clutter"] == 2
    result, summary, lines, seen = runs["none"]
    assert sorted(json.loads(x)["class"] for x in lines) == ["pipe", "reef_c"] and CLUTTER not in seen
    assert summary["recon"]["rejected_clutter"] == 0
    assert len(seen) >= len(lines)  # every reported detection was handed on (updates of a fused one too)
