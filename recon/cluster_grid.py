"""DBSCAN on a voxel grid, with Open3D's labels: the same core points, clusters, numbering and border points.

Definition (Open3D ``PointCloud.cluster_dbscan``): a point is a core when at least ``min_points`` points (itself
included) lie within ``eps``; cores within ``eps`` of each other share a cluster; a non-core point within ``eps``
of a core is a border point of the first cluster that reaches it, otherwise noise (-1). Open3D starts a cluster
at each unlabelled core in index order and grows it to the end before the next, so clusters are numbered by their
lowest core index and a border point joins the lowest-numbered cluster among those of its cores.

Here the points go into cubic cells of side ``eps / sqrt(3)``, so any two points of one cell lie within ``eps``:
every point of a cell holding ``min_points`` or more is a core without a search, and the cores of one cell are
one cluster. Only the points of the other cells count their neighbours (a KD-tree, ``scipy.spatial.cKDTree``).
Two cells 2 or fewer cells apart on every axis can hold cores within ``eps``: they are joined when the cores
nearest their centres are within ``eps`` (most joins, vectorized), and the pairs still apart are tested core
against core. Clusters are the connected components of that cell graph (``scipy.sparse.csgraph``). The cost
follows the number of points and occupied cells, not the number of neighbour pairs, which in dense clouds
(thousands of points within ``eps``) is what a point-by-point DBSCAN pays for.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: cell offsets (one of each +/- pair) whose cells can hold points within eps: up to 2 cells on every axis
_OFFSETS = np.array([d for d in itertools.product(range(-2, 3), repeat=3) if d > (0, 0, 0)], dtype=np.int64)
_SHRINK = 1.0 - 1e-9  # cell side a hair under eps / sqrt(3): two points of one cell are strictly within eps


def _cell_keys(cells: I64) -> I64:
    """One int64 per cell (the cell indices are shifted to be >= 2 and packed 21 bits an axis)."""
    c = cells - cells.min(axis=0) + 2
    if int(c.max()) >= 1 << 20:
        raise ValueError("cloud too large for the DBSCAN grid (over a million cells an axis)")
    return (c[:, 0] << 42) | (c[:, 1] << 21) | c[:, 2]


def _cores(p: F64, inv: I64, counts: I64, eps: float, min_points: int) -> NDArray[np.bool_]:
    """Per point: a core (``min_points`` or more points within ``eps``, itself included)."""
    core = counts[inv] >= min_points
    sparse = np.flatnonzero(~core)
    if sparse.size:
        n = cKDTree(p).query_ball_point(p[sparse], eps, return_length=True)
        core[sparse] = np.asarray(n) >= min_points
    return core


def _representatives(pc: F64, cell_of_core: I64, side: float, n_cells: int) -> I64:
    """Per core cell (0 .. n_cells - 1), the index among the cores of the core nearest the cell's centre."""
    centre = (np.floor(pc / side) + 0.5) * side
    d = np.sum((pc - centre) ** 2, axis=1)
    order = np.lexsort((d, cell_of_core))
    first = np.r_[True, cell_of_core[order][1:] != cell_of_core[order][:-1]]
    reps = np.empty(n_cells, np.int64)
    reps[cell_of_core[order][first]] = order[first]
    return reps


def _neighbour_cells(keys: I64) -> tuple[I64, I64]:
    """Pairs (a, b) of indices into the sorted unique ``keys`` of cells 2 or fewer cells apart on every axis."""
    other = keys[:, None] + (_OFFSETS @ np.array([1 << 42, 1 << 21, 1], dtype=np.int64))[None, :]
    j = np.minimum(np.searchsorted(keys, other), keys.size - 1)
    a, k = np.nonzero(keys[j] == other)
    return a.astype(np.int64), j[a, k]


def _core_components(pc: F64, keys_c: I64, eps: float, side: float) -> I64:
    """Per core, its cluster's component number (cores of one cell together; cells joined by cores within eps)."""
    ukeys, cell_of_core = np.unique(keys_c, return_inverse=True)
    cell_of_core = cell_of_core.ravel()
    n_cells = ukeys.size
    reps = _representatives(pc, cell_of_core, side, n_cells)
    a, b = _neighbour_cells(ukeys)
    near = np.sum((pc[reps[a]] - pc[reps[b]]) ** 2, axis=1) <= eps * eps
    graph = coo_matrix((np.ones(int(near.sum())), (a[near], b[near])), shape=(n_cells, n_cells))
    _, comp = connected_components(graph, directed=False)
    apart = np.flatnonzero(comp[a] != comp[b])  # neighbour cells not joined yet: core against core
    if apart.size:
        order = np.argsort(cell_of_core, kind="stable")
        start = np.searchsorted(cell_of_core[order], np.arange(n_cells + 1))
        joined = [k for k in apart if _any_within(pc[order[start[a[k]]:start[a[k] + 1]]],
                                                  pc[order[start[b[k]]:start[b[k] + 1]]], eps)]
        if joined:
            ja, jb = a[np.asarray(joined)], b[np.asarray(joined)]
            graph = coo_matrix((np.ones(near.sum() + ja.size), (np.r_[a[near], ja], np.r_[b[near], jb])),
                               shape=(n_cells, n_cells))
            _, comp = connected_components(graph, directed=False)
    return np.asarray(comp, dtype=np.int64)[cell_of_core]


