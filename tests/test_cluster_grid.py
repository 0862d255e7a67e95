"""The grid DBSCAN (recon.cluster_grid) gives Open3D's labels: same clusters, numbering, border points, noise."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from recon.cluster import ClusterConfig, cluster, dbscan_labels
from recon.cluster_grid import grid_dbscan


def _cloud(seed: int, blobs: int, spread: float, scattered: int) -> np.ndarray:
    """Gaussian blobs (0.05-0.6 m standard deviations) and uniformly scattered points over ``spread`` m."""
    rng = np.random.default_rng(seed)
    parts = [rng.uniform(0, spread, 3) + rng.normal(0, rng.uniform(0.05, 0.6, 3), (int(rng.integers(5, 400)), 3))
             for _ in range(blobs)]
    parts.append(rng.uniform(0, spread, (scattered, 3)))
    return np.concatenate(parts) + [5000.0, -300.0, 20.0]  # far from the origin, as a survey is


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), blobs=st.integers(0, 8), spread=st.floats(0.5, 30.0),
       scattered=st.integers(0, 600), eps=st.floats(0.1, 1.5), min_points=st.integers(1, 20))
def test_same_labels_as_open3d(seed: int, blobs: int, spread: float, scattered: int, eps: float,
                               min_points: int) -> None:
    pts = _cloud(seed, blobs, spread, scattered)
    if len(pts) == 0:
        return
    theirs = dbscan_labels(pts, eps, min_points, "open3d")
    np.testing.assert_array_equal(dbscan_labels(pts, eps, min_points, "grid"), theirs)
    local = pts - pts.mean(axis=0)  # what dbscan_labels hands over
    np.testing.assert_array_equal(grid_dbscan(local, eps, min_points, max_pairs=0), theirs)  # the grid path
    np.testing.assert_array_equal(grid_dbscan(local, eps, min_points, max_pairs=np.inf), theirs)  # the pairs path


def test_dense_cloud_and_noise() -> None:
    rng = np.random.default_rng(4)
    dense = rng.normal(0, 0.05, (3000, 3))  # thousands of neighbours each: one cluster
    far = rng.uniform(100, 200, (50, 3))  # isolated: noise
    for max_pairs in (0, np.inf):
        labels = grid_dbscan(np.concatenate([far, dense]), 0.5, 8, max_pairs)
        assert set(labels[:50]) == {-1}
        assert set(labels[50:]) == {0}
    assert grid_dbscan(np.zeros((0, 3)), 0.5, 8).shape == (0,)
    assert list(grid_dbscan(np.zeros((3, 3)), 0.5, 8)) == [-1, -1, -1]  # 3 points < min_points


def test_border_point_joins_the_lowest_numbered_cluster() -> None:
    """A non-core point within eps of cores of two clusters: Open3D's first cluster (the lower core index) has it."""
    a = np.array([[0.0, 0.0, 0.0], [-0.1, 0.0, 0.0], [-0.2, 0.0, 0.0]])
    b = a * -1 + [1.0, 0.0, 0.0]  # 1.0 .. 1.2
    border = np.array([[0.5, 0.0, 0.0]])  # 0.5 from both nearest cores, within eps 0.55
    for order in ((a, b, border), (b, a, border), (border, b, a)):
        pts = np.concatenate(order)
        for max_pairs in (0, np.inf):
            np.testing.assert_array_equal(grid_dbscan(pts, 0.55, 3, max_pairs), dbscan_labels(pts, 0.55, 3, "open3d"))


@pytest.mark.parametrize("backend", ["grid", "open3d"])
def test_batch_clustering_backends_agree(backend: str) -> None:
    pts = _cloud(9, 6, 20.0, 300)
    t = np.linspace(0.0, 10.0, len(pts))
    ref = cluster(pts, t, ClusterConfig(backend="open3d"))
    objs = cluster(pts, t, ClusterConfig(backend=backend))  # type: ignore[arg-type]
    assert [o.n_points for o in objs] == [o.n_points for o in ref]
    assert all(np.array_equal(o.points, r.points) for o, r in zip(objs, ref, strict=True))
