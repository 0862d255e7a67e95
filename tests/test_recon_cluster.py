"""DBSCAN clustering (Open3D / scikit-learn), batch == streaming, voxel bound, PLY output."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import open3d as o3d
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from recon.cluster import ClusterConfig, cluster, dbscan_labels, voxel_downsample
from recon.cluster_stream import StreamingClusterer
from recon.ply import write_cloud, write_objects, write_ply

CENTRES = np.array([[10.0, 0.5, 19.6], [18.0, -1.0, 19.5], [26.0, 1.2, 19.7], [35.0, 0.0, 19.4],
                    [44.0, -0.8, 19.6], [52.0, 1.0, 19.5]])


def _scene(rng: np.random.Generator, offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Six blobs (one object each) + sparse noise; time = when a 1 m/s vehicle would see them."""
    pts = [c + rng.normal(0, [0.35, 0.25, 0.12], size=(400, 3)) for c in CENTRES]
    noise = np.column_stack([rng.uniform(0, 60, 300), rng.uniform(-2, 2, 300), rng.uniform(19, 20, 300)])
    p = np.concatenate([*pts, noise])
    t = p[:, 0] - 7.0 + rng.uniform(-0.5, 0.5, p.shape[0])  # seen ~7 m ahead of the vehicle
    order = np.argsort(t)
    p, t = p[order], t[order]
    return (p if offset is None else p + offset), t


def _key(objs: list) -> list[tuple[int, tuple[float, ...]]]:
    return sorted((o.n_points, tuple(np.round(o.centroid, 9))) for o in objs)


def test_one_cluster_per_object() -> None:
    p, t = _scene(np.random.default_rng(0))
    objs = cluster(p, t)
    assert len(objs) == 6
    cents = np.array([o.centroid for o in objs])
    # robust box centre (2-98 % percentiles): noisier than the mean on Gaussian blobs with stray noise
    assert np.abs(cents - CENTRES).max() < 0.15  # ordered by first sighting = by north here
    assert [o.id for o in objs] == list(range(6))
    for o in objs:
        assert o.n_points == o.points.shape[0] >= 380
        assert np.all(o.extent > 0) and o.t_first <= o.t_last
        assert set(o.to_dict()) == {"id", "position_ned", "size", "n_points", "t_first", "t_last", "passes"}


def test_open3d_and_sklearn_agree() -> None:
    p, _ = _scene(np.random.default_rng(1))
    a = dbscan_labels(p, 0.3, 8, "open3d")
    b = dbscan_labels(p, 0.3, 8, "sklearn")
    assert np.array_equal(a < 0, b < 0)
    pairs = {(int(x), int(y)) for x, y in zip(a[a >= 0], b[b >= 0], strict=True)}
    assert len(pairs) == len(set(a[a >= 0])) == len(set(b[b >= 0]))  # the same partition


def test_batch_equals_streaming() -> None:
    p, t = _scene(np.random.default_rng(2))
    batch = cluster(p, t)
    sc = StreamingClusterer()
    streamed = []
    for now in np.arange(0.0, 60.0, 1.0):  # 1 Hz polls, vehicle at x = now
        sel = (t >= now - 1.0) & (t < now)
        sc.add(p[sel], t[sel])
        out = sc.poll([now, 0.0, 15.0], now)
        for o in out:  # final only once the vehicle is past it
            assert now - o.t_last >= sc.config.quiet_s
        streamed += out
    streamed += sc.flush()
    assert len(streamed) == 6
    assert _key(streamed) == _key(batch)
    assert sc.late_points == 0
    assert len([o for o in streamed if o.t_last < 50]) >= 4  # most were final during the mission


def test_voxel_bound_and_far_from_origin() -> None:
    p, t = _scene(np.random.default_rng(3), offset=np.array([7e5, -3e5, 0.0]))
    cent, inv = voxel_downsample(p, 0.05)
    assert cent.shape[0] <= p.shape[0] and inv.shape == (p.shape[0],)
    objs = cluster(p, t, ClusterConfig(max_points=500, voxel=0.05))
    assert len(objs) == 6
    shifted = CENTRES + np.array([7e5, -3e5, 0.0])
    assert np.abs(np.array([o.centroid for o in objs]) - shifted).max() < 0.15  # robust box centre, stray noise


def test_empty_inputs() -> None:
    assert cluster(np.zeros((0, 3)), np.zeros(0)) == []
    sc = StreamingClusterer()
    assert sc.poll([0, 0, 0], 0.0) == [] and sc.flush() == []


@pytest.mark.parametrize("fmt", ["binary", "ascii"])
def test_ply_round_trip(tmp_path: Path, fmt: str) -> None:
    p, t = _scene(np.random.default_rng(4), offset=np.array([1e6, 2e5, 0.0]))
    objs = cluster(p, t)
    paths = write_objects(tmp_path / "objects", objs, fmt=fmt)  # type: ignore[arg-type]
    assert sorted(paths) == [o.id for o in objs]
    back = np.asarray(o3d.io.read_point_cloud(paths[objs[0].id]).points)
    assert np.allclose(back, objs[0].points, atol=1e-6 if fmt == "ascii" else 0.0)
    cloud = write_cloud(tmp_path / "cloud.ply", objs, fmt=fmt)  # type: ignore[arg-type]
    pc = o3d.io.read_point_cloud(cloud)
    assert len(pc.points) == sum(o.n_points for o in objs) and pc.has_colors()
    assert write_ply(tmp_path / "empty.ply", np.zeros((0, 3))).read_bytes().startswith(b"ply\n")


