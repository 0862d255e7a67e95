"""What recon does with the seabed fitted for a poll: object points, the seabed under each object, clutter.

:func:`object_points` keeps the points that stand above the seabed model by its threshold (the tiled planes:
``seabed.min_height``; the texture grid, :class:`recon.seabed_texture.TexturedSeabed`: the threshold from the
measured seabed noise), and, with the texture grid, an object's flanks (:func:`flanks`). :func:`on_seabed`
gives each finalized object the depth of the seabed under it and says "not an object" to a cluster wider
than any object (:data:`recon.target_envelope.MAX_OBJECT_EXTENT_M`) or whose top does not stand high enough
above the tiled planes (:data:`recon.target_envelope.MIN_OBJECT_HEIGHT_M`, lower on a smooth seabed:
:data:`TOP_OVER_THRESHOLD`). The size limits are those of the target envelope (:mod:`recon.target_envelope`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from recon.cluster import DetectedObject, make_object
from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_texture import TexturedSeabed
from recon.target_envelope import FLANK_RADIUS_M, LOWEST_TOP_M, MAX_OBJECT_EXTENT_M, MIN_OBJECT_HEIGHT_M

F64 = NDArray[np.float64]


#: the top of an object (95th percentile of its points over the planes) stands at least this many times the
#: point threshold above the planes (clipped to LOWEST_TOP_M .. MIN_OBJECT_HEIGHT_M): the lowest object's
#: detected top (0.15 m) over the smooth-seabed threshold (5 sigma of a 0.02 m rms seabed: 0.1 m)
TOP_OVER_THRESHOLD = 1.5


def threshold(model: TexturedSeabed | SeabedModel, cfg: SeabedConfig) -> float:
    """Height (m) above ``model`` from which a point is an object point."""
    return model.min_height(cfg.min_height) if isinstance(model, TexturedSeabed) else cfg.min_height


def object_points(p: F64, model: TexturedSeabed | SeabedModel, cfg: SeabedConfig) -> NDArray[np.bool_]:
    """Mask of the points (N, 3) that are object points (see the module docstring)."""
    h = model.height_above(p)
    thr = threshold(model, cfg)
    keep = (h >= thr) & (h <= cfg.max_height)
    if isinstance(model, TexturedSeabed):
        anchor = keep & (h >= max(2.0 * MIN_OBJECT_HEIGHT_M, 3.0 * thr))
        keep |= flanks(p, anchor, model, cfg.min_height, cfg.max_height, FLANK_RADIUS_M)
    return np.asarray(keep, dtype=bool)


def flanks(p: F64, anchor: NDArray[np.bool_], model: TexturedSeabed, lo: float, hi: float, radius: float
           ) -> NDArray[np.bool_]:
    """The lower parts of objects: points ``lo``-``hi`` m above the tiled planes within ``radius`` m
    (horizontally) of an anchor, a point well above the texture grid. A crest of the texture has no anchor
    near it; a large object the grid partly followed has, and its flanks stay (the classifier needs the
    whole cloud)."""
    out = np.zeros(p.shape[0], bool)
    hc = model.coarse.height_above(p)
    cand = ~anchor & (hc >= lo) & (hc <= hi)
    if anchor.any() and cand.any():
        d, _ = cKDTree(p[anchor, :2]).query(p[cand, :2], distance_upper_bound=radius)
        out[np.flatnonzero(cand)[np.isfinite(d)]] = True
    return out


def on_seabed(objects: list[DetectedObject], model: TexturedSeabed | SeabedModel | None, rejected: dict[str, int]
              ) -> list[DetectedObject]:
    """The objects with their seabed depth (median of the tiled planes under their points: the texture grid
    may pass over part of a large object), less the clusters that are not objects (counted in ``rejected``:
    ``too_wide`` (unless its core is an object: :func:`_core`), ``too_low``)."""
    min_height, max_extent = MIN_OBJECT_HEIGHT_M, MAX_OBJECT_EXTENT_M
    if isinstance(model, TexturedSeabed):  # a smooth seabed (low threshold) lets lower tops stand out
        min_height = float(np.clip(TOP_OVER_THRESHOLD * model.min_height(0.0), LOWEST_TOP_M, min_height))
    planes = None if model is None else model.coarse if isinstance(model, TexturedSeabed) else model
    out = []
    for o in objects:
        if _width(o.points) > max_extent:
            core = None if planes is None else _core(o, planes, max_extent)
            if core is None:
                rejected["too_wide"] = rejected.get("too_wide", 0) + 1
                continue
            o = core
        if planes is not None:
            ground = planes.depth_at(o.points[:, :2])
            if float(np.percentile(ground - o.points[:, 2], 95)) < min_height:
                rejected["too_low"] = rejected.get("too_low", 0) + 1
                continue
            o = replace(o, seabed_depth=float(np.median(ground)))
        out.append(o)
    return out


def _width(points: F64) -> float:
    """The larger horizontal side (m) of the points' bounding box."""
    return float(np.max(points[:, :2].max(axis=0) - points[:, :2].min(axis=0)))


#: a cluster wider than any object keeps its core, the points at least this fraction of its top above the planes,
#: when that core is narrow enough: an object whose cluster reached out over low seabed points (a crest beside it, a
#: patch of seabed the texture grid put too deep) stays an object instead of being dropped whole
CORE_FRACTION = 0.5
MIN_CORE_POINTS = 20


def _core(o: DetectedObject, planes: SeabedModel, max_extent: float) -> DetectedObject | None:
    """The core of a too-wide cluster (:data:`CORE_FRACTION`), or None when it is still too wide or too small."""
    h = planes.depth_at(o.points[:, :2]) - o.points[:, 2]
    keep = h >= CORE_FRACTION * float(np.percentile(h, 95))
    if int(keep.sum()) < MIN_CORE_POINTS or _width(o.points[keep]) > max_extent:
        return None
    times = o.times[keep] if o.times.shape[0] == o.points.shape[0] else np.full(int(keep.sum()), o.t_first)
    extra = o.extra[keep] if o.extra.shape[0] == o.points.shape[0] else None
    return make_object(o.id, o.points[keep], times, extra, o.passes)
