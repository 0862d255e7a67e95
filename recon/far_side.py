"""The hidden far side: an object's centroid moved away from the sonar by the depth it could not see.

The sonar sees an opaque object's near side and top. Its far side faces away, and the last rays that still
meet it (the steepest ray, as the object leaves the fan) do so at grazing incidence, too weak to be detected,
so the cloud ends short of the far edge and the robust box centre (:func:`recon.cluster.robust_centre`) leans
towards the vehicle.

Correction (:func:`far_side_centre`), from the object's own points and their range arcs
(:func:`recon.range_arcs.arc_columns`: the sonar origin of every point and the beam's horizontal look
direction ``u``); no class is needed, recon runs before classification:

1. Look direction ``m``: the mean of the points' unit horizontal look vectors, length ``R`` <= 1 (an
   object seen from both sides, ``R`` near 0, is hardly moved).
2. Hidden depth: the footprint is taken to be as deep along ``m`` as it is wide across it (round objects,
   reefs; roughly boxes): ``hidden = W - L``, ``W`` and ``L`` the across and along extents of the points
   between their ``q``-th and (100 - ``q``)-th percentiles, clipped to ``[0, 2 cap]`` (a long object lying
   across the look must not count its length as depth). The centre moves by ``hidden / 2`` along the
   mean look vector (``R m``): at most ``cap``.
3. Open structures are left alone: a frame reef is seen through, its far side is in the cloud. A point lies
   in its object's own acoustic shadow (:func:`self_shadowed`) where, in the vertical slab of its beam
   (``width`` m either side), a point of the same object nearer to the sonar by more than ``gap`` m rises
   above the line of sight to it by more than ``dz`` m; an opaque object cannot return from there. An
   object with at least ``open_min`` such points, and more than ``open_fraction`` of its points, is open.

The correction is a function of the object's final points alone, computed in a sorted order (the same bits
for the same points in any order), so batch and streaming agree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from recon.range_arcs import RangeArcs, is_arc_record

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class FarSideConfig:
    enabled: bool = True
    cap: float = 0.2  # m: the largest move of the centre
    q: float = 2.0  # percentiles of the extents (those of the robust box centre)
    width: float = 0.2  # m: half-width of a beam's vertical slab in the shadow test
    gap: float = 0.3  # m: how much nearer the shadowing point must be
    dz: float = 0.15  # m: how far below the line of sight a shadowed point must be
    open_min: int = 3  # shadowed points (at least) ...
    open_fraction: float = 0.005  # ... and (more than) this fraction of the points: an open structure
    max_points: int = 1500  # the shadow test runs on at most this many points (an even subsample)


def self_shadowed(points: F64, origins: F64, width: float = 0.2, gap: float = 0.3, dz: float = 0.15,
                  chunk: int = 256) -> int:
    """How many of ``points`` (N, 3; NED) lie in the acoustic shadow of the others, each seen from its own
    sonar origin ``origins`` (N, 3): see the module docstring."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    o = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    count = 0
    for c0 in range(0, p.shape[0], chunk):
        pc, oc = p[c0 : c0 + chunk], o[c0 : c0 + chunk]
        h = pc[:, :2] - oc[:, :2]
        dist = np.linalg.norm(h, axis=1)
        look = h / np.maximum(dist, 1e-12)[:, None]
        rel = p[None, :, :2] - oc[:, None, :2]  # (chunk, N, 2) every point from this chunk's origins
        along = rel[:, :, 0] * look[:, None, 0] + rel[:, :, 1] * look[:, None, 1]
        across = np.abs(rel[:, :, 0] * look[:, None, 1] - rel[:, :, 1] * look[:, None, 0])
        nearer = (along > 1e-6) & (along < dist[:, None] - gap) & (across <= width)
        # depth of the line of sight over each nearer point, carried on to the shadowed point's distance
        sight = oc[:, None, 2] + (p[None, :, 2] - oc[:, None, 2]) * dist[:, None] / np.where(nearer, along, 1.0)
        count += int(np.any(nearer & (pc[:, None, 2] > sight + dz), axis=1).sum())
    return count


def far_side_centre(centre: F64, points: F64, arcs: F64, config: FarSideConfig | None = None) -> F64:
    """``centre`` (the robust box centre of ``points``) moved by the hidden far side; ``arcs`` (N, 10) are
    the points' range arcs. Unchanged when disabled, without arcs, or for an open structure."""
    cfg = config or FarSideConfig()
    c = np.asarray(centre, dtype=np.float64).copy()
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    a = np.asarray(arcs, dtype=np.float64)
    if not cfg.enabled or p.shape[0] < 2 or not is_arc_record(a, p.shape[0]):
        return c
    order = np.lexsort(np.column_stack([p, a]).T[::-1])  # the same answer, to the bit, in any point order
    p, a = p[order], a[order]
    look = RangeArcs.of(a).u[:, :2]  # the beam's horizontal look direction
    u = look / np.maximum(np.linalg.norm(look, axis=1, keepdims=True), 1e-12)
    mean_look = u.mean(axis=0)
    r = float(np.linalg.norm(mean_look))
    if r < 1e-9:
        return c
    m = mean_look / r
    rel = p[:, :2] - c[:2]
    along = rel @ m
    across = rel[:, 0] * m[1] - rel[:, 1] * m[0]
    lo, hi = cfg.q, 100.0 - cfg.q
    hidden = np.ptp(np.percentile(across, [lo, hi])) - np.ptp(np.percentile(along, [lo, hi]))
    hidden = float(np.clip(hidden, 0.0, 2.0 * cfg.cap))
    if hidden == 0.0:
        return c
    sub = np.arange(0, p.shape[0], max(1, -(-p.shape[0] // cfg.max_points)))  # an even subsample
    shadowed = self_shadowed(p[sub], RangeArcs.of(a[sub]).origin, cfg.width, cfg.gap, cfg.dz)
    if shadowed >= cfg.open_min and shadowed > cfg.open_fraction * sub.size:
        return c
    c[:2] += 0.5 * hidden * mean_look
    return c