def test_footprint_merge_joins_a_part_seen_apart() -> None:
    rng = np.random.default_rng(4)
    top = np.array([15.0, 4.0, 18.8]) + rng.normal(0, [0.3, 0.4, 0.02], (300, 3))  # a reef's top
    post = np.array([14.0, 4.8, 19.7]) + rng.normal(0, [0.03, 0.05, 0.15], (40, 3))  # its post, 0.5 m off
    other = np.array([19.0, 4.0, 19.5]) + rng.normal(0, 0.2, (200, 3))  # another object, 3 m away
    p = np.concatenate([top, post, other])
    t = np.zeros(p.shape[0])
    apart = cluster(p, t, ClusterConfig(footprint_gap=0.0))
    merged = cluster(p, t, ClusterConfig(footprint_gap=0.8))
    assert len(apart) == 3 and len(merged) == 2
    assert sorted(o.n_points for o in merged) == [200, 340]


def _late_brute(objs: list[np.ndarray], p: np.ndarray, eps: float, gap: float) -> np.ndarray:
    """The late test against every finalized object (what the clusterer did before its grid index)."""
    from scipy.spatial import cKDTree

    d, _ = cKDTree(np.concatenate(objs)).query(p, distance_upper_bound=eps)
    late = np.isfinite(d)
    if gap > 0:
        lo = np.array([o[:, :2].min(axis=0) for o in objs])
        hi = np.array([o[:, :2].max(axis=0) for o in objs])
        sep = np.maximum(0.0, np.maximum(lo[None] - p[:, None, :2], p[:, None, :2] - hi[None]))
        late |= np.any(np.linalg.norm(sep, axis=2) <= gap, axis=1)
    return late


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.sampled_from([0.0, 0.8, 2.5]), st.sampled_from([0.3, 0.5, 1.0]),
       st.sampled_from([0.0, 1e6]), st.sampled_from([None, 0.5, 3.0]))
@pytest.mark.slow
def test_finalized_index_matches_brute_force(seed: int, gap: float, eps: float, far: float,
                                             cell: float | None) -> None:
    from recon.cluster_index import FinalizedIndex

    rng = np.random.default_rng(seed)
    off = np.array([far, -far, 0.0])
    objs = [c + off + rng.normal(0, rng.uniform(0.05, 1.5, 3), (int(rng.integers(1, 60)), 3))
            for c in np.column_stack([rng.uniform(0, 60, 25), rng.uniform(-6, 6, 25), np.full(25, 19.5)])]
    idx = FinalizedIndex(eps, gap, cell)
    for o in objs:
        idx.add(o)
    p = off + np.column_stack([rng.uniform(-3, 63, 3000), rng.uniform(-9, 9, 3000), rng.uniform(18, 21, 3000)])
    p = np.concatenate([p, objs[0] + rng.normal(0, 0.2, objs[0].shape)])  # some certainly late
    got, ref = idx.late(p), _late_brute(objs, p, eps, gap)
    assert ref.any() and not ref.all()
    assert np.array_equal(got, ref)


def test_streaming_revisits_fused_into_the_same_objects() -> None:
    """A second pass over finalized objects adds no object: each is emitted again with the same id, with
    both passes' points (recon.fusion)."""
    p, t = _scene(np.random.default_rng(5))
    sc = StreamingClusterer()
    out = []
    for rnd, shift in ((0, 0.0), (1, 70.0)):  # the same points again, 70 s later (the next survey line)
        for now in np.arange(0.0, 62.0, 1.0):
            sel = (t >= now - 1.0) & (t < now)
            sc.add(p[sel], t[sel] + shift)
            out += sc.poll([now, 0.0 if rnd == 0 else 3.0, 15.0], now + shift)
    out += sc.flush()
    first = {o.id: o for o in out[:6]}
    assert len(first) == 6 and len(out) == 12
    for o in out[6:]:
        assert o.n_points == 2 * first[o.id].n_points and len(o.passes) == 2
        assert o.passes[1][0] >= 70.0
    assert sc.fused_points == sum(o.n_points for o in first.values())


def test_streaming_revisits_dropped_as_late_without_fusion() -> None:
    """With fusion off, a second pass adds no object; its points are counted as late and dropped."""
    from recon.fusion import FusionConfig

    p, t = _scene(np.random.default_rng(5))
    sc = StreamingClusterer(ClusterConfig(fusion=FusionConfig(enabled=False)))
    out = []
    for rnd, shift in ((0, 0.0), (1, 70.0)):  # the same points again, 70 s later (the next survey line)
        for now in np.arange(0.0, 62.0, 1.0):
            sel = (t >= now - 1.0) & (t < now)
            sc.add(p[sel], t[sel] + shift)
            out += sc.poll([now, 0.0 if rnd == 0 else 3.0, 15.0], now + shift)
    out += sc.flush()
    assert len(out) == 6
    assert sc.late_points > 6 * 380
