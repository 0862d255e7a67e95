"""Where below the fan's edge a reflector was seen: the elevation at which its range arcs from successive frames meet.

A highlight-extension return is placed on the effective lower edge of the fan (:mod:`recon.beam_edge`). A real
beam has energy beyond that edge (a smooth pattern's tail, the sidelobes of the vertical pattern), and a
reflector brighter than the seabed keeps returning through it after the edge ray has passed over it: those returns
come from steeper rays, and placed on the edge ray they stand too high (by decimetres under a Gaussian pattern, up
to 0.8 m under a sinc^2 one), and the front-slope correction lifts the whole object to them.

The sonar's motion resolves it without any model of the beam. A fixed reflector ``T`` seen from the frames ``j``
lies on every one of their range arcs (:mod:`recon.range_arcs`: ``|T - o_j| = r_j`` in the beam's plane), so the
arcs of successive frames cross at ``T``; placed at the wrong elevation, the returns of those frames spread along
the track instead. :func:`consensus_elevations` samples each return's arc from the elevation it was placed at down to
:data:`SPAN_SPREADS` nominal spreads below it (every :data:`STEP_RAD`), counts per candidate the candidates of the
*other* frames within :data:`RADIUS_M` (arcs from one frame meet only by beam adjacency, not by motion), each
weighted by the distance between the two frames' sonar positions (arcs from nearby positions run side by side for
decimetres and meet anywhere along them; from positions far apart they cross at one point), and moves a return to
its best-scored candidate when that candidate's count clearly exceeds the count where it was placed
(:data:`MARGIN_SIGMAS` Poisson sigmas). A return from the edge ray sweeping an object's face is already where its
frames' arcs meet (their envelope is the face), and stays. Candidates below the seabed do not count.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from recon.range_arcs import ARC_COLUMNS, arc_elevations, points_at

F64 = NDArray[np.float64]

#: how far below its placed elevation a return may lie, in nominal spreads: issue 36's acoustic space draws energy
#: out to 4 nominal -3 dB widths (+-2 spreads about the axis), 1.5 spreads beyond the nominal edge
SPAN_SPREADS = 1.5
#: rad between candidates on an arc: 0.5 deg, 4 cm at 5 m, 7 cm at 8 m (the candidates of a frame then cover the
#: consensus disk at the ranges objects are seen from, 3-8 m)
STEP_RAD = np.radians(0.5)
#: m: arcs closer than this meet: twice the coarsest supported range bin (DIDSON 300 m, 512 bins over 11 m: 2.1
#: cm) plus the pose's drift between frames a second apart (< 1 cm)
RADIUS_M = 0.05
#: a return moves when its best candidate's count exceeds the count where it lies by this many Poisson sigmas
MARGIN_SIGMAS = 2.0
#: m a candidate may lie below the seabed fitted under the object (the seabed's own noise)
BELOW_SEABED_M = 0.05
#: frames a return needs around it (other frames' returns in its object) before its arc is tested
MIN_FRAMES = 3


def consensus_elevations(points: F64, arcs: F64, times: F64, spread: float,
                         seabed_depth: float = float("nan")) -> F64:
    """Per return of one object (``points`` (N, 3) world NED m, their ``arcs`` (N, 10), frame ``times`` (N,) s),
    the elevation (rad below the fan's axis, (N,)) at which the arcs of its frames meet (module docstring): at
    least the elevation it was placed at. ``spread``: the fan's nominal vertical spread (rad); ``seabed_depth``:
    the seabed under the object (m NED; NaN: no limit)."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    n = p.shape[0]
    phi0 = arc_elevations(p, arcs) if n else np.zeros(0)
    frames = np.unique(times, return_inverse=True)[1].reshape(-1) if n else np.zeros(0, np.int64)
    if n == 0 or arcs.shape != (n, ARC_COLUMNS) or int(frames.max()) + 1 < MIN_FRAMES:
        return phi0
    steps = np.arange(0.0, SPAN_SPREADS * spread + 0.5 * STEP_RAD, STEP_RAD)
    k = steps.size
    phis = phi0[:, None] + steps[None, :]  # (N, K)
    cand = points_at(np.repeat(arcs, k, axis=0), phis.reshape(-1))  # (N K, 3)
    frame = np.repeat(frames, k)
    origin = np.repeat(np.asarray(arcs, np.float64)[:, :3], k, axis=0)
    valid = cand[:, 2] <= seabed_depth + BELOW_SEABED_M if np.isfinite(seabed_depth) else np.ones(n * k, bool)
    idx = np.flatnonzero(valid)
    pairs = cKDTree(cand[idx]).query_pairs(RADIUS_M, output_type="ndarray")
    a, b = idx[pairs[:, 0]], idx[pairs[:, 1]]
    other = frame[a] != frame[b]
    a, b = a[other], b[other]
    ends = np.concatenate([a, b])
    baseline = np.linalg.norm(origin[a] - origin[b], axis=1)
    score = np.bincount(ends, weights=np.concatenate([baseline, baseline]), minlength=n * k)
    score[~valid] = -1.0
    count = np.bincount(ends, minlength=n * k).reshape(n, k).astype(np.float64)
    best = np.argmax(score.reshape(n, k), axis=1)  # the first of equal scores: the least move
    rows = np.arange(n)
    move = count[rows, best] > count[:, 0] + MARGIN_SIGMAS * np.sqrt(count[:, 0] + 1.0)
    return np.asarray(np.where(move, phis[rows, best], phi0), np.float64)


def consensus_points(points: F64, arcs: F64, times: F64, spread: float, seabed_depth: float = float("nan")
                     ) -> tuple[F64, F64 | None]:
    """One object's points re-placed at their :func:`consensus_elevations` and those elevations (rad), for the
    front-slope correction's ``steepest`` (:func:`recon.front_slope.replace_on_arcs`); the points unchanged and None
    without arcs."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    if arcs.shape != (p.shape[0], ARC_COLUMNS):
        return p, None
    phi = consensus_elevations(p, arcs, times, spread, seabed_depth)
    return points_at(arcs, phi), phi
