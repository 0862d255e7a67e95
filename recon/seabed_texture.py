"""The seabed at the scale of its texture: a fine grid on top of the tiled planes of :mod:`recon.seabed`.

A rough seabed (ripples and bumps of 0.5-8 m wavelength, centimetres to decimetres high) puts its
crests in the sonar's highlight extension: the steepest ray meets a crest before the onset the tiled
planes (6 m) predict. Those points lie *on* the seabed, so the model has to follow the seabed at the
scale of the texture, while still passing *under* the objects. :class:`SeabedCells` accumulates every
seabed sample the sonar gives (the seabed returns at the onset, the first returns before it, the DVL's
bottom points) per horizontal cell (``cell`` m, grid anchored at the world origin): count, sum and sum
of squares of depth, so memory is bounded by the area surveyed, not the number of frames.

:func:`fit_textured` builds, over a box, a :class:`TexturedSeabed`: the residual of each cell's mean
depth above the tiled planes, compared with the level of its neighbourhood (``window_m`` on each
side): a plane fitted by least squares to the neighbourhood's seabed cells (cells without samples, in a narrow
swath or an object's shadow, do not count), evaluated at the cell (:func:`local_level`), recomputed ``iterations``
times without the object cells found. A plane, not the mean: a neighbourhood covered on one side only (a swath's
edge, gaps) puts the mean of a tilted seabed off the cell's level. The neighbourhood planes are fitted to the cell
means less one plane through all of the box's cells, not less the tiled planes: each tile's plane follows the
texture of its 6 m and their blend bends where tiles meet.
Objects stand out of their neighbourhood by far more than the texture does: a cell higher than
the neighbourhood by ``clip_k`` robust sigmas of those differences (measured on the box, so the
threshold follows the seabed at hand; over all of its cells, the object cells of the last round too: a spread
measured without the cells out beyond 3 sigma shrinks each round and the object cells grew over a crest) is an
object cell; object cells (grown by ``grow_m``: an object's
flanks stand lower than its top) and empty cells
take the neighbourhood's level instead (the level recomputed without them). Depth at a point is the
planes plus the bilinear interpolation of the cell residuals.

The seabed noise (:attr:`TexturedSeabed.sigma`) is measured too (:meth:`SeabedCells.noise`): the
median, over every cell surveyed so far, of the spread of its samples about its mean (sonar range
quantization, speckle, texture finer than a cell); objects are few among all the cells, so they do not
set it. Each fit sees ``context_m`` of seabed around the points it filters, so an object is a
minority of its cells too.
Object points are those at least ``max(min_height, k_sigma * sigma)`` above the
model (:meth:`TexturedSeabed.min_height`); the noise is measured only on ``min_sigma_cells`` seabed cells or
more (the first seconds of a line hold few, and an object among them would set it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import binary_dilation, uniform_filter

from recon.seabed import SeabedModel
from recon.target_envelope import MAX_SEABED_THRESHOLD_M

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class TextureConfig:
    enabled: bool = True
    cell: float = 0.5  # m
    window_m: float = 3.0  # m each side: objects (<= 3 m) must stand out of this neighbourhood
    context_m: float = 8.0  # m of seabed around the new points that each fit sees (objects a minority in it)
    clip_k: float = 3.0  # object cell: higher than its neighbourhood by this many robust sigmas
    iterations: int = 3  # rounds of: level of the seabed cells around, object cells out
    level_ridge: float = 0.1  # cells^2: pulls a window's plane to the box plane's slope where its cells do not span it
    sigma_floor: float = 0.02  # m: floor of that sigma (a smooth seabed)
    min_count: int = 2  # samples for a cell to count
    grow_m: float = 1.0  # m: object cells grow by this much (an object's flanks are lower than its top)
    k_sigma: float = 5.0  # object points: at least k_sigma * the measured seabed noise above the model
    min_sigma_cells: int = 25  # seabed cells (3+ samples) needed to measure the noise; fewer: the floor alone
    #: the highlight points feed the grid too; off: an object's own returns would lift its cells, and a low object
    #: on a rough seabed (cells under clip_k sigma over their neighbourhood) would become seabed (RESULTS.md)
    highlights: bool = False
    max_cells: int = 400_000  # a box larger than this many cells is fitted at a coarser cell


#: the texture grid recon runs with (fixed: each value's source is its comment above)
SEABED_TEXTURE = TextureConfig()


def _key(ij: NDArray[np.int64]) -> NDArray[np.int64]:
    return (ij[:, 0] << 32) + (ij[:, 1] & 0xFFFFFFFF)


class SeabedCells:
    """Per-cell sums of seabed samples (count, depth, depth squared), grown as samples come."""

    def __init__(self, cell: float) -> None:
        self.cell = float(cell)
        self._index: dict[int, int] = {}
        self._ij = np.zeros((0, 2), np.int64)
        self._sums = np.zeros((0, 3))
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def add(self, points: ArrayLike) -> None:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        p = p[np.all(np.isfinite(p), axis=1)]
        if p.shape[0] == 0:
            return
        ij = np.floor(p[:, :2] / self.cell).astype(np.int64)
        keys, inv = np.unique(_key(ij), return_inverse=True)
        inv = inv.ravel()
        rows = np.empty(keys.size, np.int64)
        first = np.zeros(keys.size, np.int64)
        first[inv[::-1]] = np.arange(inv.size)[::-1]
        new: list[int] = []
        for k, key in enumerate(keys.tolist()):
            r = self._index.get(key)
            if r is None:
                r = self._n + len(new)
                self._index[key] = r
                new.append(k)
            rows[k] = r
        if new:
            need = self._n + len(new)
            if need > self._sums.shape[0]:
                cap = max(need, 2 * self._sums.shape[0], 1024)
                self._sums = np.concatenate([self._sums, np.zeros((cap - self._sums.shape[0], 3))])
                self._ij = np.concatenate([self._ij, np.zeros((cap - self._ij.shape[0], 2), np.int64)])
            self._ij[self._n : need] = ij[first[new]]
            self._n = need
        z = p[:, 2]
        self._sums[rows, 0] += np.bincount(inv, minlength=keys.size)  # rows are distinct
        self._sums[rows, 1] += np.bincount(inv, weights=z, minlength=keys.size)
        self._sums[rows, 2] += np.bincount(inv, weights=z * z, minlength=keys.size)

    def noise(self, min_cells: int) -> float:
        """The seabed noise (m): the median over every cell with 3+ samples of the samples' standard
        deviation about the cell mean; 0 with fewer than ``min_cells`` such cells. Over the whole area
        surveyed so far, objects are a small minority of the cells, so they do not set it."""
        s = self._sums[: self._n]
        ok = s[:, 0] >= 3
        if int(ok.sum()) < min_cells:
            return 0.0
        m = s[ok, 1] / s[ok, 0]
        var = np.maximum(s[ok, 2] / s[ok, 0] - m * m, 0.0)
        return float(np.sqrt(np.median(var)))

    def grid(self, lo: F64, hi: F64) -> tuple[NDArray[np.int64], F64]:
        """Cell index of the box's first cell and the (nx, ny, 3) sums of the cells from ``lo`` to ``hi``."""
        i0 = np.floor(np.asarray(lo) / self.cell).astype(np.int64)
        i1 = np.floor(np.asarray(hi) / self.cell).astype(np.int64)
        shape = (int(i1[0] - i0[0] + 1), int(i1[1] - i0[1] + 1))
        out = np.zeros((*shape, 3))
        ij = self._ij[: self._n]
        sel = np.flatnonzero(np.all((ij >= i0) & (ij <= i1), axis=1))
        out[ij[sel, 0] - i0[0], ij[sel, 1] - i0[1]] = self._sums[sel]
        return i0, out


