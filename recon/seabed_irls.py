"""The arithmetic of the tiled seabed fit (:mod:`recon.seabed`): which tiles each point feeds, and the IRLS planes.

Both give exactly the numbers of the straightforward forms they replace (every point paired with its 9
neighbouring tiles, then filtered; one ``np.bincount`` per normal-equation term over every point with its 0/1
weight; ``np.einsum`` for the residuals), only with fewer passes over the points:

- the pairs are grouped by tile with one stable sort, so each tile's sums still add its points in the order of the
  points, and the planes are spread back to the pairs with ``np.repeat`` instead of a gather;
- the sums run over the points of weight 1 only (a term of weight 0 adds +-0.0, which leaves a sum of finite
  numbers unchanged);
- the iterations stop once the points kept repeat (every further one would give the same planes and weights);
- the residual ``z - (c0 + dx c1 + dy c2)`` is written out in the order in which numpy's ``einsum`` over the 3
  terms adds them (``(c0 + dy c2) + dx c1``, its two-lane inner loop; checked bit for bit by
  ``tests/test_seabed_irls.py`` against ``einsum``).

Units: positions in m, offsets from a tile's centre in tiles, depths in m.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
_OFFSETS = (-1, 0, 1)  # the neighbouring tiles along one axis (recon.seabed: i outer, j inner)
#: a dense tile grid (cells) at most this many times the pairs; a wider spread of points sorts the keys instead
_DENSE_GRID_FACTOR = 4


class IrlsConfig(Protocol):
    """The IRLS settings of :class:`recon.seabed.SeabedConfig`."""

    @property
    def iterations(self) -> int: ...

    @property
    def clip_sigma(self) -> float: ...

    @property
    def sigma_floor(self) -> float: ...  # m


class TilePairs:
    """Every (point, tile) pair of points ``p`` (N, 2+) on square tiles of ``tile`` m whose box, widened by
    ``overlap`` tiles each side, holds the point; grouped by tile (stable: points in order within a tile).

    ``point`` (M,) the point of each pair, ``dx``, ``dy`` (M,) its offsets from the tile's centre (tiles),
    ``ij`` (T, 2) the tiles, ``counts`` (T,) pairs per tile, ``tix`` (M,) each pair's tile (non-decreasing)."""

    def __init__(self, p: F64, tile: float, overlap: float) -> None:
        t = tile
        n = p.shape[0]
        cell = np.floor(p[:, :2] / t).astype(np.int64)
        half = t * (0.5 + overlap)
        offs = np.asarray(_OFFSETS, dtype=np.int64)
        # per axis and offset: the offset from the neighbour tile's centre (m) and whether its widened box holds it
        cen = [(cell[:, k, None] + offs[None]) + 0.5 for k in (0, 1)]  # (N, 3) tile index + 0.5, per axis
        dm = [p[:, k, None] - cen[k] * t for k in (0, 1)]
        ok = [np.abs(d) <= half for d in dm]
        inside = (ok[0][:, :, None] & ok[1][:, None, :]).reshape(n, 9)  # i outer, j inner
        flat = np.flatnonzero(inside)
        point, k = flat // 9, flat % 9
        oi, oj = k // 3, k % 3
        ti, tj = cell[point, 0] + offs[oi], cell[point, 1] + offs[oj]
        label, ij = _tile_labels(ti, tj)
        # stable: the points in their order within each tile (16-bit labels sort by radix, the order is the same)
        order = np.argsort(label.astype(np.uint16) if ij.shape[0] <= 1 << 16 else label, kind="stable")
        self.point = point[order]
        self.dx = dm[0][self.point, oi[order]] / t
        self.dy = dm[1][self.point, oj[order]] / t
        self.tix = label[order]
        self.ij = ij
        self.counts = np.bincount(self.tix, minlength=ij.shape[0])