def _any_within(x: F64, y: F64, eps: float) -> bool:
    """True when some point of ``x`` lies within ``eps`` of some point of ``y``."""
    return bool(np.any(np.sum((x[:, None, :] - y[None, :, :]) ** 2, axis=2) <= eps * eps))


#: estimated pairs within eps up to which every pair is listed at once (a KD-tree), above which the grid works cell
#: by cell: the crossover measured on blobs of 1000-10000 points, eps 0.5 m (CPU time: 1000 points 2.5 ms direct
#: / 4.1 ms grid at 41 000 estimated pairs, 3000 points 17.7 / 8.8 ms at 285 000; notes/replay_speed)
MAX_PAIRS = 100_000
#: pairs within eps per point of a cell, per point of that cell (half the ~22 cells of side eps / sqrt(3) that fit
#: in a ball of radius eps: the estimate the choice of path uses)
_PAIRS_PER_CELL_POINT = 11


def grid_dbscan(points: F64, eps: float, min_points: int, max_pairs: float = MAX_PAIRS) -> I64:
    """DBSCAN labels (-1 noise) of ``(n, 3)`` finite points, as Open3D gives them (see the module doc).

    A cloud whose estimated neighbour pairs (from its cell counts) stay under ``max_pairs`` takes the direct path
    (:func:`_pairs_dbscan`: every pair listed at once, the cheaper for small and sparse clouds), others the grid."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    labels = np.full(p.shape[0], -1, np.int64)
    if p.shape[0] == 0:
        return labels
    side = eps / np.sqrt(3.0) * _SHRINK
    keys = _cell_keys(np.floor(p / side).astype(np.int64))
    _, inv, counts = np.unique(keys, return_inverse=True, return_counts=True)
    if _PAIRS_PER_CELL_POINT * float(np.sum(counts.astype(np.float64) ** 2)) <= max_pairs:
        return _pairs_dbscan(p, eps, min_points)
    core = _cores(p, inv.ravel(), counts, eps, min_points)
    ci = np.flatnonzero(core)
    if ci.size == 0:
        return labels
    comp = _core_components(p[ci], keys[ci], eps, side)
    labels[ci] = _ranked(comp, ci, p.shape[0])[comp]
    rest = np.flatnonzero(~core)
    if rest.size:  # border points: the lowest-numbered cluster among their cores within eps (few neighbours each)
        near = cKDTree(p[ci]).query_ball_point(p[rest], eps)
        labels[rest] = [min((int(labels[ci[j]]) for j in js), default=-1) for js in near]
    return labels


def _ranked(comp: I64, index: I64, n: int) -> I64:
    """Per component, its cluster number: components ordered by their lowest point ``index`` (Open3D's order)."""
    first = np.full(int(comp.max()) + 1, n, np.int64)
    np.minimum.at(first, comp, index)
    rank = np.empty_like(first)
    rank[np.argsort(first, kind="stable")] = np.arange(first.size)
    return rank


def _pairs_dbscan(p: F64, eps: float, min_points: int) -> I64:
    """The same labels from every pair of points within ``eps`` (``cKDTree.query_pairs``)."""
    n = p.shape[0]
    pairs = cKDTree(p).query_pairs(eps, output_type="ndarray").astype(np.int64)
    core = 1 + np.bincount(pairs.ravel(), minlength=n) >= min_points
    labels = np.full(n, -1, np.int64)
    ci = np.flatnonzero(core)
    if ci.size == 0:
        return labels
    both = pairs[core[pairs[:, 0]] & core[pairs[:, 1]]]
    graph = coo_matrix((np.ones(both.shape[0]), (both[:, 0], both[:, 1])), shape=(n, n))
    _, comp_all = connected_components(graph, directed=False)
    comp = np.unique(np.asarray(comp_all, dtype=np.int64)[ci], return_inverse=True)[1].ravel()
    labels[ci] = _ranked(comp, ci, n)[comp]
    one = pairs[core[pairs[:, 0]] != core[pairs[:, 1]]]  # a core and a non-core: a border candidate
    if one.size:
        border = np.where(core[one[:, 0]], one[:, 1], one[:, 0])
        cluster = labels[np.where(core[one[:, 0]], one[:, 0], one[:, 1])]
        best = np.full(n, np.iinfo(np.int64).max, np.int64)
        np.minimum.at(best, border, cluster)
        hit = best < np.iinfo(np.int64).max
        labels[hit] = best[hit]
    return labels
