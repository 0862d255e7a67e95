"""PointNet shapes and regulariser, checkpoints, inference checks, augmentation, evaluation."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch

from classify.checkpoint import load_checkpoint, save_checkpoint
from classify.errors import CheckpointError, InvalidCloudError, SynthesisError
from classify.infer import Classifier, check_cloud
from classify.pointnet import PointNet, PointNetConfig, orthogonality_loss
from classify.training.augment import AugmentConfig, augment_batch, point_dropout, random_yaw
from classify.training.evaluate import EvalReport, plot_confusion

torch.set_num_threads(1)


def test_forward_shapes() -> None:
    model = PointNet(PointNetConfig(num_classes=8, width=0.25)).eval()
    logits, trans = model(torch.randn(3, 100, 3))
    assert logits.shape == (3, 8)
    assert trans is not None and trans.shape == (3, 16, 16)
    bare = PointNet(PointNetConfig(num_classes=5, width=0.125, input_transform=False, feature_transform=False))
    logits, trans = bare.eval()(torch.randn(2, 50, 3))
    assert logits.shape == (2, 5) and trans is None


def test_full_width_matches_paper_channels() -> None:
    from classify.pointnet import LinearBN

    model = PointNet(PointNetConfig(num_classes=8))
    widths = [m.linear.out_features for part in (model.mlp1, model.mlp2, model.head) for m in part
              if isinstance(m, LinearBN)]
    assert widths == [64, 64, 64, 128, 1024, 512, 256]
    assert model.feature_tnet is not None and model.feature_tnet.k == 64


def test_tnets_start_at_identity_and_regulariser_zero() -> None:
    model = PointNet(PointNetConfig(num_classes=3, width=0.25)).eval()
    _, trans = model(torch.randn(2, 64, 3))
    assert trans is not None
    assert torch.allclose(trans, torch.eye(16).expand(2, 16, 16))
    assert orthogonality_loss(torch.eye(16).expand(4, 16, 16)).item() == pytest.approx(0.0, abs=1e-9)
    q, _ = torch.linalg.qr(torch.randn(2, 16, 16))
    assert orthogonality_loss(q).item() == pytest.approx(0.0, abs=1e-6)
    assert orthogonality_loss(2 * torch.eye(16)[None]).item() == pytest.approx(16 * 9.0)


def test_fused_model_same_output() -> None:
    torch.manual_seed(0)
    model = PointNet(PointNetConfig(num_classes=4, width=0.25))
    model.train()
    for _ in range(3):  # move the running statistics away from their defaults
        model(torch.randn(8, 64, 3))
    model.eval()
    x = torch.randn(2, 64, 3)
    with torch.no_grad():
        a, _ = model(x)
        b, _ = model.fused()(x)
    assert torch.allclose(a, b, atol=1e-4)


def test_permutation_invariant() -> None:
    model = PointNet(PointNetConfig(num_classes=4, width=0.25)).eval()
    x = torch.randn(1, 80, 3)
    with torch.no_grad():
        a, _ = model(x)
        b, _ = model(x[:, torch.randperm(80)])
    assert torch.allclose(a, b, atol=1e-5)


def _ckpt(tmp_path: Path) -> Path:
    model = PointNet(PointNetConfig(num_classes=3, width=0.125))
    return save_checkpoint(tmp_path / "m.pt", model, ("a", "b", "c"), 128, synthesis={"headings_deg": (0.0, 20.0)},
                           train={"epochs": 1}, metrics={"val_acc": np.float64(0.5)})


def test_checkpoint_round_trip(tmp_path: Path) -> None:
    path = _ckpt(tmp_path)
    ck = load_checkpoint(path)
    assert ck.class_names == ("a", "b", "c") and ck.n_points == 128
    assert ck.synthesis == {"headings_deg": [0.0, 20.0]} and ck.metrics == {"val_acc": 0.5}
    assert ck.model.cfg == PointNetConfig(num_classes=3, width=0.125)
    original = PointNet(PointNetConfig(num_classes=3, width=0.125))
    original.load_state_dict(torch.load(path, weights_only=True)["state_dict"])
    x = torch.randn(1, 40, 3)
    with torch.no_grad():
        assert torch.equal(original.eval()(x)[0], ck.model(x)[0])


def test_bad_checkpoints(tmp_path: Path) -> None:
    with pytest.raises(CheckpointError):
        load_checkpoint(tmp_path / "missing.pt")
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError):
        load_checkpoint(tmp_path / "junk.pt")
    torch.save({"format": "other"}, tmp_path / "other.pt")
    with pytest.raises(CheckpointError, match="format"):
        load_checkpoint(tmp_path / "other.pt")


def test_classifier_rejects_nan_inf_and_bad_shapes(tmp_path: Path) -> None:
    clf = Classifier.load(_ckpt(tmp_path), device=torch.device("cpu"))
    good = np.random.default_rng(0).normal(size=(300, 3)) + [100.0, 50.0, 20.0]
    name, score = clf.classify(good)
    assert name in ("a", "b", "c") and 0.0 < score <= 1.0
    assert clf.classify(good) == (name, score)  # deterministic
    for bad in (np.nan, np.inf, -np.inf):
        cloud = good.copy()
        cloud[17, 1] = bad
        with pytest.raises(InvalidCloudError, match="NaN or inf"):
            clf.classify(cloud)
    with pytest.raises(InvalidCloudError):
        check_cloud(np.zeros((0, 3)))
    with pytest.raises(InvalidCloudError):
        check_cloud(np.zeros((10, 2)))
    assert issubclass(InvalidCloudError, Exception)
    results = clf.classify_many([good, good[:50], good])
    assert results[0] == results[2] == (name, score)


def test_augmentations_seeded_and_shape_preserving() -> None:
    x = np.random.default_rng(0).normal(size=(4, 64, 3)).astype(np.float32)
    cfg = AugmentConfig()
    a = augment_batch(x, np.random.default_rng(1), cfg)
    b = augment_batch(x, np.random.default_rng(1), cfg)
    assert a.shape == x.shape and a.dtype == np.float32 and np.array_equal(a, b)
    y = random_yaw(x, np.random.default_rng(2))
    assert np.allclose(y[..., 2], x[..., 2])  # yaw keeps depth
    assert np.allclose(np.linalg.norm(y[..., :2], axis=-1), np.linalg.norm(x[..., :2], axis=-1), atol=1e-5)
    d = point_dropout(x, np.random.default_rng(3), 0.9)
    dup = (d == d[:, :1]).all(axis=-1).sum(axis=1)
    assert (dup >= 1).all() and dup.sum() > 4


def test_eval_report_metrics(tmp_path: Path) -> None:
    names = ("sphere", "hemisphere", "pipe", "half_pipe")
    true = [0, 0, 0, 0, 1, 1, 2, 2, 3, 3]
    pred = [0, 0, 0, 1, 1, 0, 2, 2, 3, 2]
    r = EvalReport.from_predictions(names, true, pred)
    pc = r.per_class()
    assert pc["sphere"]["recall"] == pytest.approx(0.75) and pc["sphere"]["precision"] == pytest.approx(0.75)
    assert pc["half_pipe"]["precision"] == pytest.approx(1.0) and pc["half_pipe"]["recall"] == pytest.approx(0.5)
    assert r.accuracy == pytest.approx(0.7)
    pairs = r.pair_confusions()
    assert pairs["sphere/hemisphere"]["sphere_as_hemisphere"] == 1
    assert pairs["sphere/hemisphere"]["hemisphere_as_sphere"] == 1
    assert pairs["pipe/half_pipe"]["half_pipe_as_pipe"] == 1
    assert "sphere/hemisphere" in r.text()
    png = plot_confusion(r, tmp_path / "cm.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plane_cut_removes_one_side_and_rescales() -> None:
    from classify.training.augment import normalize_batch, plane_cut

    x = normalize_batch(np.random.default_rng(0).normal(size=(5, 300, 3)).astype(np.float32))
    y = plane_cut(x, np.random.default_rng(1), prob=1.0, max_ratio=0.4)
    assert y.shape == x.shape
    assert np.allclose(np.linalg.norm(y, axis=2).max(axis=1), 1.0, atol=1e-5)
    assert np.allclose(y.mean(axis=1), 0.0, atol=0.05)
    assert all(len(np.unique(c, axis=0)) < 300 for c in y)
    assert np.array_equal(plane_cut(x, np.random.default_rng(1), prob=0.0, max_ratio=0.4), x)


def test_seabed_referenced_normalization_keeps_height() -> None:
    from classify.training.augment import normalize_batch
    from classify.training.synthesis import normalize_cloud

    p = np.array([[10.0, 5.0, 19.0], [12.0, 7.0, 19.5]])  # NED: 1.0 and 0.5 m above a seabed at 20 m
    n = normalize_cloud(p, 2.0, "seabed", 20.0)
    np.testing.assert_allclose(n, [[-0.5, -0.5, -0.5], [0.5, 0.5, -0.25]])
    np.testing.assert_allclose(normalize_cloud(p, 2.0), [[-0.5, -0.5, -0.125], [0.5, 0.5, 0.125]])
    with pytest.raises(SynthesisError, match="z_ref"):
        normalize_cloud(p, 2.0, "top")
    b = np.stack([n, n + [1.0, 1.0, 0.0]]).astype(np.float32)
    out = normalize_batch(b, fixed_scale=True, keep_z=True)
    np.testing.assert_allclose(out[:, :, 2], b[:, :, 2])  # heights untouched
    np.testing.assert_allclose(out[:, :, :2].mean(axis=1), 0.0, atol=1e-6)
    cfg = AugmentConfig(yaw=True, jitter_sigma=0.0, dropout_max=0.0, scale=(1.0, 1.0), z_shift=(0.1, 0.2))
    aug = augment_batch(b, np.random.default_rng(0), cfg, fixed_scale=True, keep_z=True)
    dz = (b[:, :, 2] - aug[:, :, 2])  # the seabed taken deeper: every point higher by one draw per cloud
    assert np.all((dz > 0.1 - 1e-6) & (dz < 0.2 + 1e-6)) and np.allclose(dz, dz[:, :1])
    # clouds made by recon's own seabed removal keep the seabed error recon made, when so configured: no shift or
    # tilt on those; the others are augmented as before, from the same draws
    measured = np.arange(len(b)) % 2 == 0
    cfg = replace(cfg, yaw=False, tilt_deg=8.0, seabed_error_on_measured=False)
    spared = augment_batch(b, np.random.default_rng(0), cfg, fixed_scale=True, keep_z=True, measured=measured)
    every = augment_batch(b, np.random.default_rng(0), replace(cfg, seabed_error_on_measured=True),
                          fixed_scale=True, keep_z=True, measured=measured)
    np.testing.assert_allclose(spared[measured], b[measured])
    np.testing.assert_allclose(spared[~measured], every[~measured])
    assert not np.allclose(every[measured], b[measured])


def test_classifier_seabed_depth(tmp_path: Path) -> None:
    net = PointNet(PointNetConfig(num_classes=3, width=0.125)).eval()
    path = save_checkpoint(tmp_path / "m.pt", net, ("a", "b", "c"), 64, {"scale_m": 1.5, "z_ref": "seabed"}, {}, {})
    clf = Classifier.load(path, device=torch.device("cpu"))
    assert clf.needs_seabed
    pts = np.random.default_rng(0).normal(size=(100, 3)) * 0.3 + [50.0, 20.0, 19.0]
    x = clf.prepare(pts, 20.0)
    assert x[:, 2].mean() == pytest.approx(-1.0 / 1.5, abs=0.05)  # 1 m above the seabed, in 1.5 m units
    # unknown (None or NaN): the cloud's deepest point stands in for the seabed
    np.testing.assert_allclose(clf.prepare(pts, None), clf.prepare(pts, float(pts[:, 2].max())))
    np.testing.assert_allclose(clf.prepare(pts, float("nan")), clf.prepare(pts, None))
    assert clf.classify(pts, 20.0) == clf.classify_many([pts], [20.0])[0]
    with pytest.raises(InvalidCloudError, match="seabed depths"):
        clf.probabilities([pts, pts], seabed_depths=[20.0])


def test_ensemble_checkpoint_averages_its_members(tmp_path: Path) -> None:
    """A checkpoint of three models (``[train] members``): they load back, and inference gives the mean of their
    probabilities (not of their logits), the first's clutter threshold and class names."""
    torch.manual_seed(0)
    nets = [PointNet(PointNetConfig(num_classes=3, width=0.125)).eval() for _ in range(3)]
    path = save_checkpoint(tmp_path / "ens.pt", nets[0], ("a", "b", "c"), 64, {}, {}, {}, {"clutter_threshold": 0.7},
                           members=nets[1:])
    ck = load_checkpoint(path)
    assert len(ck.members) == 2
    x = torch.randn(5, 64, 3)
    with torch.no_grad():
        for a, b in zip(nets, [ck.model, *ck.members], strict=True):
            assert torch.equal(a(x)[0], b(x)[0])
    clf = Classifier.load(path, device=torch.device("cpu"), yaw_views=1)
    assert clf.clutter_threshold == 0.7 and clf.model.cfg.width == 0.125
    clouds = [c.astype(np.float64) for c in x.numpy()]  # 64 points each: prepare only centres and scales them
    got = clf.probabilities(clouds)
    prepared = torch.from_numpy(np.stack([clf.prepare(c) for c in clouds]))
    with torch.no_grad():
        mean = torch.stack([torch.softmax(n(prepared)[0], dim=1) for n in nets]).mean(dim=0).numpy()
    np.testing.assert_allclose(got, mean, atol=1e-5)
    np.testing.assert_allclose(got.sum(axis=1), 1.0, atol=1e-5)
    single = Classifier.load(save_checkpoint(tmp_path / "one.pt", nets[0], ("a", "b", "c"), 64), torch.device("cpu"),
                             yaw_views=1)
    assert not np.allclose(single.probabilities(clouds), got, atol=1e-4)
    wide = PointNet(PointNetConfig(num_classes=3, width=0.25))
    with pytest.raises(CheckpointError, match="config"):
        save_checkpoint(tmp_path / "bad.pt", nets[0], ("a", "b", "c"), 64, members=[wide])


