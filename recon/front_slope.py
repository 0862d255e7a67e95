"""Front-slope correction of highlight-extension points: re-placement on the beam's range arc.

Why: a highlight-extension return is placed on the steepest ray of its beam (phi = +s/2). While an
object's top front edge E is the nearest surface in the fan it is the first return from a shallower
ray, so the point lands on E's range sphere but lower and nearer than E. Over successive frames,
from the first detection (range = seabed onset: the point lands near the seabed, in front of the
object) until E passes under the steepest ray (the point is right), these points draw a slope in
front of the object: the "front slope" of Sung et al. Its horizontal length for an edge h above a
seabed H below the sonar is L = r_on (cos e0 - cos(t + s/2)), r_on = H / sin(t + s/2) the onset
range and sin e0 = (H - h) / r_on (0.35 m for h = 0.5 m, 0.64 m for h = 1 m at H = 4.8 m, t = 30 deg,
s = 14 deg): the objects look longer towards the vehicle and their centroids move towards it.

:func:`replace_on_arcs`: every point stays on its own range arc (same frame,
range and beam; elevation free in [-s/2, +s/2]) and is moved up that arc to the height of the
object's top where the beam looked: the highest point of the same object within ``length`` m
behind it along the beam's horizontal look direction and ``width`` m across. A point never lands
below its steepest-ray position or above the highest point seen there, points already at the top
stay, and since placed points are never higher than their source, the top is not overestimated.
Applied per object once the object is final (its top is known only when the vehicle has passed
it), so batch and streaming give the same points. Each point carries its ray as 10 columns
(:mod:`recon.range_arcs`: sonar origin, the arc's unit vectors u and w in W, range); the arcs are those of
the exact beam geometry, whatever the placement mode.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from recon.range_arcs import ARC_COLUMNS, RangeArcs, arc_columns, steepest_points

__all__ = ["ARC_COLUMNS", "arc_columns", "replace_on_arcs", "steepest_points"]

F64 = NDArray[np.float64]


def replace_on_arcs(points: F64, arcs: F64, spread: float, length: float = 1.0, width: float = 0.25,
                    chunk: int = 1024, steepest: F64 | None = None) -> F64:
    """Front-slope corrected copy of one object's ``points`` (N, 3) given their ``arcs`` (N, 10).

    ``steepest``: per point the steepest elevation (rad) a raised point may keep (default ``+spread / 2``): the
    elevation below the edge an object's points were re-placed on (:mod:`recon.pattern_fall`), so that raising a
    point to its object's top never lifts it above that top, back to the edge ray.

    The neighbour pairs are formed ``chunk`` points at a time (the same answer for any ``chunk``): a
    dense cloud, e.g. a seabed left in by a threshold far too low (150,000 points), held every pair
    within ~1 m at once and took 7 GB."""
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    if n == 0 or arcs.shape != (n, ARC_COLUMNS):
        return p.copy()
    o, u, w, r = RangeArcs.of(arcs)
    norm = np.linalg.norm(u[:, :2], axis=1)
    look = u[:, :2] / np.maximum(norm, 1e-12)[:, None]
    top = p[:, 2].copy()  # NED: the top is the smallest depth
    tree = cKDTree(p[:, :2])
    # each point's look-ahead rectangle lies in the disk around its centre of radius its half-diagonal (plus a
    # rounding margin): the pairs within that disk hold every pair the rectangle test below keeps; a ray (nearly)
    # straight down has no look direction: the disk of radius hypot(length, width) around the point itself
    vertical = norm < 1e-12
    centres = np.where(vertical[:, None], p[:, :2], p[:, :2] + (0.5 * length) * look)
    for sel, radius in ((np.flatnonzero(~vertical), np.hypot(0.5 * length, width) * (1.0 + 1e-9) + 1e-9),
                        (np.flatnonzero(vertical), np.hypot(length, width))):
        for c0 in range(0, sel.size, chunk):  # `chunk` points at a time: memory bounded however dense
            idx = sel[c0 : c0 + chunk]
            pairs = cKDTree(centres[idx]).sparse_distance_matrix(tree, radius, output_type="ndarray")
            i, j = idx[pairs["i"].astype(np.int64)], pairs["j"].astype(np.int64)
            higher = p[j, 2] < p[i, 2]  # only a higher point can raise the top
            _raise_tops(top, p, look, i[higher], j[higher], length, width)
    # solve depth(phi) = o_z + r (cos phi u_z + sin phi w_z) = top on the rising branch, phi in [-s/2, s/2]
    a, b = r * u[:, 2], r * w[:, 2]
    amp = np.maximum(np.hypot(a, b), 1e-12)
    phi = np.arctan2(b, a) - np.arccos(np.clip((top - o[:, 2]) / amp, -1.0, 1.0))
    half = 0.5 * spread
    hi = np.full(n, half) if steepest is None else np.maximum(half, np.asarray(steepest, np.float64))
    phi = np.where(top < p[:, 2], np.clip(phi, -half, hi), half)
    q = o + r[:, None] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * w)
    moved = top < p[:, 2]
    return np.where(moved[:, None], q, p)


def _raise_tops(top: F64, p: F64, look: F64, i: NDArray[np.int64], j: NDArray[np.int64], length: float,
                width: float) -> None:
    """``top[i]`` lowered (NED: raised) to the depth of each pair's point ``j`` that lies within ``length`` m
    ahead of point ``i`` along its ``look`` direction and ``width`` m across it."""
    d = p[j, :2] - p[i, :2]
    along = np.einsum("ni,ni->n", d, look[i])
    across = np.abs(d[:, 0] * look[i, 1] - d[:, 1] * look[i, 0])
    ok = (along >= 0.0) & (along <= length) & (across <= width)
    np.minimum.at(top, i[ok], p[j[ok], 2])
