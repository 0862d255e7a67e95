"""DBSCAN clustering of object points into :class:`DetectedObject`, in batch and streaming.

DBSCAN runs on a voxel grid by default (:func:`recon.cluster_grid.grid_dbscan`: Open3D's labels, to the
cluster number and border point, at a cost set by the points and cells rather than by the neighbour pairs),
Open3D (``PointCloud.cluster_dbscan``) and scikit-learn as the alternatives (the same definition: a core point
has >= ``min_points`` neighbours within ``eps``, itself included).
Clusters whose horizontal bounding boxes come within ``footprint_gap`` m are then merged
(:func:`merge_footprints`): objects rest side by side on the seabed, and a part seen apart from its
object (a reef's post, farther than ``eps`` from its top) shares its footprint.

Memory is bounded: a cloud larger than ``max_points`` is first reduced to one point per occupied
voxel (centroid, voxel grid anchored at the world origin, so batch and streaming see the same
voxels); labels go back to every original point through the voxel index.

Streaming, poll by poll as the survey goes: :class:`recon.cluster_stream.StreamingClusterer`.

Each point may carry ``extra`` columns (e.g. the sonar ray it came from, for the front-slope
correction); they travel with the point and end up in :attr:`DetectedObject.extra`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.errors import ReconError
from recon.fusion import FusionConfig
from recon.shadow import ShadowReading

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ClusterConfig:
    eps: float = 0.5  # m (reefs: frames and openings leave gaps of 0.3-0.5 m)
    min_points: int = 8
    min_cluster_points: int = 25  # smaller clusters are noise
    max_points: int = 200_000  # above this, voxel-downsample first
    voxel: float = 0.05  # m
    backend: Literal["grid", "open3d", "sklearn"] = "grid"
    quiet_s: float = 3.0
    margin: float = 2.0  # m
    noise_keep_s: float = 60.0
    footprint_gap: float = 0.8  # m: merge clusters whose horizontal boxes come this close (0 = off)
    fusion: FusionConfig = field(default_factory=FusionConfig)  # later passes fused into finalized objects


@dataclass(frozen=True, eq=False)
class DetectedObject:
    """One cluster: centroid (NED m, :func:`robust_centre`), axis-aligned extent (N, E, D sizes in m), points."""

    id: int
    centroid: F64
    extent: F64
    points: F64
    n_points: int
    t_first: float
    t_last: float
    times: F64 = field(repr=False, default_factory=lambda: np.zeros(0))
    extra: F64 = field(repr=False, default_factory=lambda: np.zeros((0, 0)))  # per-point columns
    seabed_depth: float = float("nan")  # m, NED: the seabed under the object (recon's model of the poll)
    passes: tuple[tuple[float, float], ...] = ()  # time spans (s) of the passes fused into it (recon.fusion)
    shadow_height: float = float("nan")  # m: its top over the seabed from its acoustic shadows (recon.shadow)
    shadow: ShadowReading = field(default_factory=ShadowReading)  # its shadows' and the seabed's (recon.shadow)

    @property
    def size(self) -> F64:
        return self.extent

    def to_dict(self) -> dict[str, Any]:
        """The geometric part of a detections.jsonl line (class and score come from classify)."""
        return {"id": self.id, "position_ned": [float(v) for v in self.centroid],
                "size": [float(v) for v in self.extent], "n_points": self.n_points,
                "t_first": self.t_first, "t_last": self.t_last, "passes": [list(p) for p in self.passes]}


def voxel_downsample(points: F64, voxel: float) -> tuple[F64, NDArray[np.int64]]:
    """One centroid per occupied voxel and, per input point, the index of its voxel."""
    cells = np.floor(points / voxel).astype(np.int64)
    _, inv, counts = np.unique(cells, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    cent = np.stack([np.bincount(inv, weights=points[:, k]) for k in range(3)], axis=1) / counts[:, None]
    return cent, inv


def dbscan_labels(points: ArrayLike, eps: float, min_points: int,
                  backend: Literal["grid", "open3d", "sklearn"] = "grid") -> NDArray[np.int64]:
    """DBSCAN labels (-1 = noise) of (N, 3) points."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0, np.int64)
    if not np.all(np.isfinite(p)):  # one NaN would poison the mean below and silently lose every cluster
        bad = ~np.isfinite(p).all(axis=1)
        raise ReconError(f"cannot cluster {int(bad.sum())} non-finite point(s) (first at index {int(np.argmax(bad))})")
    local = p - p.mean(axis=0)  # keep the neighbour search well conditioned far from the origin
    if backend == "grid":
        from recon.cluster_grid import grid_dbscan

        return grid_dbscan(local, eps, min_points)
    if backend == "sklearn":
        from sklearn.cluster import DBSCAN

        return np.asarray(DBSCAN(eps=eps, min_samples=min_points).fit(local).labels_, dtype=np.int64)
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(local))
    labels = pcd.cluster_dbscan(eps=eps, min_points=min_points, print_progress=False)
    return np.asarray(labels, dtype=np.int64)


