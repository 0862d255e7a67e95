"""DBSCAN clustering of object points into :class:`DetectedObject`, in batch and streaming.

DBSCAN runs in Open3D (``PointCloud.cluster_dbscan``) by default, scikit-learn as the alternative
(the same definition: a core point has >= ``min_points`` neighbours within ``eps``, itself included).
Clusters whose horizontal bounding boxes come within ``footprint_gap`` m are then merged
(:func:`merge_footprints`): objects rest side by side on the seabed, and a part seen apart from its
object (a reef's post, farther than ``eps`` from its top) shares its footprint.

Memory is bounded: a cloud larger than ``max_points`` is first reduced to one point per occupied
voxel (centroid, voxel grid anchored at the world origin, so batch and streaming see the same
voxels); labels go back to every original point through the voxel index.

Streaming (:class:`StreamingClusterer`): points are added as they come; :meth:`poll` clusters the
points not yet emitted and finalizes a cluster once the vehicle is past it: no new point for
``quiet_s`` seconds and the vehicle horizontally farther than ``margin`` m from its bounding box.
Its points then leave the working set. Points arriving later within ``eps`` of a finalized object,
or within ``footprint_gap`` of its horizontal box, are counted in ``late_points`` and dropped (no
duplicate objects: a revisit from the next survey line does not make a second object); old noise
points are pruned after ``noise_keep_s``. Where no object is revisited after it was finalized (and
noise is not pruned under a growing cluster), streaming returns exactly the batch objects. The
finalized objects sit in a grid index (:class:`recon.cluster_index.FinalizedIndex`): the late test
looks only at those near the new points, so the cost of a poll does not grow with the number of
objects emitted before it.

Each point may carry ``extra`` columns (e.g. the sonar ray it came from, for the front-slope
correction); they travel with the point and end up in :attr:`DetectedObject.extra`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.cluster_index import FinalizedIndex
from recon.errors import ReconError
from recon.fusion import FusionConfig, ObjectStore

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ClusterConfig:
    eps: float = 0.5  # m (reefs: frames and openings leave gaps of 0.3-0.5 m)
    min_points: int = 8
    min_cluster_points: int = 25  # smaller clusters are noise
    max_points: int = 200_000  # above this, voxel-downsample first
    voxel: float = 0.05  # m
    backend: Literal["open3d", "sklearn"] = "open3d"
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
                  backend: Literal["open3d", "sklearn"] = "open3d") -> NDArray[np.int64]:
    """DBSCAN labels (-1 = noise) of (N, 3) points."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return np.zeros(0, np.int64)
    if not np.all(np.isfinite(p)):  # one NaN would poison the mean below and silently lose every cluster
        bad = ~np.isfinite(p).all(axis=1)
        raise ReconError(f"cannot cluster {int(bad.sum())} non-finite point(s) (first at index {int(np.argmax(bad))})")
    local = p - p.mean(axis=0)  # keep the neighbour search well conditioned far from the origin
    if backend == "sklearn":
        from sklearn.cluster import DBSCAN

        return np.asarray(DBSCAN(eps=eps, min_samples=min_points).fit(local).labels_, dtype=np.int64)
    import open3d as o3d

    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(local))
    labels = pcd.cluster_dbscan(eps=eps, min_points=min_points, print_progress=False)
    return np.asarray(labels, dtype=np.int64)


Group = tuple[F64, F64, F64]  # points, times, extra columns


def _extra(extra: ArrayLike | None, n: int) -> F64:
    if extra is None:
        return np.zeros((n, 0))
    e = np.asarray(extra, dtype=np.float64)
    return e.reshape(n, -1) if n else e.reshape(0, e.shape[-1] if e.ndim == 2 else 0)


