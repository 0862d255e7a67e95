"""The survey stage of training: clouds recon makes of simulated surveys, labelled by the simulator's truth, and the
networks trained on from their weights on them (``[surveys]``, ``auvlink train --from-checkpoint``)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from auvlink.evaluation.draw import draw_surveys
from auvlink.evaluation.survey_clouds import (
    MATCH_M,
    cache_key,
    label_objects,
    survey_cloud_set,
    survey_object_set,
    survey_space,
)
from classify.checkpoint import load_checkpoint, save_checkpoint
from classify.decision import EVIDENCE
from classify.labels import CLUTTER
from classify.pointnet import PointNet, PointNetConfig
from classify.training.config import TrainSettings, load_train_settings
from classify.training.dataset import CloudSet
from classify.training.survey_tuning import SurveySettings, mixed_with_synthesized, tune_on_surveys
from classify.training.synthesis import SynthesisSettings
from classify.training.train import TrainConfig, train
from classify.training.workflow import survey_stage

torch.set_num_threads(1)
NAMES = ("box", "sphere", "pipe", CLUTTER)
CFG = TrainConfig(epochs=2, batch_size=8, lr=5e-3, n_points=64, width=0.125, threads=1, val_fraction=0.25)


def _clouds(n_per_class: int = 8, seed: int = 0) -> CloudSet:
    """Clouds whose class is their size (box 1x, sphere 2x, pipe 3x, clutter 0.5x of a unit blob)."""
    rng = np.random.default_rng(seed)
    scale = np.repeat([1.0, 2.0, 3.0, 0.5], n_per_class)
    pts = (rng.normal(0.0, 0.2, (len(scale), 128, 3)) * scale[:, None, None]).astype(np.float32)
    labels = np.repeat(np.arange(4), n_per_class)
    return CloudSet(pts, labels, NAMES, np.zeros(len(labels)), np.zeros(len(labels)), 1.5, "seabed",
                    np.ones(len(labels), bool))


def test_objects_are_labelled_by_the_true_object_within_the_match_radius() -> None:
    truth = [("sphere", 10.0, 5.0), ("pipe", -3.0, 2.0)]
    pos = np.array([[10.3, 5.2], [-3.0, 2.0 + MATCH_M * 1.01], [-2.5, 2.4], [40.0, 0.0]])
    assert label_objects(pos, truth) == ["sphere", CLUTTER, "pipe", CLUTTER]
    assert label_objects(pos[:1], []) == [CLUTTER]


def test_training_from_weights_continues_them_and_leaves_them_alone() -> None:
    init = PointNet(PointNetConfig(num_classes=4, width=0.125))
    before = {k: v.clone() for k, v in init.state_dict().items()}
    data = _clouds()
    res = tune_on_surveys([init], data, SurveySettings(surveys=1, epochs=2, lr=1e-3), CFG, progress=False)
    assert len(res) == 1 and len(res[0].history) == 2
    assert all(torch.equal(v, init.state_dict()[k]) for k, v in before.items())  # the member given is untouched
    after = res[0].model.state_dict()
    assert any(v.dtype.is_floating_point and not torch.equal(v, after[k]) for k, v in before.items())
    with pytest.raises(ValueError, match="outputs"):
        train(data, CFG, progress=False, init=PointNet(PointNetConfig(num_classes=3, width=0.125)))


def test_the_stage_needs_its_clouds_and_enough_of_them() -> None:
    from classify.errors import SynthesisError

    settings = TrainSettings(SynthesisSettings(), CFG, surveys=SurveySettings(surveys=2, epochs=1))
    net = PointNet(PointNetConfig(num_classes=4, width=0.125))
    with pytest.raises(SynthesisError, match="surveys"):
        survey_stage([net], settings, NAMES, None, progress=False)
    with pytest.raises(SynthesisError, match="too few"):
        survey_stage([net], settings, NAMES, lambda s, names: _clouds(1), progress=False)
    stage = survey_stage([net], settings, NAMES, lambda s, names: _clouds(8), progress=False)
    assert stage.metrics["n_clouds"] == 32 and stage.metrics["clouds_per_class"] == dict.fromkeys(NAMES, 8)
    assert len(stage.calibration_set) == 8  # the validation split: 2 per class


def test_every_kth_survey_is_flown_under_the_idealized_model() -> None:
    assert [survey_space(i, "random", 4) for i in range(8)] == ["random"] * 3 + ["ideal"] + ["random"] * 3 + ["ideal"]
    assert {survey_space(i, "didson", 0) for i in range(8)} == {"didson"}
    assert {survey_space(i, "random", 1) for i in range(3)} == {"ideal"}


def test_synthesized_clouds_make_up_their_share_and_stay_apart() -> None:
    surveys, synthesized = _clouds(8), _clouds(40, seed=1)
    synthesized = replace(synthesized, measured=np.zeros(len(synthesized), bool))
    mixed, from_survey = mixed_with_synthesized(surveys, synthesized, 0.5, seed=3)
    assert len(mixed) == 64 and from_survey.sum() == 32 and not from_survey[32:].any()
    assert np.array_equal(mixed.points[:32], surveys.points) and np.array_equal(mixed.labels[:32], surveys.labels)
    assert mixed.measured is not None and mixed.measured.tolist() == from_survey.tolist()
    rows = {c.tobytes() for c in synthesized.points}
    assert all(c.tobytes() in rows for c in mixed.points[32:])  # drawn from the synthesized set, without repeats
    assert len({c.tobytes() for c in mixed.points[32:]}) == 32
    again, _ = mixed_with_synthesized(surveys, synthesized, 0.5, seed=3)
    assert np.array_equal(again.points, mixed.points)  # the seed fixes the draw
    assert len(mixed_with_synthesized(surveys, synthesized, 0.75, seed=3)[0]) == 32 + 96
    assert len(mixed_with_synthesized(surveys, synthesized, 0.95, seed=3)[0]) == 32 + 160  # at most all of them
    same, mask = mixed_with_synthesized(surveys, None, 0.5, seed=3)
    assert same is surveys and mask.all()
    with pytest.raises(ValueError, match="z_ref"):
        mixed_with_synthesized(surveys, replace(synthesized, z_ref="mean"), 0.5, seed=3)
    with pytest.raises(ValueError, match="share"):
        mixed_with_synthesized(surveys, synthesized, 1.0, seed=3)


def test_the_stage_calibrates_on_survey_clouds_only() -> None:
    from classify.errors import SynthesisError

    settings = TrainSettings(SynthesisSettings(), CFG, surveys=SurveySettings(surveys=2, epochs=1,
                                                                              synthesized_share=0.5))
    net = PointNet(PointNetConfig(num_classes=4, width=0.125))
    with pytest.raises(SynthesisError, match="synthesized_share"):
        survey_stage([net], settings, NAMES, lambda s, names: _clouds(8), progress=False)
    synthesized = replace(_clouds(40, seed=1), measured=np.zeros(160, bool))
    stage = survey_stage([net], settings, NAMES, lambda s, names: _clouds(8), synthesized, progress=False)
    assert stage.metrics["n_clouds"] == 32 and stage.metrics["n_synthesized"] == 32
    cal = stage.calibration_set
    assert 0 < len(cal) < 16 and cal.measured is not None and cal.measured.all()  # no synthesized cloud in it


def test_surveys_settings_are_checked() -> None:
    s = load_train_settings()
    assert s.surveys.acoustics == "random" and s.surveys.seed == 31 and s.surveys.epochs > 0
    assert s.surveys.surveys == 240 and s.surveys.ideal_every == 4 and s.surveys.synthesized_share == 0.5  # shipped
    assert load_train_settings(quick=True).surveys.surveys == 0  # --quick runs no survey stage


@pytest.mark.parametrize("text,key", [('[surveys]\nsonar = "gemini"\n', "surveys.sonar"),
                                      ("[surveys]\nsurveyz = 3\n", "surveys.surveyz"),
                                      ("[surveys]\nsurveys = -1\n", "surveys.surveys"),
                                      ("[surveys]\nsynthesized_share = 1.0\n", "surveys.synthesized_share"),
                                      ("[surveys]\nideal_every = -4\n", "surveys.ideal_every")])
def test_bad_surveys_settings_name_the_key(tmp_path: Path, text: str, key: str) -> None:
    from auvlink.errors import ConfigError

    p = tmp_path / "t.toml"
    p.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_train_settings(p)
    assert e.value.key == key, str(e.value)


@pytest.mark.slow
def test_survey_clouds_are_recons_clusters_labelled_by_the_truth(tmp_path: Path) -> None:
    names = ("sphere", "hemisphere", "box", "pipe", "half_pipe", "reef_a", "reef_b", "reef_c", CLUTTER)
    kw = {"n_points": 128, "scale_m": 1.5, "z_ref": "seabed", "cache_dir": tmp_path, "workers": 1,
          "progress": False, "small": True}
    data = survey_cloud_set(2, 5, names, **kw)
    truth = {c for d in draw_surveys(2, 5, small=True) for c, *_ in d.objects}
    found = {names[k] for k in data.labels} - {CLUTTER}
    assert len(found) >= 2 and found <= truth  # every object found is one the surveys hold
    assert data.points.shape == (len(data), 128, 3) and np.isfinite(data.points).all()
    # seabed-referenced: the objects stand above the seabed (z up is negative), none far below it
    assert np.median(data.points[:, :, 2]) < 0.0 and data.points[:, :, 2].max() < 1.0
    cached = sorted((tmp_path / "surveys").glob("*.npz"))
    assert len(cached) == 2
    again = survey_cloud_set(2, 5, names, **kw)  # from the cache
    assert np.array_equal(again.points, data.points) and np.array_equal(again.labels, data.labels)
    # each object's evidence for the decision model, from the same files
    objects, evidence = survey_object_set(2, 5, names, **kw)
    assert np.array_equal(objects.points, data.points) and evidence.shape == (len(data), len(EVIDENCE))
    ev = {k: evidence[:, i] for i, k in enumerate(EVIDENCE)}
    assert (ev["n_points"] >= 25).all() and (ev["length_m"] > 0).all() and (ev["span_s"] >= 0).all()
    assert np.isfinite(ev["top_m"]).all() and (ev["top_m"] > 0).all()  # objects stand above the seabed
    # a cache file written before the evidence was stored is harvested again when the evidence is asked for
    with np.load(cached[0]) as z:
        old = {k: z[k] for k in z.files if k != "evidence"}
    np.savez(cached[0], **old)
    _, again_ev = survey_object_set(2, 5, names, **kw)
    assert np.array_equal(again_ev, evidence) and "evidence" in np.load(cached[0]).files


@pytest.mark.slow
@pytest.mark.train
def test_from_checkpoint_runs_the_survey_stage_on_its_networks(tmp_path: Path) -> None:
    from auvlink.cli import main

    names = ("sphere", "hemisphere", "box", "pipe", "half_pipe", "reef_a", "reef_b", "reef_c", CLUTTER)
    nets = [PointNet(PointNetConfig(num_classes=len(names), width=0.125)) for _ in range(2)]
    start = save_checkpoint(tmp_path / "start.pt", nets[0], names, 64,
                            replace(load_train_settings().synthesis, headings_deg=(0.0, 120.0, 240.0),
                                    tilts_deg=(25.0, 40.0), copies=1, n_points=128, object_patch_views=0,
                                    clutter_clouds=8).to_dict(),
                            replace(CFG, batch_size=4).to_dict(), {"heldout": {"accuracy": 0.5}},
                            {"clutter_threshold": 0.6, "shadow_tops_m": {"sphere": 1.0}}, nets[1:])
    # the survey clouds from the cache (survey_cloud_set's own files; the harvest itself is tested above)
    (tmp_path / "cache" / "surveys").mkdir(parents=True)
    rng = np.random.default_rng(0)
    for i in range(3):
        key = cache_key(5, "ideal" if i == 2 else "random", "didson", 128, 1.5, "seabed")  # ideal_every = 3
        labels = np.array([names[(i * 9 + k) % 9] for k in range(12)])
        np.savez(tmp_path / "cache" / "surveys" / f"{key}-{i:04d}.npz",
                 clouds=rng.normal(0.0, 0.3, (12, 128, 3)).astype(np.float32), labels=labels,
                 shadow_heights=np.full(12, np.nan), heading_deg=np.zeros(12), tilt_deg=np.full(12, 30.0))
    cfg = tmp_path / "s.toml"
    cfg.write_text("[train]\nbatch_size = 4\nn_points = 64\nwidth = 0.125\nval_fraction = 0.25\n"
                   "[surveys]\nsurveys = 3\nseed = 5\nepochs = 1\nworkers = 1\nideal_every = 3\n"
                   "synthesized_share = 0.25\n")
    out = tmp_path / "tuned.pt"
    args = ["train", "--from-checkpoint", str(start), "--config", str(cfg), "--out", str(out), "--quiet",
            "--cache", str(tmp_path / "cache"), "--threads", "1"]
    assert main(args) == 0
    ck = load_checkpoint(out)
    assert ck.class_names == names and len(ck.members) == 1
    assert ck.metrics["surveys"]["settings"]["surveys"] == 3 and ck.metrics["surveys"]["n_clouds"] == 36
    assert ck.metrics["surveys"]["n_synthesized"] == 12  # a quarter of the stage's clouds
    assert ck.metrics["heldout_before_surveys"] == {"accuracy": 0.5}  # the start's report, kept under its name
    assert ck.metrics["heldout"]["thin"] and ck.metrics["heldout"]["n"] >= 8  # its held-out clouds classified again
    assert ck.calibration["shadow_tops_m"] == {"sphere": 1.0} and 0.3 <= ck.calibration["clutter_threshold"] <= 0.95
    assert out.with_suffix(".npz").is_file()
    before = out.read_bytes()
    assert main(args) == 1  # an existing --out is replaced only with --force
    assert out.read_bytes() == before


def test_cache_key_follows_the_code_the_clouds_pass_through(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """A survey cache made by other recon, simulator or engine code is not reused: the key holds their digest."""
    import auvlink.evaluation.survey_clouds as sc

    key = cache_key(5, "random", "didson", 128, 1.5, "seabed")
    assert key == cache_key(5, "random", "didson", 128, 1.5, "seabed")
    assert len(sc.code_digest()) == 64
    # a package of the same names with one line changed: another digest, another key
    pkg = tmp_path / "fake_recon"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "edge.py").write_text("STEP = 0.5\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sc, "CODE_PACKAGES", ("fake_recon",))
    sc.code_digest.cache_clear()
    first = cache_key(5, "random", "didson", 128, 1.5, "seabed")
    (pkg / "edge.py").write_text("STEP = 0.25\n")
    sc.code_digest.cache_clear()
    assert cache_key(5, "random", "didson", 128, 1.5, "seabed") not in (first, key)
    sc.code_digest.cache_clear()
