"""Fusion across passes: every point of one physical object, from every line and pass, in one cloud.

A survey sees an object from several lines (adjacent swaths overlap, lines run both ways) and an
object longer than one swath in parts. The streaming clusterer (:class:`recon.cluster_stream.StreamingClusterer`)
finalizes an object once the vehicle is past it; a later pass that sees it again makes a new cluster.
:class:`ObjectStore` keeps the finalized objects; a new cluster whose horizontal box comes within
``gap`` m of a stored object's box is the same object seen again: it is aligned to the stored cloud
(:func:`align_offset`: dead reckoning drifts between lines) and merged into it, and the object is emitted
again with the same id (an update). Each object records its passes (time spans of the points of each
merge) and the offset applied to each.

Alignment (:func:`align_offset`): a horizontal translation only (the drift between two lines a minute
apart is a shift; heading drift over an object's 3 m is millimetres), estimated on a target: the top of
the object (the points within ``upper_fraction`` of its height from its highest point), which every pass
sees whatever side it comes from, while the flanks are seen only from the side of each pass. The shift
is the difference of the median horizontal positions of the two tops; it is applied only when, once
shifted, at least ``min_pairs`` top points of the new view lie within ``max_pair`` m of the stored top
and it is smaller than ``max_shift`` m (a drift, not a different part); otherwise the views are merged
as they are (a pipe seen in two halves has two different tops).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class FusionConfig:
    enabled: bool = True
    upper_fraction: float = 0.3  # the top: within this fraction of the height below the highest point
    max_pair: float = 0.4  # m
    min_pairs: int = 12
    max_shift: float = 0.6  # m


def align_offset(stored: F64, new: F64, cfg: FusionConfig) -> F64:
    """Horizontal (north, east) shift to add to ``new`` to align it with ``stored`` (see the module doc)."""

    def top(p: F64) -> F64:
        z = p[:, 2]  # NED: smaller z is higher
        return p[z <= z.min() + cfg.upper_fraction * (z.max() - z.min())]

    a, b = top(stored), top(new)
    if a.shape[0] < cfg.min_pairs or b.shape[0] < cfg.min_pairs:
        return np.zeros(2)
    shift = np.median(a[:, :2], axis=0) - np.median(b[:, :2], axis=0)
    tree = cKDTree(a[:, :2])
    d, _ = tree.query(b[:, :2] + shift, distance_upper_bound=cfg.max_pair)
    if int(np.isfinite(d).sum()) < cfg.min_pairs or float(np.linalg.norm(shift)) > cfg.max_shift:
        return np.zeros(2)  # the tops do not overlap once shifted, or the shift is not a drift
    return np.asarray(shift, dtype=np.float64)


@dataclass
class StoredObject:
    points: F64
    times: F64
    extra: F64
    passes: list[tuple[float, float]] = field(default_factory=list)
    offsets: list[tuple[float, float]] = field(default_factory=list)


class ObjectStore:
    """Finalized objects by id with their horizontal boxes (see the module docstring)."""

    def __init__(self, gap: float, config: FusionConfig | None = None) -> None:
        self.gap = float(gap)
        self.config = config or FusionConfig()
        self.objects: dict[int, StoredObject] = {}
        self._ids: list[int] = []
        self._lo = np.zeros((0, 2))
        self._hi = np.zeros((0, 2))

    def __len__(self) -> int:
        return len(self.objects)

    def _box(self, i: int, p: F64) -> None:
        lo, hi = p[:, :2].min(axis=0), p[:, :2].max(axis=0)
        if i in self._ids:
            k = self._ids.index(i)
            self._lo[k], self._hi[k] = lo, hi
        else:
            self._ids.append(i)
            self._lo = np.vstack([self._lo, lo])
            self._hi = np.vstack([self._hi, hi])

    def nearest(self, points: F64) -> int | None:
        """Id of the stored object whose box comes nearest (within ``gap``) to the box of ``points``."""
        if not self._ids or not self.config.enabled:
            return None
        lo, hi = points[:, :2].min(axis=0), points[:, :2].max(axis=0)
        sep = np.maximum(0.0, np.maximum(self._lo - hi, lo - self._hi))
        d = np.linalg.norm(sep, axis=1)
        k = int(np.argmin(d))
        return self._ids[k] if d[k] <= self.gap else None

    def add(self, i: int, points: F64, times: F64, extra: F64) -> StoredObject:
        obj = StoredObject(points, times, extra, [(float(times.min()), float(times.max()))], [(0.0, 0.0)])
        self.objects[i] = obj
        self._box(i, points)
        return obj

    def fuse(self, i: int, points: F64, times: F64, extra: F64) -> StoredObject:
        """Align ``points`` (a later view) to object ``i`` and merge them into it."""
        obj = self.objects[i]
        shift = align_offset(obj.points, points, self.config)
        moved = points.copy()
        moved[:, :2] += shift
        obj.points = np.concatenate([obj.points, moved])
        obj.times = np.concatenate([obj.times, times])
        obj.extra = np.concatenate([obj.extra, extra])
        obj.passes.append((float(times.min()), float(times.max())))
        obj.offsets.append((float(shift[0]), float(shift[1])))
        self._box(i, obj.points)
        return obj
