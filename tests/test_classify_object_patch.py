"""Objects on rough seabeds (classify.training.object_patch_synth): the mesh lies on a drawn rough patch, the
lines' rays meet it or the seabed, and recon's own seabed removal and clustering give the view the classifier is
trained on."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from auvlink.sim.object_meshes import mesh_for
from auvlink.sim.scene import Seabed
from auvlink.sim.seabed import SeabedSurface
from classify.training.config import load_train_settings
from classify.training.dataset import _cache_key, heldout_settings
from classify.training.object_patch_synth import _placed, object_patch_view, synthesize_object_patches
from classify.training.seabed_returns import line_returns

SETTINGS = replace(load_train_settings().synthesis, seed=5, object_patch_views=2)


def test_the_obstacle_returns_before_the_seabed() -> None:
    """On a flat seabed a line past a box: without the box no highlight-extension point (a flat seabed has nothing
    ahead of its onset), with it the points lie on the box (within a range bin and the detection lag of its
    faces), none above its top."""
    seabed = SeabedSurface(Seabed(depth=30.0), 0)
    v, f = mesh_for("box")
    world, scene = _placed("box", np.asarray(v), f, seabed, 30.0)
    xs = np.arange(-14.0, 2.0, 0.1)
    origins = np.column_stack([xs, np.full_like(xs, 0.3), np.full_like(xs, 25.0)])
    rng = np.random.default_rng(1)
    plain = line_returns(seabed, origins, 0.0, math.radians(30.0), SETTINGS, rng, 0.0, 1.0, 0.001)
    assert len(plain.points) == 0
    box = line_returns(seabed, origins, 0.0, math.radians(30.0), SETTINGS, np.random.default_rng(1), 0.0, 1.0,
                       0.001, (scene, 1.0))
    p = box.points
    assert len(p) > 50
    lo, hi = world.min(axis=0), world.max(axis=0)
    # the steepest ray places each return lower and nearer than the face that gave it (the front slope); it never
    # stands higher than the top
    assert p[:, 2].min() >= lo[2] - 0.05
    assert np.all(np.abs(p[:, 1] - 0.3) < 5.0)
    assert np.median(np.linalg.norm(p[:, :2] - (lo[:2] + hi[:2]) / 2, axis=1)) < 2.0


@pytest.mark.slow
def test_views_on_rough_patches_are_recon_clusters_on_the_object() -> None:
    """Views of a box and a hemisphere: clusters centred within ``object_patch_offset_m`` of the object, standing
    about the object's height above the seabed depth recon gives them (the rough seabed's error, +- 0.3 m), no
    wider than recon's largest object; the same draw gives the same view."""
    for name in ("box", "hemisphere"):
        v, f = mesh_for(name)
        height = float(np.ptp(np.asarray(v)[:, 2]))
        got = [object_patch_view(name, np.asarray(v), f, SETTINGS, np.random.default_rng([9, i])) for i in range(6)]
        views = [g for g in got if g is not None]
        assert len(views) >= 3, name
        for pts, depth, heading, tilt in views:
            assert 0.0 <= heading < 360.0 and 20.0 <= tilt <= 45.0
            assert abs((depth - pts[:, 2].min()) - height) < 0.3 + 0.1 * height, (name, depth - pts[:, 2].min())
            assert np.max(np.ptp(pts[:, :2], axis=0)) <= 6.0
        again = object_patch_view(name, np.asarray(v), f, SETTINGS, np.random.default_rng([9, 0]))
        assert (got[0] is None) == (again is None)
        if got[0] is not None and again is not None:
            np.testing.assert_array_equal(got[0][0], again[0])


@pytest.mark.slow
def test_training_clouds_and_cache_keys() -> None:
    """``synthesize_object_patches`` gives training clouds of the stored shape, the same for the same seed; the
    flat synthesis's cache key ignores the patch settings (its clouds do not depend on them); held-out draws a
    third as many."""
    v, f = mesh_for("sphere")
    a, dirs = synthesize_object_patches("sphere", np.asarray(v), f, SETTINGS, 2)
    b, _ = synthesize_object_patches("sphere", np.asarray(v), f, SETTINGS, 2)
    assert a.shape == (2, SETTINGS.n_points, 3) and a.dtype == np.float32 and np.array_equal(a, b)
    assert dirs.shape == (2, 2)
    assert _cache_key("sphere", v, f, SETTINGS) == _cache_key("sphere", v, f, replace(SETTINGS, object_patch_views=0))
    assert heldout_settings(replace(SETTINGS, object_patch_views=150)).object_patch_views == 50