class TexturedSeabed:
    """Tiled planes + a residual grid that follows the seabed texture; see the module docstring."""

    def __init__(self, coarse: SeabedModel, i0: NDArray[np.int64], cell: float, resid: F64, sigma: float,
                 objects: NDArray[np.bool_], config: TextureConfig) -> None:
        self.coarse, self.i0, self.cell, self.resid = coarse, i0, float(cell), resid
        self.sigma = float(sigma)
        self.object_cells = objects
        self.config = config
        self.level_sigma = 0.0  # m: robust spread of the cells about their neighbourhood's level

    def depth_at(self, xy: ArrayLike) -> F64:
        """Seabed depth (m, NED z) under ``xy`` (N, 2 or 3): planes + bilinear cell residual."""
        q = np.asarray(xy, dtype=np.float64).reshape(-1, np.shape(xy)[-1])[:, :2]
        base = self.coarse.depth_at(q)
        nx, ny = self.resid.shape
        u = q / self.cell - 0.5 - self.i0
        a = np.floor(u).astype(np.int64)
        f = u - a
        out = np.zeros(q.shape[0])
        for di in (0, 1):
            for dj in (0, 1):
                ii = np.clip(a[:, 0] + di, 0, nx - 1)
                jj = np.clip(a[:, 1] + dj, 0, ny - 1)
                w = (f[:, 0] if di else 1.0 - f[:, 0]) * (f[:, 1] if dj else 1.0 - f[:, 1])
                out += w * self.resid[ii, jj]
        return np.asarray(base + out, dtype=np.float64)

    def height_above(self, points: ArrayLike) -> F64:
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return self.depth_at(p) - p[:, 2]

    def covers(self, lo: ArrayLike, hi: ArrayLike) -> bool:
        """True when the horizontal box ``lo``-``hi`` lies inside the fitted grid."""
        a = self.i0 * self.cell
        b = (self.i0 + np.array(self.resid.shape)) * self.cell
        return bool(np.all(np.asarray(lo) >= a) and np.all(np.asarray(hi) <= b))

    def min_height(self, floor: float) -> float:
        """Height (m) above the model from which a point counts as an object point."""
        return max(floor, min(self.config.k_sigma * self.sigma, MAX_SEABED_THRESHOLD_M))


