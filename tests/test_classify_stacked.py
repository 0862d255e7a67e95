"""Inference with every ensemble member stacked into one network (classify.ensemble.StackedPointNets) gives the
probabilities of the members run one by one, and the classifier's threads follow the process's role."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from pointnet_helpers import trained_like

from auvlink.pipeline.object_labels import TORCH_THREADS, ObjectLabeller
from classify.ensemble import Ensemble, StackedPointNets
from classify.infer import Classifier, turned_views
from classify.numpy_infer import NumpyClassifier
from classify.pointnet import PointNet, PointNetConfig


def _trained_like(cfg: PointNetConfig, seed: int) -> PointNet:
    """A trained-like PointNet (tests/pointnet_helpers.py) with its batch norms folded."""
    return trained_like(cfg, seed).fused()


@pytest.mark.parametrize("members", [1, 3])
@pytest.mark.parametrize("transforms", [True, False])
def test_stacked_equals_members_one_by_one(members: int, transforms: bool) -> None:
    cfg = PointNetConfig(num_classes=9, width=0.25, input_transform=transforms, feature_transform=transforms)
    nets = [_trained_like(cfg, seed=10 * k) for k in range(members)]
    x = turned_views(torch.randn(5, 64, 3, generator=torch.Generator().manual_seed(3)), 4)
    with torch.inference_mode():
        each = torch.softmax(Ensemble(nets)(x)[0], dim=1) if members > 1 else torch.softmax(nets[0](x)[0], dim=1)
        stacked = StackedPointNets(nets)(x)
    assert stacked.shape == (20, 9)
    torch.testing.assert_close(stacked, each, atol=1e-5, rtol=0)
    assert torch.equal(stacked.argmax(dim=1), each.argmax(dim=1))


def test_stack_refuses_unfused_members() -> None:
    with pytest.raises(ValueError, match="fused"):
        StackedPointNets([PointNet(PointNetConfig(num_classes=3, width=0.125))])


@settings(max_examples=15, deadline=None)
@given(sizes=st.lists(st.integers(1, 300), min_size=1, max_size=6), seed=st.integers(0, 2**16))
def test_shipped_model_batch_equals_one_by_one(sizes: list[int], seed: int) -> None:
    """The shipped ensemble: clouds of any sizes classified together or alone, the same probabilities."""
    clf = _labeller().classifier
    assert clf is not None
    rng = np.random.default_rng(seed)
    clouds = [rng.normal(size=(n, 3)) * [1.0, 1.0, 0.3] + [0.0, 0.0, 19.0] for n in sizes]
    together = clf.probabilities(clouds, seabed_depths=[20.0] * len(clouds))
    alone = np.concatenate([clf.probabilities([c], seabed_depths=[20.0]) for c in clouds])
    np.testing.assert_allclose(together, alone, atol=1e-5)
    np.testing.assert_allclose(together.sum(axis=1), 1.0, atol=1e-5)


_LABELLER: list[ObjectLabeller] = []


def _labeller() -> ObjectLabeller:
    """The shipped model as a replay loads it: its inference export (NumPy), one BLAS thread per forward pass."""
    if not _LABELLER:
        lab = ObjectLabeller(True, None, torch_threads=TORCH_THREADS["replay"])
        threads = torch.get_num_threads()
        lab.load()
        assert isinstance(lab.classifier, NumpyClassifier) and lab.classifier.threads == TORCH_THREADS["replay"]
        assert torch.get_num_threads() == threads  # the NumPy path leaves PyTorch's threads alone
        _LABELLER.append(lab)
    return _LABELLER[0]


def test_labeller_leaves_threads_alone_without_a_role() -> None:
    threads = torch.get_num_threads()
    lab = ObjectLabeller(True, None)
    lab.load()
    assert torch.get_num_threads() == threads


def test_shipped_model_stacked_is_bit_identical_on_cpu() -> None:
    """The PyTorch path's stack gives the members' numbers to the bit (the same kernel per layer)."""
    clf = Classifier.load(None, device=torch.device("cpu"))
    rng = np.random.default_rng(5)
    x = turned_views(torch.from_numpy(rng.normal(size=(6, 256, 3)).astype(np.float32) * 0.4), clf.yaw_views)
    with torch.inference_mode():
        one_by_one = torch.softmax(clf.model(x)[0].float(), dim=1)
        assert torch.equal(clf.stacked(x), one_by_one)
