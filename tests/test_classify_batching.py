"""Classification in the engine: one batched pass equals the per-object pass, the content cache never classifies
the same cloud twice, and the modules on the start-up path load neither PyTorch nor Open3D."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from labelled_objects import box_object, loaded_labeller

from auvlink.pipeline.object_labels import ObjectLabeller, cloud_key
from recon.cluster import DetectedObject


def _object(oid: int, n: int, seed: int) -> DetectedObject:
    """A box-like cloud of ``n`` points (NED m) 1 m over a seabed at 20 m depth."""
    return box_object(oid, n, (-1.0, -0.5, 18.5), (1.0, 0.5, 19.0), seed, step_m=100.0)


@pytest.fixture(scope="module")
def labeller() -> ObjectLabeller:
    return loaded_labeller()


def test_batched_probabilities_equal_per_object(labeller: ObjectLabeller) -> None:
    clf = labeller.classifier
    assert clf is not None
    objs = [_object(i, n, seed=i) for i, n in enumerate([40, 40, 300, 300, 1500])]
    batched = clf.probabilities([o.points for o in objs], seabed_depths=[o.seabed_depth for o in objs])
    single = np.concatenate([clf.probabilities([o.points], seabed_depths=[o.seabed_depth]) for o in objs])
    np.testing.assert_allclose(batched, single, atol=1e-5)
    assert list(batched.argmax(axis=1)) == list(single.argmax(axis=1))


def test_same_cloud_is_classified_once(labeller: ObjectLabeller) -> None:
    objs = [_object(10 + i, 200, seed=100 + i) for i in range(3)]
    before = labeller.forward_clouds
    first = labeller.label(objs, reported=set())
    assert labeller.forward_clouds - before == 3
    again = labeller.label(objs, reported=set())
    assert labeller.forward_clouds - before == 3  # all three from the cache
    assert again == first


def test_changed_cloud_is_classified_again(labeller: ObjectLabeller) -> None:
    o = _object(20, 200, seed=7)
    labeller.label([o], reported=set())
    before = labeller.forward_clouds
    grown = _object(20, 260, seed=7)  # a later pass fused into the same id: new points
    labeller.label([grown], reported=set())
    assert labeller.forward_clouds - before == 1
    moved = DetectedObject(**{**o.__dict__, "seabed_depth": 21.0})  # same points, another seabed: new input
    labeller.label([moved], reported=set())
    assert labeller.forward_clouds - before == 2


def test_cloud_key_follows_content() -> None:
    p = np.random.default_rng(1).normal(size=(50, 3))
    assert cloud_key(p, 20.0) == cloud_key(p.copy(), 20.0)
    assert cloud_key(p, 20.0) != cloud_key(p[:49], 20.0)
    q = p.copy()
    q[3, 2] += 1e-9
    assert cloud_key(p, 20.0) != cloud_key(q, 20.0)


@pytest.mark.parametrize("module", ["auvlink.pipeline.engine", "auvlink.pipeline.object_labels",
                                    "auvlink.pipeline.process", "auvlink.cli"])
def test_start_up_modules_load_neither_torch_nor_open3d(module: str) -> None:
    code = (f"import sys, {module}; heavy = [m for m in ('torch', 'open3d') if m in sys.modules]; "
            "assert not heavy, heavy")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