Group = tuple[F64, F64, F64]  # points, times, extra columns


def extra_columns(extra: ArrayLike | None, n: int) -> F64:
    if extra is None:
        return np.zeros((n, 0))
    e = np.asarray(extra, dtype=np.float64)
    return e.reshape(n, -1) if n else e.reshape(0, e.shape[-1] if e.ndim == 2 else 0)


def label_groups(points: F64, times: F64, labels: NDArray[np.int64], min_size: int, extra: F64) -> list[Group]:
    out: list[Group] = []
    if labels.size == 0:
        return out
    order = np.argsort(labels, kind="stable")
    lab = labels[order]
    starts = np.flatnonzero(np.r_[True, lab[1:] != lab[:-1]])
    for s, e in zip(starts, np.r_[starts[1:], lab.size], strict=True):
        if lab[s] < 0 or e - s < min_size:
            continue
        idx = np.sort(order[s:e])
        out.append((points[idx], times[idx], extra[idx]))
    return out


def robust_centre(pts: F64, q: float = 2.0) -> F64:
    """Centre of the box between the ``q``-th and (100 - q)-th percentiles of each axis.

    The sonar sees an object's near side and top, from as many frames as it approaches, so the
    point mean leans towards the vehicle (0.25 m on the demo scene with true navigation); the
    robust box centre does not weigh by point density (0.18 m), and the percentiles ignore strays.
    :class:`recon.reconstructor.Reconstructor` then moves it by the far side it could not see (:mod:`recon.far_side`).
    """
    lo, hi = np.percentile(pts, [q, 100.0 - q], axis=0)
    return np.asarray(0.5 * (lo + hi), dtype=np.float64)


def make_object(i: int, pts: F64, ts: F64, extra: F64 | None = None,
                passes: tuple[tuple[float, float], ...] | None = None) -> DetectedObject:
    """A :class:`DetectedObject` from its points (centroid: :func:`robust_centre`, extent: min-max box)."""
    return DetectedObject(id=i, centroid=robust_centre(pts), extent=pts.max(axis=0) - pts.min(axis=0),
                          points=pts, n_points=int(pts.shape[0]), t_first=float(ts.min()),
                          t_last=float(ts.max()), times=ts, extra=extra_columns(extra, pts.shape[0]),
                          passes=passes if passes is not None else ((float(ts.min()), float(ts.max())),))


def merge_footprints(points: F64, labels: NDArray[np.int64], gap: float) -> NDArray[np.int64]:
    """Merge clusters whose horizontal bounding boxes come within ``gap`` m of each other.

    Objects rest on the seabed side by side, never on top of each other: a part seen apart from its
    object (a reef's post below its top, farther than ``eps`` from it) still shares its footprint.
    """
    ids = np.unique(labels[labels >= 0])
    if ids.size < 2 or gap <= 0:
        return labels
    lo = np.stack([points[labels == i, :2].min(axis=0) for i in ids])
    hi = np.stack([points[labels == i, :2].max(axis=0) for i in ids])
    sep = np.maximum(0.0, np.maximum(lo[:, None, :] - hi[None, :, :], lo[None, :, :] - hi[:, None, :]))
    near = np.linalg.norm(sep, axis=2) <= gap
    root = np.arange(ids.size)
    for i, j in zip(*np.nonzero(np.triu(near, 1)), strict=True):  # union-find, few clusters
        ri, rj = int(root[i]), int(root[j])
        while root[ri] != ri:
            ri = int(root[ri])
        while root[rj] != rj:
            rj = int(root[rj])
        root[max(ri, rj)] = min(ri, rj)
    for k in range(ids.size):
        r = k
        while root[r] != r:
            r = int(root[r])
        root[k] = r
    lut = np.full(int(ids.max()) + 1, -1, np.int64)
    lut[ids] = ids[root]
    return np.where(labels >= 0, lut[np.maximum(labels, 0)], labels)


def cluster_labels(points: F64, cfg: ClusterConfig) -> NDArray[np.int64]:
    """Labels per point, voxel-downsampling first when the cloud is larger than ``max_points``."""
    if points.shape[0] > cfg.max_points:
        cent, inv = voxel_downsample(points, cfg.voxel)
        labels = dbscan_labels(cent, cfg.eps, cfg.min_points, cfg.backend)[inv]
    else:
        labels = dbscan_labels(points, cfg.eps, cfg.min_points, cfg.backend)
    return merge_footprints(points, labels, cfg.footprint_gap)


def cluster(points: ArrayLike, times: ArrayLike, config: ClusterConfig | None = None,
            extra: ArrayLike | None = None) -> list[DetectedObject]:
    """Batch clustering: objects ordered by first sighting (then north), ids 0, 1, ..."""
    cfg = config or ClusterConfig()
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    groups = label_groups(p, t, cluster_labels(p, cfg), cfg.min_cluster_points, extra_columns(extra, p.shape[0]))
    groups.sort(key=lambda g: (float(g[1].min()), float(g[0][:, 0].mean())))
    return [make_object(i, *g) for i, g in enumerate(groups)]