def local_level(r: F64, use: NDArray[np.bool_], size: int, ridge: float) -> F64:
    """Level of the grid ``r`` (nx, ny) at each cell from the cells ``use`` of the ``size`` x ``size`` window
    around it: the least-squares plane through them evaluated at the cell (``ridge`` (cells^2) x their count
    added to the slope terms' normal equations: a window whose cells lie on a line or a point gets a flat
    plane along the directions they do not span). NaN where the window holds no
    cell of ``use``. Vectorized: window sums of the moments (``uniform_filter``) and one batched 3 x 3 solve."""
    w = use.astype(np.float64)
    rw = np.where(use, r, 0.0)

    def wsum(a: F64) -> F64:
        return np.asarray(uniform_filter(a, size=size, mode="constant"), np.float64)

    s0, sr = wsum(w), wsum(rw)
    empty = s0 <= 1e-9
    x, y = np.meshgrid(np.arange(r.shape[0], dtype=np.float64), np.arange(r.shape[1], dtype=np.float64),
                       indexing="ij")
    sx, sy, sxx, sxy, syy = wsum(w * x), wsum(w * y), wsum(w * x * x), wsum(w * x * y), wsum(w * y * y)
    sxr, syr = wsum(rw * x), wsum(rw * y)
    # moments about each window's own centre cell (x0, y0) = (x, y)
    cx, cy = sx - x * s0, sy - y * s0
    cxx = sxx - 2.0 * x * sx + x * x * s0 + ridge * s0
    cyy = syy - 2.0 * y * sy + y * y * s0 + ridge * s0
    cxy = sxy - x * sy - y * sx + x * y * s0
    a = np.stack([np.stack([s0, cx, cy], -1), np.stack([cx, cxx, cxy], -1), np.stack([cy, cxy, cyy], -1)], -2)
    a += np.eye(3) * 1e-9
    b = np.stack([sr, sxr - x * sr, syr - y * sr], -1)
    level = np.linalg.solve(a, b[..., None])[..., 0, 0]
    return np.where(empty, np.nan, level)


