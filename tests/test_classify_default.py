"""The shipped default model: size, metadata, accuracy on synthesized and on reconstructed clouds, clutter
named clutter and objects not; a reduced-budget retrain reproduces it."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch
from image_checks import assert_plot_drawn

from auvlink.evaluation.recon_eval import PassSettings, reconstruct_pass
from classify.checkpoint import load_checkpoint
from classify.errors import SynthesisError
from classify.infer import DEFAULT_MODEL, Classifier
from classify.labels import CLUTTER, with_clutter
from classify.training.clutter_synth import synthesize_clutter
from classify.training.synthesis import MeshSynthesizer, SynthesisSettings

torch.set_num_threads(1)
catalog = pytest.importorskip("auvlink.sim.object_meshes")

#: a `--quick` retrain (6 headings, one pass per direction, 8 clutter clouds, 6 views on rough patches per class:
#: 248 clouds; 40 epochs, about 90 s here) must reach the shipped model's held-out accuracy minus this (measured:
#: 0.708 against 0.850; 12 epochs reached 0.576, still learning)
QUICK_TOLERANCE = 0.25
#: accuracy on the held-out views synthesized by the test (single, fused and partial views as in training:
#: measured 0.873, 55 of 63), with a margin
HELDOUT_FLOOR = 0.80


@pytest.fixture(scope="module")
def shipped() -> Classifier:
    if not DEFAULT_MODEL.is_file():
        pytest.skip("no shipped model (train it: auvlink train --out classify/data/pointnet_default.pt)")
    return Classifier.load(device=torch.device("cpu"))


def test_shipped_model_small_and_complete(shipped: Classifier) -> None:
    assert DEFAULT_MODEL.stat().st_size <= 15e6
    ck = load_checkpoint(DEFAULT_MODEL)
    assert ck.class_names == with_clutter(catalog.CLASSES, True) and shipped.clutter_index == 8
    assert 0.3 <= ck.calibration["clutter_threshold"] <= 0.95
    assert shipped.clutter_threshold == ck.calibration["clutter_threshold"]  # inference applies the calibration
    assert ck.synthesis["fused_prob"] > 0 and ck.synthesis["partial_prob"] > 0 and ck.synthesis["clutter_clouds"] > 0
    assert ck.synthesis["mode"] == "scan" and ck.synthesis["correction"] == "arc"
    assert ck.synthesis["detect"] == "energy" and ck.synthesis["z_ref"] == "seabed" and shipped.needs_seabed
    assert len(ck.synthesis["headings_deg"]) == 18 and len(ck.synthesis["tilts_deg"]) == 4
    assert ck.train["width"] > 0 and ck.metrics["epochs_run"] >= 1
    # accuracy is measured by running the model (below), not read from the metrics stored in the checkpoint


@pytest.mark.slow
def test_shipped_model_accuracy_on_heldout_views(shipped: Classifier) -> None:
    """A held-out set synthesized here: 8 random views per class (headings 0-360 deg, tilts 20-45 deg, a
    seed the training never used; single, fused and partial views as in training) through the shipped model.
    Measured: 55 of 63 right (0.873), 3 called clutter, 5 s; the training's own held-out figure is 0.857 (with
    the clutter class); the weakest class is pipe, 4 of 8 (a partial view of a pipe's end looks like a
    hemisphere or a box). Every class must be named right at least half of the time, so a swapped pair of class
    names fails even where the overall figure would not; few objects may be called clutter."""
    settings = replace(SynthesisSettings.from_dict(shipped.checkpoint.synthesis), seed=777)
    rng = np.random.default_rng(777)
    right: dict[str, list[bool]] = {}
    clutter = 0
    for name in catalog.CLASSES:
        synth = MeshSynthesizer(*catalog.mesh_for(name))
        for heading, tilt in zip(rng.uniform(0, 360, 8), rng.uniform(20, 45, 8), strict=True):
            try:
                cloud, _ = synth.view(math.radians(heading), math.radians(tilt), settings, rng)
            except SynthesisError:  # a low half pipe seen end-on shows no highlight extension at all
                continue
            label, _ = shipped.classify(cloud.astype(np.float64) * settings.scale_m + [100.0, 50.0, 30.0], 30.0)
            right.setdefault(name, []).append(label == name)
            clutter += label == CLUTTER
    n = sum(len(v) for v in right.values())
    accuracy = sum(sum(v) for v in right.values()) / n
    recall = {name: sum(v) / len(v) for name, v in right.items()}
    assert n >= 60 and set(right) == set(catalog.CLASSES), right
    assert accuracy >= HELDOUT_FLOOR, (accuracy, recall)
    assert min(recall.values()) >= 0.5, recall
    assert clutter <= 6, clutter


@pytest.mark.slow
def test_shipped_model_names_clutter(shipped: Classifier) -> None:
    """Clutter clouds of seabed patches the training never drew (another seed): what recon leaves of a rough
    seabed, through the shipped model in the world frame. Measured: 9 of 12 called clutter (seed 4242; 10 of 12
    with seed 4243), the others half_pipe; about 2 s."""
    settings = replace(SynthesisSettings.from_dict(shipped.checkpoint.synthesis), seed=4242)
    clouds, _ = synthesize_clutter(settings, 12)
    labels = [shipped.classify(c.astype(np.float64) * settings.scale_m + [200.0, -30.0, 40.0], 40.0)[0]
              for c in clouds]
    assert sum(label == CLUTTER for label in labels) >= 7, labels


@pytest.mark.slow
def test_shipped_model_names_unseen_views(shipped: Classifier) -> None:
    settings = replace(SynthesisSettings.from_dict(shipped.checkpoint.synthesis), seed=4242)
    rng = np.random.default_rng(4242)
    right = 0
    for name in catalog.CLASSES:
        synth = MeshSynthesizer(*catalog.mesh_for(name))
        for heading, tilt in ((37.0, 24.0), (213.0, 41.0)):
            cloud, _ = synth.view(math.radians(heading), math.radians(tilt), settings, rng)
            # a world-frame cloud: back to metres and moved far from the origin (seabed at 25 m)
            label, score = shipped.classify(cloud.astype(np.float64) * settings.scale_m + [512.0, -40.0, 25.0], 25.0)
            right += label == name
            assert 0.0 < score <= 1.0
    assert right >= 12  # of 16 (measured 14; chance is 2)


@pytest.mark.slow
def test_shipped_model_names_reconstructed_clouds(shipped: Classifier) -> None:
    """Clouds recon makes of simulated passes (simulator -> sonar frames -> recon), one per class."""
    s = PassSettings(seed=2027, run_in=11.0)
    right, seen = 0, 0
    for i, name in enumerate(catalog.CLASSES):
        pts, seabed = reconstruct_pass(name, 30.0 + 41.0 * i, (27.0, 33.0)[i % 2], (4.2, 4.8)[i % 3 % 2], 0.3, s)
        if len(pts) >= 8:
            seen += 1
            right += shipped.classify(pts, seabed)[0] == name
    # recon's own seabed fit gives the heights; measured: all that were detected named right (chance: 1 in 8)
    assert seen >= 7 and right >= seen - 1, (right, seen)


@pytest.mark.slow
@pytest.mark.train
def test_quick_retrain_reproduces_accuracy(shipped: Classifier, tmp_path: Path) -> None:
    from auvlink.cli import main

    out = tmp_path / "quick.pt"
    args = ["train", "--quick", "--out", str(out), "--cache", str(tmp_path / "cache"), "--quiet", "--threads", "1"]
    assert main(args) == 0
    quick = load_checkpoint(out).metrics["heldout"]["accuracy"]
    ref = load_checkpoint(DEFAULT_MODEL).metrics["heldout"]["accuracy"]
    assert quick >= ref - QUICK_TOLERANCE, (quick, ref)


@pytest.mark.slow
def test_eval_cli_writes_report(shipped: Classifier, tmp_path: Path) -> None:
    import json

    from auvlink.cli import main

    out = tmp_path / "eval"
    assert main(["eval", "--quick", "--out", str(out), "--cache", str(tmp_path / "cache")]) == 0
    report = json.loads((out / "eval.json").read_text())
    # 8 classes x 6 headings x 2 tilts, less the views from which a low half pipe gives no highlight at all,
    # 9 clutter clouds (200 for 270 views per class in the held-out set, 12 views per class here), and up to 2
    # views per class on rough patches (a patch whose object recon misses gives none)
    assert 8 * 6 * 2 - 6 + 9 + 8 <= report["n"] <= 8 * 6 * 2 + 9 + 16
    assert report["class_names"] == [*catalog.CLASSES, CLUTTER]
    assert set(report["lookalike_pairs"]) == {"sphere/hemisphere", "pipe/half_pipe"}
    assert report["macro"]["recall"] >= 0.7  # measured 0.78
    assert_plot_drawn(out / "confusion.png")  # the matrix drawn (Blues: every cell of recall >= 0.3 is coloured)
