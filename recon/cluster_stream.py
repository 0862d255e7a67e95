"""Streaming DBSCAN as the survey goes (:class:`StreamingClusterer`; the batch form and the definitions are in
:mod:`recon.cluster`): points are added as they come; :meth:`poll` clusters the points not yet emitted and
finalizes a cluster once the vehicle is past it: no new point for ``quiet_s`` seconds and the vehicle horizontally
farther than ``margin`` m from its bounding box. Its points then leave the working set. With ``fusion`` on (the
default), a cluster finalized next to an object emitted before is fused into it (:mod:`recon.fusion`) and the
object is emitted again with the same id; with it off, points arriving later within ``eps`` of a finalized object,
or within ``footprint_gap`` of its horizontal box, are counted in ``late_points`` and dropped (no duplicate
objects: a revisit from the next survey line does not make a second object); old noise points are pruned after
``noise_keep_s``. Where no object is revisited after it was finalized (and noise is not pruned under a growing
cluster), streaming returns exactly the batch objects. The finalized objects sit in a grid index
(:class:`recon.cluster_index.FinalizedIndex`): the late test looks only at those near the new points, so the cost
of a poll does not grow with the number of objects emitted before it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from recon.cluster import (
    F64,
    ClusterConfig,
    DetectedObject,
    Group,
    cluster_labels,
    extra_columns,
    label_groups,
    make_object,
)
from recon.cluster_index import FinalizedIndex
from recon.errors import ReconError
from recon.fusion import ObjectStore


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
        e = extra_columns(extra, p.shape[0])
        if self._ex and self._ex[0].shape[1] != e.shape[1]:
            raise ReconError(f"extra columns changed from {self._ex[0].shape[1]} to {e.shape[1]}")
        if len(self._final) and not self.config.fusion.enabled:  # only the objects near these points are tested
            late = self._final.late(p)
            self.late_points += int(late.sum())
            p, t, e = p[~late], t[~late], e[~late]
        self._pts.append(p)
        self._ts.append(t)
        self._ex.append(e)

    def near_emitted(self, points: ArrayLike) -> NDArray[np.bool_]:
        """Per point (N, 3): within ``eps`` of an emitted object's points or ``footprint_gap`` of its box."""
        return self._final.late(np.asarray(points, dtype=np.float64).reshape(-1, 3))

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
        groups = label_groups(p, t, cluster_labels(p, self.config), self.config.min_cluster_points, e)
        self._pts, self._ts, self._ex = [], [], []
        return self._emit(groups)
