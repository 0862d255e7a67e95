"""The finalized objects of a :class:`recon.cluster_stream.StreamingClusterer`, indexed for the late-point test.

A point arriving after its object was finalized is "late" when it lies within ``eps`` (3D) of one of
the object's points, or when its horizontal position comes within ``gap`` m of the object's
horizontal bounding box (what :func:`recon.cluster.merge_footprints` would have merged). Both tests
only ever concern objects whose horizontal box, grown by ``reach = max(eps, gap)`` on every side,
contains the point (a 3D distance bounds the horizontal one). So each finalized object is entered,
once, into the cells of a horizontal grid that its grown box touches, keeps its own KD-tree, and its
box goes into one growing array; a query looks up the cells of the new points and tests only the
objects found there. The cost of a query is then set by the objects near the vehicle, not by how
many were finalized before (a whole mission's cost grows linearly with its length, not
quadratically); the answers are the same as testing every finalized object.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

F64 = NDArray[np.float64]


class FinalizedIndex:
    """Finalized objects' points (one KD-tree each) and horizontal boxes on a grid of ``cell`` m."""

    def __init__(self, eps: float, gap: float, cell: float | None = None) -> None:
        self.eps = float(eps)
        self.gap = float(gap) if gap > 0 else 0.0
        self.reach = max(self.eps, self.gap)
        self.cell = float(cell) if cell else max(4.0, 4.0 * self.reach)
        self._lo = np.zeros((16, 2))
        self._hi = np.zeros((16, 2))
        self._trees: list[cKDTree] = []
        self._grid: dict[tuple[int, int], list[int]] = {}

    def __len__(self) -> int:
        return len(self._trees)

    def add(self, points: F64) -> None:
        """Enter one finalized object (its (n, 3) points, n >= 1)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        i = len(self._trees)
        if i == self._lo.shape[0]:  # grow the box arrays by doubling: amortized constant per object
            self._lo = np.concatenate([self._lo, np.zeros_like(self._lo)])
            self._hi = np.concatenate([self._hi, np.zeros_like(self._hi)])
        lo, hi = p[:, :2].min(axis=0), p[:, :2].max(axis=0)
        self._lo[i], self._hi[i] = lo, hi
        self._trees.append(cKDTree(p))
        grow = self.reach * (1.0 + 1e-6) + 1e-9  # a point on the edge of the grown box still finds it
        c0 = np.floor((lo - grow) / self.cell).astype(np.int64)
        c1 = np.floor((hi + grow) / self.cell).astype(np.int64)
        for cx in range(int(c0[0]), int(c1[0]) + 1):
            for cy in range(int(c0[1]), int(c1[1]) + 1):
                self._grid.setdefault((cx, cy), []).append(i)

    def late(self, points: F64) -> NDArray[np.bool_]:
        """Per point: within ``eps`` of a finalized object's points or within ``gap`` of its box."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        out = np.zeros(p.shape[0], dtype=bool)
        if not self._trees or p.shape[0] == 0:
            return out
        cells = np.floor(p[:, :2] / self.cell).astype(np.int64)
        uniq, inv = np.unique(cells, axis=0, return_inverse=True)
        inv = inv.ravel()
        for k, (cx, cy) in enumerate(uniq.tolist()):
            ids = self._grid.get((cx, cy))
            if not ids:
                continue
            sel = np.flatnonzero(inv == k)
            q = p[sel]
            hit = np.zeros(sel.size, dtype=bool)
            if self.gap > 0:  # the batch path would merge them (merge_footprints)
                idx = np.asarray(ids)
                lo, hi = self._lo[idx], self._hi[idx]
                sep = np.maximum(0.0, np.maximum(lo[None] - q[:, None, :2], q[:, None, :2] - hi[None]))
                hit |= np.any(np.linalg.norm(sep, axis=2) <= self.gap, axis=1)
            for i in ids:
                rest = np.flatnonzero(~hit)
                if rest.size == 0:
                    break
                d, _ = self._trees[i].query(q[rest], distance_upper_bound=self.eps)
                hit[rest[np.isfinite(d)]] = True
            out[sel] = hit
        return out