def _objects(points: F64, times: F64, labels: NDArray[np.int64], min_size: int, extra: F64) -> list[Group]:
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
    :class:`recon.pipeline.Reconstructor` then moves it by the far side it could not see (:mod:`recon.far_side`).
    """
    lo, hi = np.percentile(pts, [q, 100.0 - q], axis=0)
    return np.asarray(0.5 * (lo + hi), dtype=np.float64)


def make_object(i: int, pts: F64, ts: F64, extra: F64 | None = None,
                passes: tuple[tuple[float, float], ...] | None = None) -> DetectedObject:
    """A :class:`DetectedObject` from its points (centroid: :func:`robust_centre`, extent: min-max box)."""
    return DetectedObject(id=i, centroid=robust_centre(pts), extent=pts.max(axis=0) - pts.min(axis=0),
                          points=pts, n_points=int(pts.shape[0]), t_first=float(ts.min()),
                          t_last=float(ts.max()), times=ts, extra=_extra(extra, pts.shape[0]),
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
    groups = _objects(p, t, cluster_labels(p, cfg), cfg.min_cluster_points, _extra(extra, p.shape[0]))
    groups.sort(key=lambda g: (float(g[1].min()), float(g[0][:, 0].mean())))
    return [make_object(i, *g) for i, g in enumerate(groups)]


class StreamingClusterer:
    """Clusters as the survey goes; objects are emitted once the vehicle is past them."""

    def __init__(self, config: ClusterConfig | None = None) -> None:
        self.config = config or ClusterConfig()
        self._pts: list[F64] = []
        self._ts: list[F64] = []
        self._ex: list[F64] = []
        self._final = FinalizedIndex(self.config.eps, self.config.footprint_gap)
        self._store = ObjectStore(self.config.footprint_gap, self.config.fusion)
        self._next_id = 0
        self.late_points = 0
        self.fused_points = 0
        self.pruned_points = 0

    def add(self, points: ArrayLike, times: ArrayLike, extra: ArrayLike | None = None) -> None:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        t = np.broadcast_to(np.asarray(times, dtype=np.float64), (p.shape[0],)).copy()
        if p.shape[0] == 0:
            return
        e = _extra(extra, p.shape[0])
        if self._ex and self._ex[0].shape[1] != e.shape[1]:
            raise ReconError(f"extra columns changed from {self._ex[0].shape[1]} to {e.shape[1]}")
        if len(self._final) and not self.config.fusion.enabled:  # only the objects near these points are tested
            late = self._final.late(p)
            self.late_points += int(late.sum())
            p, t, e = p[~late], t[~late], e[~late]
        self._pts.append(p)
        self._ts.append(t)
        self._ex.append(e)

    def bounds(self) -> tuple[F64, F64] | None:
        """Horizontal box (lo, hi) of the points not yet emitted; None when there are none."""
        p = self._active()[0]
        if p.shape[0] == 0:
            return None
        return p[:, :2].min(axis=0), p[:, :2].max(axis=0)

    @property
    def n_active(self) -> int:
        return int(sum(a.shape[0] for a in self._pts))

    def _active(self) -> tuple[F64, F64, F64]:
        if not self._pts:
            return np.zeros((0, 3)), np.zeros(0), np.zeros((0, 0))
        p, t, e = np.concatenate(self._pts), np.concatenate(self._ts), np.concatenate(self._ex)
        self._pts, self._ts, self._ex = [p], [t], [e]
        return p, t, e

    def poll(self, vehicle_position: ArrayLike, t_now: float) -> list[DetectedObject]:
        """Finalize and return the clusters the vehicle is past (see the module docstring)."""
        cfg = self.config
        p, t, e = self._active()
        if p.shape[0] == 0:
            return []
        veh = np.asarray(vehicle_position, dtype=np.float64).reshape(3)
        labels = cluster_labels(p, cfg)
        keep = np.ones(p.shape[0], bool)
        stale_before = t_now - cfg.noise_keep_s
        done: list[Group] = []
        for lab in np.unique(labels[labels >= 0]):
            idx = np.flatnonzero(labels == lab)
            newest = t[idx].max()
            if idx.size < cfg.min_cluster_points:
                if newest < stale_before:  # a small cluster that stopped growing long ago
                    labels[idx] = -1
                continue
            lo, hi = p[idx, :2].min(axis=0), p[idx, :2].max(axis=0)
            gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - veh[:2], veh[:2] - hi)))
            if t_now - newest >= cfg.quiet_s and gap >= cfg.margin:
                done.append((p[idx], t[idx], e[idx]))
                keep[idx] = False
        stale = (labels < 0) & (t < stale_before)
        self.pruned_points += int(stale.sum())
        keep &= ~stale
        self._pts, self._ts, self._ex = [p[keep]], [t[keep]], [e[keep]]
        return self._emit(done)

    def _emit(self, done: list[Group]) -> list[DetectedObject]:
        """New objects get the next id; a cluster next to a finalized object is fused into it and the
        object is emitted again, same id, with every pass's points (:mod:`recon.fusion`)."""
        done.sort(key=lambda g: (float(g[1].min()), float(g[0][:, 0].mean())))
        out: dict[int, DetectedObject] = {}
        for pts, ts, ex in done:
            i = self._store.nearest(pts)
            if i is None:
                i = self._next_id
                self._next_id += 1
                obj = self._store.add(i, pts, ts, ex)
                self._final.add(pts)
            else:
                obj = self._store.fuse(i, pts, ts, ex)
                self.fused_points += int(pts.shape[0])
            out[i] = make_object(i, obj.points, obj.times, obj.extra, tuple(obj.passes))
        return list(out.values())

    def flush(self) -> list[DetectedObject]:
        """End of mission: every remaining cluster is final."""
        p, t, e = self._active()
        groups = _objects(p, t, cluster_labels(p, self.config), self.config.min_cluster_points, e)
        self._pts, self._ts, self._ex = [], [], []
        return self._emit(groups)


def single_thread_env() -> None:
    """Ask OpenMP (Open3D) for one thread; effective only before Open3D is first imported."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
