"""Inference without PyTorch: a checkpoint's inference export (classify.inference_export) run by NumPy
(classify.numpy_infer) gives PyTorch's probabilities and classes; a stale or broken export is refused and the checkpoint
runs with PyTorch; a replay with the shipped model never imports PyTorch."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
import torch
from pointnet_helpers import trained_like

from auvlink.cli import main
from auvlink.file_digest import sha256_file
from classify.checkpoint import save_checkpoint
from classify.cloud_classifier import DEFAULT_MODEL
from classify.errors import CheckpointError, InferenceExportWarning
from classify.infer import Classifier
from classify.inference_export import export_path, matching_export, read_export
from classify.numpy_infer import NumpyClassifier, load_classifier
from classify.pointnet import PointNetConfig

SEABED = 20.0  # m, NED depth of the flat seabed under the synthetic objects
ATOL = 1e-5  # probabilities: float32 sums in another order (OpenBLAS vs MKL), about 2e-7 seen


def _object_clouds(seed: int) -> tuple[list[npt.NDArray[np.float64]], list[float]]:
    """Clouds like recon's: the sonar-facing surfaces of spheres, boxes, pipes and mounds on a seabed at
    :data:`SEABED` m, a few cm of noise, 30 to 700 points, and flat seabed patches (clutter-like)."""
    rng = np.random.default_rng(seed)
    clouds = []
    for i in range(12):
        n = int(rng.integers(30, 700))
        kind = i % 4
        if kind == 0:  # a sphere of radius r resting on the seabed: its upper half
            r = rng.uniform(0.3, 1.0)
            d = rng.normal(size=(n, 3))
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            d[:, 2] = -np.abs(d[:, 2])
            p = d * r + [0.0, 0.0, SEABED - r]
        elif kind == 1:  # a box: its top and two sides
            size = rng.uniform(0.4, 2.0, 3) * [1.0, 1.0, 0.5]
            p = (rng.uniform(-0.5, 0.5, (n, 3)) * size)
            face = rng.integers(0, 3, n)
            p[face == 0, 2] = -size[2] / 2
            p[face == 1, 0] = size[0] / 2
            p[face == 2, 1] = size[1] / 2
            p += [0.0, 0.0, SEABED - size[2] / 2]
        elif kind == 2:  # a pipe lying along a random heading: its upper half cylinder
            r, length, yaw = rng.uniform(0.1, 0.4), rng.uniform(1.5, 4.0), rng.uniform(0, np.pi)
            a, s = rng.uniform(np.pi, 2 * np.pi, n), rng.uniform(-length / 2, length / 2, n)
            p = np.stack([s, r * np.cos(a), SEABED - r + r * np.sin(a)], axis=1)
            c, si = np.cos(yaw), np.sin(yaw)
            p[:, :2] = p[:, :2] @ np.array([[c, si], [-si, c]])
        else:  # a rough seabed patch
            p = np.column_stack([rng.uniform(-1.5, 1.5, (n, 2)), SEABED - np.abs(rng.normal(0, 0.08, n))])
        p += rng.normal(0.0, 0.03, p.shape) + [*rng.uniform(-50, 50, 2), 0.0]
        clouds.append(p)
    return clouds, [SEABED] * len(clouds)


def _same_decisions(a: list[tuple[str, float]], b: list[tuple[str, float]]) -> None:
    assert [c for c, _ in a] == [c for c, _ in b]
    np.testing.assert_allclose([s for _, s in a], [s for _, s in b], atol=ATOL, rtol=0)


@pytest.fixture(scope="module")
def shipped() -> tuple[NumpyClassifier, Classifier]:
    clf = load_classifier()
    assert isinstance(clf, NumpyClassifier)
    return clf, Classifier.load(None, device=torch.device("cpu"))


def test_shipped_export_is_made_from_the_shipped_checkpoint() -> None:
    """A retrained shipped model must be exported again (``auvlink train --export-inference``) before commit."""
    export, why = matching_export(DEFAULT_MODEL)
    assert export is not None, why
    assert export.meta.source_sha256 == sha256_file(DEFAULT_MODEL)


def test_shipped_model_numpy_equals_torch(shipped: tuple[NumpyClassifier, Classifier]) -> None:
    np_clf, torch_clf = shipped
    for seed in (1, 2, 3):
        clouds, depths = _object_clouds(seed)
        a = np_clf.probabilities(clouds, seabed_depths=depths)
        b = torch_clf.probabilities(clouds, seabed_depths=depths)
        np.testing.assert_allclose(a, b, atol=ATOL, rtol=0)
        np.testing.assert_allclose(a.sum(axis=1), 1.0, atol=ATOL)
        assert np.array_equal(a.argmax(axis=1), b.argmax(axis=1))
        _same_decisions(np_clf.decide(a), torch_clf.decide(b))


def test_shipped_model_settings_are_the_checkpoints(shipped: tuple[NumpyClassifier, Classifier]) -> None:
    np_clf, torch_clf = shipped
    for key in ("class_names", "n_points", "scale_m", "z_ref", "clutter_threshold", "clutter_index", "yaw_views"):
        assert getattr(np_clf, key) == getattr(torch_clf, key), key
    assert np_clf.needs_seabed and np_clf.backend == "numpy" and torch_clf.backend == "torch"


def _save(path: Path, members: int, transforms: bool, seed: int = 0, z_ref: str = "seabed") -> Path:
    cfg = PointNetConfig(num_classes=4, width=0.125, input_transform=transforms, feature_transform=transforms)
    nets = [trained_like(cfg, seed + 10 * k) for k in range(members)]
    return save_checkpoint(path, nets[0], ("box", "pipe", "sphere", "clutter"), 64, {"scale_m": 1.5, "z_ref": z_ref},
                           calibration={"clutter_threshold": 0.7}, members=nets[1:])


@pytest.mark.parametrize(("members", "transforms", "z_ref"), [(1, True, "seabed"), (3, True, "mean"),
                                                              (2, False, "seabed")])
def test_saved_checkpoint_exports_and_numpy_equals_torch(tmp_path: Path, members: int, transforms: bool,
                                                         z_ref: str) -> None:
    pt = _save(tmp_path / "m.pt", members, transforms, z_ref=z_ref)
    assert export_path(pt).is_file()
    export = read_export(export_path(pt))
    assert export.meta.members == members and export.meta.z_ref == z_ref and export.meta.clutter_threshold == 0.7
    np_clf = load_classifier(pt, yaw_views=3)
    torch_clf = Classifier.load(pt, device=torch.device("cpu"), yaw_views=3)
    assert isinstance(np_clf, NumpyClassifier) and np_clf.source == export_path(pt)
    clouds, depths = _object_clouds(7)
    a = np_clf.probabilities(clouds, seabed_depths=depths, batch_size=5)
    b = torch_clf.probabilities(clouds, seabed_depths=depths, batch_size=5)
    np.testing.assert_allclose(a, b, atol=ATOL, rtol=0)
    assert np.array_equal(a.argmax(axis=1), b.argmax(axis=1))
    _same_decisions(np_clf.classify_many(clouds, depths), torch_clf.classify_many(clouds, depths))


def test_stale_export_is_refused_and_torch_runs_the_checkpoint(tmp_path: Path) -> None:
    pt = _save(tmp_path / "m.pt", 2, True, seed=0)
    old_export = tmp_path / "old.npz"
    shutil.copy(export_path(pt), old_export)
    _save(pt, 2, True, seed=99)  # the checkpoint retrained: other weights
    shutil.copy(old_export, export_path(pt))  # ... and the old export put back beside it
    assert matching_export(pt)[0] is None
    with pytest.warns(InferenceExportWarning, match="stale"):
        clf = load_classifier(pt, threads=1)
    assert isinstance(clf, Classifier)
    clouds, depths = _object_clouds(4)
    fresh = Classifier.load(pt, device=torch.device("cpu")).probabilities(clouds, seabed_depths=depths)
    np.testing.assert_array_equal(clf.probabilities(clouds, seabed_depths=depths), fresh)
    stale = NumpyClassifier(read_export(old_export)).probabilities(clouds, seabed_depths=depths)
    assert np.abs(stale - fresh).max() > 1e-3  # the refused export would have given another model's answer


def test_missing_or_broken_export_falls_back_to_torch(tmp_path: Path) -> None:
    pt = _save(tmp_path / "m.pt", 1, True)
    export_path(pt).unlink()
    threads = torch.get_num_threads()
    try:
        with pytest.warns(InferenceExportWarning, match="no inference export"):
            assert isinstance(load_classifier(pt, threads=1), Classifier)
        assert torch.get_num_threads() == 1  # the PyTorch path sets PyTorch's threads
    finally:
        torch.set_num_threads(threads)
    export_path(pt).write_bytes(b"not a zip file")
    with pytest.warns(InferenceExportWarning, match="not a readable inference export"):
        assert isinstance(load_classifier(pt), Classifier)


def test_tampered_export_is_refused(tmp_path: Path) -> None:
    pt = _save(tmp_path / "m.pt", 1, True)
    with np.load(export_path(pt)) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["mlp2.0.weight"][0, 0, 0] = np.nan
    with open(export_path(pt), "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(CheckpointError, match=r"'mlp2\.0' holds NaN"):
        read_export(export_path(pt))
    arrays["mlp2.0.weight"][0, 0, 0] = 0.0
    arrays["classifier.weight"] = arrays["classifier.weight"][:, :3]
    arrays["classifier.bias"] = arrays["classifier.bias"][:, :3]
    with open(export_path(pt), "wb") as f:
        np.savez(f, **arrays)
    with pytest.raises(CheckpointError, match="no classifier layer with 4 outputs"):
        read_export(export_path(pt))


def test_export_whose_layers_do_not_chain_falls_back_to_torch(tmp_path: Path) -> None:
    pt = _save(tmp_path / "m.pt", 1, True)
    with np.load(export_path(pt)) as z:
        arrays = {k: z[k] for k in z.files}
    del arrays["head.1.weight"], arrays["head.1.bias"]  # the head's last layer gone: its input reaches the classifier
    with open(export_path(pt), "wb") as f:
        np.savez(f, **arrays)
    export = read_export(export_path(pt))  # every layer itself well-formed, and still naming this checkpoint
    assert matching_export(pt)[0] is not None
    with pytest.raises(CheckpointError, match="do not chain"):
        NumpyClassifier(export)
    with pytest.warns(InferenceExportWarning, match="do not chain"):
        assert isinstance(load_classifier(pt), Classifier)


def test_export_inference_command(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pt = _save(tmp_path / "m.pt", 2, True)
    export_path(pt).unlink()
    assert main(["train", "--export-inference", str(pt)]) == 0
    assert matching_export(pt)[0] is not None
    assert main(["train", "--export-inference", str(pt)]) == 0
    assert "already made from this checkpoint" in capsys.readouterr().out
    _save(pt, 2, True, seed=5)
    export_path(pt).write_bytes(b"a user's file")  # neither an export of this checkpoint nor ours to replace
    assert main(["train", "--export-inference", str(pt)]) == 1
    assert "--force" in capsys.readouterr().err and export_path(pt).read_bytes() == b"a user's file"
    assert main(["train", "--export-inference", str(pt), "--force"]) == 0
    assert matching_export(pt)[0] is not None
    assert main(["train", "--export-inference", str(tmp_path / "none.pt")]) == 1


def test_classifying_with_the_shipped_export_imports_no_torch() -> None:
    code = ("import sys, numpy as np\n"
            "from classify.numpy_infer import load_classifier\n"
            "clf = load_classifier(threads=1)\n"
            "p = np.random.default_rng(0).normal(size=(200, 3)) * [1.0, 1.0, 0.2] + [0.0, 0.0, 19.8]\n"
            "print(clf.backend, clf.classify(p, 20.0)[0])\n"
            "assert 'torch' not in sys.modules, 'torch imported'\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("numpy ")


@pytest.mark.slow
def test_replay_imports_no_torch(small_mission_log: Path, tmp_path: Path) -> None:
    """A replay of a mission with the shipped model classifies every object and never loads PyTorch."""
    code = ("import sys, json\n"
            "from auvlink.cli import main\n"
            f"assert main(['replay', {str(small_mission_log)!r}, '--out', {str(tmp_path / 'out')!r}, '--quiet', "
            "'--no-report']) == 0\n"
            "assert 'torch' not in sys.modules, 'torch imported'\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode == 0, out.stderr
    lines = (tmp_path / "out" / "detections.jsonl").read_text().splitlines()
    assert lines and all('"class": "unknown"' not in line for line in lines)