def test_yaw_views_average_the_turned_clouds(tmp_path: Path) -> None:
    """With ``yaw_views`` V the probabilities are the mean of those of the cloud turned by 0, 360/V, ... degrees
    about its vertical axis; so a cloud turned by 360/V degrees gets the same answer, which one view does not."""
    torch.manual_seed(1)
    net = PointNet(PointNetConfig(num_classes=3, width=0.125)).eval()
    path = save_checkpoint(tmp_path / "one.pt", net, ("a", "b", "c"), 64)
    one = Classifier.load(path, torch.device("cpu"), yaw_views=1)
    four = Classifier.load(path, torch.device("cpu"), yaw_views=4)
    rng = np.random.default_rng(3)
    cloud = rng.normal(size=(64, 3)) * [1.0, 0.3, 0.2] + [10.0, -4.0, 30.0]
    centre = cloud[:, :2].mean(axis=0)

    def turned(deg: float) -> np.ndarray:
        a = np.radians(deg)
        out = cloud.copy()
        out[:, :2] = (cloud[:, :2] - centre) @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]]) + centre
        return out

    views = one.probabilities([turned(d) for d in (0.0, 90.0, 180.0, 270.0)])
    np.testing.assert_allclose(four.probabilities([cloud])[0], views.mean(axis=0), rtol=0, atol=1e-6)
    np.testing.assert_allclose(four.probabilities([turned(90.0)]), four.probabilities([cloud]), rtol=0, atol=1e-6)
    assert np.abs(views[0] - views[1]).max() > 5e-6  # the network alone is not yaw-invariant
    with pytest.raises(ValueError, match="yaw_views"):
        Classifier.load(path, torch.device("cpu"), yaw_views=0)