def box_plane(depth: F64, use: NDArray[np.bool_]) -> F64:
    """The least-squares plane through the cells ``use`` of the grid ``depth`` (nx, ny; m), at every cell (a
    flat plane at their mean from fewer than 3 cells)."""
    ij = np.argwhere(use).astype(np.float64)
    z = depth[use]
    centre = ij.mean(axis=0)
    coef = np.zeros(2)
    if ij.shape[0] >= 3:
        coef = np.linalg.lstsq(ij - centre, z - z.mean(), rcond=None)[0]
    i, j = np.meshgrid(np.arange(depth.shape[0]), np.arange(depth.shape[1]), indexing="ij")
    return np.asarray(z.mean() + (i - centre[0]) * coef[0] + (j - centre[1]) * coef[1], np.float64)


def fit_textured(cells: SeabedCells, coarse: SeabedModel, lo: ArrayLike, hi: ArrayLike,
                 config: TextureConfig) -> TexturedSeabed:
    """The textured seabed over the box ``lo``-``hi`` (north, east m); see the module docstring."""
    c = cells.cell
    lo_a, hi_a = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    area = np.prod(np.maximum(hi_a - lo_a, c) / c)
    if area > config.max_cells:  # a huge box (a long straight poll gap): bound the work
        grow = np.sqrt(area / config.max_cells)
        mid = 0.5 * (lo_a + hi_a)
        half = 0.5 * (hi_a - lo_a) / grow
        lo_a, hi_a = mid - half, mid + half
    i0, sums = cells.grid(lo_a, hi_a)
    n = sums[..., 0]
    ok = n >= config.min_count
    mean = np.where(ok, sums[..., 1] / np.maximum(n, 1), np.nan)
    centres = (np.stack(np.meshgrid(np.arange(n.shape[0]), np.arange(n.shape[1]), indexing="ij"), -1)
               + i0 + 0.5) * c
    base = coarse.depth_at(centres.reshape(-1, 2)).reshape(n.shape)
    r = mean - base  # + deeper than the planes
    # the neighbourhood planes are fitted to the depth less one plane through the box (the tiles bend)
    shift = box_plane(mean, ok) - base if ok.any() else np.zeros(n.shape)
    size = 2 * max(1, round(config.window_m / c)) + 1
    objects = np.zeros(n.shape, bool)
    med = np.zeros(n.shape)
    sigma_c = config.sigma_floor
    for _ in range(config.iterations):
        use = ok & ~objects
        if not use.any():
            break
        # the level of the seabed cells of the window: empty cells (a narrow swath, the shadows behind objects)
        # and the object cells found so far do not count
        med = local_level(r - shift, use, size, config.level_ridge) + shift
        med = np.where(np.isnan(med), float(np.median(r[use])), med)  # no seabed cell within the window
        d = r - med
        dv = d[ok]  # all cells: the spread of the seabed cells alone shrinks as the crests go to the objects
        if dv.size >= 8:
            sigma_c = max(config.sigma_floor, 1.4826 * float(np.median(np.abs(dv - np.median(dv)))))
        objects = ok & (d < -config.clip_k * sigma_c)  # higher than the neighbourhood: an object
        if objects.any():
            objects = binary_dilation(objects, iterations=max(1, round(config.grow_m / c))) & ok
    seabed = ok & ~objects
    resid = np.where(seabed, r, med)
    sigma = cells.noise(config.min_sigma_cells)
    model = TexturedSeabed(coarse, i0, c, resid, sigma, objects, config)
    model.level_sigma = sigma_c
    return model