def _tile_labels(ti: I64, tj: I64) -> tuple[I64, I64]:
    """A label 0..T-1 per pair for its tile (ti, tj) and the T tiles (T, 2) (any order: the model sorts them)."""
    if ti.size == 0:
        return np.zeros(0, np.int64), np.zeros((0, 2), np.int64)
    i0, j0 = int(ti.min()), int(tj.min())
    w = int(tj.max()) - j0 + 1
    size = (int(ti.max()) - i0 + 1) * w
    if size <= _DENSE_GRID_FACTOR * ti.size:
        lin = (ti - i0) * w + (tj - j0)
        present = np.bincount(lin, minlength=size) > 0
        rank = np.cumsum(present) - 1
        cells = np.flatnonzero(present)
        return rank[lin], np.stack([cells // w + i0, cells % w + j0], axis=1)
    keys, label = np.unique(np.stack([ti, tj], axis=1), axis=0, return_inverse=True)
    return label.reshape(-1), keys


def irls_planes(dx: F64, dy: F64, z: F64, tix: I64, counts: I64, ridge: float, cfg: IrlsConfig
                ) -> tuple[F64, F64]:
    """Planes ``z = c0 + c1 dx + c2 dy`` of the ``T = counts.size`` groups (pair ``k`` in group ``tix[k]``,
    ``tix`` non-decreasing, ``counts`` pairs per group) by iteratively reweighted least squares: a plain fit, then
    the deeper half (objects only stand above the seabed), then the points within ``clip_sigma`` sigmas (m);
    ``ridge`` x the group's weight on the two slope terms. Returns the (T, 3) coefficients and the last weights
    (0 or 1 per pair)."""
    n_t = counts.size
    coef = np.zeros((n_t, 3))
    keep: I64 | None = None  # None: every pair
    wsum = np.ones(n_t)
    for it in range(max(2, cfg.iterations)):
        if keep is None:
            g, zk, x, y = tix, z, dx, dy
        else:
            g, zk, x, y = tix[keep], z[keep], dx[keep], dy[keep]
        ata = np.empty((n_t, 3, 3))
        atz = np.stack([np.bincount(g, weights=zk, minlength=n_t), np.bincount(g, weights=x * zk, minlength=n_t),
                        np.bincount(g, weights=y * zk, minlength=n_t)], axis=1)
        terms = ((0, 0, None), (0, 1, x), (0, 2, y), (1, 1, x * x), (1, 2, x * y), (2, 2, y * y))
        for r, c, v in terms:
            s_rc = np.bincount(g, minlength=n_t).astype(np.float64) if v is None else np.bincount(
                g, weights=v, minlength=n_t)
            ata[:, r, c] = ata[:, c, r] = s_rc
        wsum = np.maximum(ata[:, 0, 0], 1e-12)
        ata[:, 1, 1] += ridge * wsum
        ata[:, 2, 2] += ridge * wsum
        ata[:, 0, 0] += 1e-12
        coef = np.asarray(np.linalg.solve(ata, atz[..., None])[..., 0], dtype=np.float64)
        res = z - ((np.repeat(coef[:, 0], counts) + dy * np.repeat(coef[:, 2], counts))
                   + dx * np.repeat(coef[:, 1], counts))
        if it == 0:  # objects only stand above the seabed: restart from the deeper half
            keep = np.flatnonzero(res >= 0)
            continue
        sel = keep if keep is not None else slice(None)
        wss = np.bincount(tix[sel], weights=res[sel] ** 2, minlength=n_t)
        sigma = np.maximum(np.sqrt(wss / wsum), cfg.sigma_floor)
        prev, keep = keep, np.flatnonzero(np.abs(res) <= cfg.clip_sigma * np.repeat(sigma, counts))
        if prev is not None and np.array_equal(prev, keep):
            break  # the same points again: every further iteration gives these planes and weights
    w = np.zeros(z.size)
    w[keep if keep is not None else slice(None)] = 1.0
    return coef, w
