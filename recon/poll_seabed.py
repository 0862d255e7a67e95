"""What recon does with the seabed fitted for a poll: object points, the seabed under each object, clutter.

:func:`object_points` keeps the points that stand above the seabed model by its threshold (the tiled planes:
``seabed.min_height``; the texture grid, :class:`recon.seabed_texture.TexturedSeabed`: the threshold from the
measured seabed noise), and, with the texture grid, an object's flanks (:func:`flanks`). :func:`on_seabed`
gives each finalized object the depth of the seabed under it and says "not an object" to a cluster wider
than any object or whose top does not stand high enough above the tiled planes (``min_height``, lower on a
smooth seabed: :data:`TOP_OVER_THRESHOLD`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from recon.cluster import DetectedObject
from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_texture import TexturedSeabed

F64 = NDArray[np.float64]


#: the top of an object (95th percentile of its points over the planes) stands at least this many times the
#: point threshold above the planes, between LOWEST_TOP_M and ``min_height``: a 0.3 m half pipe's top is
#: detected 0.13-0.15 m high at 30 deg of tilt, a crest of a 0.1 m rms seabed reaches 0.2 m and more
TOP_OVER_THRESHOLD = 1.5
LOWEST_TOP_M = 0.1


def threshold(model: TexturedSeabed | SeabedModel, cfg: SeabedConfig) -> float:
    """Height (m) above ``model`` from which a point is an object point."""
    return model.min_height(cfg.min_height) if isinstance(model, TexturedSeabed) else cfg.min_height


def object_points(p: F64, model: TexturedSeabed | SeabedModel, cfg: SeabedConfig, min_object_height: float,
                  flank_radius: float) -> NDArray[np.bool_]:
    """Mask of the points (N, 3) that are object points (see the module docstring)."""
    h = model.height_above(p)
    thr = threshold(model, cfg)
    keep = (h >= thr) & (h <= cfg.max_height)
    if isinstance(model, TexturedSeabed):
        anchor = keep & (h >= max(2.0 * min_object_height, 3.0 * thr))
        keep |= flanks(p, anchor, model, cfg.min_height, cfg.max_height, flank_radius)
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


def on_seabed(objects: list[DetectedObject], model: TexturedSeabed | SeabedModel | None, max_extent: float,
              min_height: float, rejected: dict[str, int]) -> list[DetectedObject]:
    """The objects with their seabed depth (median of the tiled planes under their points: the texture grid
    may pass over part of a large object), less the clusters that are not objects (counted in ``rejected``:
    ``too_wide``, ``too_low``)."""
    if isinstance(model, TexturedSeabed):  # a smooth seabed (low threshold) lets lower tops stand out
        min_height = float(np.clip(TOP_OVER_THRESHOLD * model.min_height(0.0), LOWEST_TOP_M, min_height))
    out = []
    for o in objects:
        wide = float(np.max(o.points[:, :2].max(axis=0) - o.points[:, :2].min(axis=0)))
        if wide > max_extent:
            rejected["too_wide"] = rejected.get("too_wide", 0) + 1
            continue
        if model is not None:
            planes = model.coarse if isinstance(model, TexturedSeabed) else model
            ground = planes.depth_at(o.points[:, :2])
            if float(np.percentile(ground - o.points[:, 2], 95)) < min_height:
                rejected["too_low"] = rejected.get("too_low", 0) + 1
                continue
            o = replace(o, seabed_depth=float(np.median(ground)))
        out.append(o)
    return out
