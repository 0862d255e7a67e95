"""Seabed model from seabed points, and seabed removal by height above it.

The seabed is fitted per square tile (``tile`` m, grid anchored at the world origin) with a plane
depth = c0 + c1 dx + c2 dy (dx, dy from the tile centre), by iteratively reweighted least squares:
after a plain fit, the first refit keeps the deeper half of the points (objects only stand above
the seabed), the next ones give weight 0 to points farther than ``clip_sigma`` sigmas from the
current fit (objects, mis-detections), sigma being the tile's weighted RMS residual floored at
``sigma_floor``. Each tile's fit also uses the points within ``overlap`` tiles of its border, and a
small ridge term keeps the slope at zero along any direction the points do not span (a single
survey line). Depth at a query point is the bilinear blend of the four surrounding tiles' planes
evaluated at that point (no steps at tile borders); a tile without enough points borrows its
nearest fitted neighbour.

Seabed points come from the DVL (vehicle position + altitude along NED down,
:meth:`recon.trajectory.Trajectory.seabed_points`) and from the sonar's own seabed returns (the first
return at the seabed onset lies on the steepest ray, so it is a seabed point). Removal keeps the
points whose height above the local seabed is at least ``min_height``, so sloped seabeds work. The
default 0.05 m is low on purpose: the first detections of an object edge lie on the steepest ray
just short of the onset, about margin x sin(t + s/2) = 0.06 m above the seabed, and a low object
(a 0.3 m half pipe) is a highlight for only a few frames; the front-slope correction raises them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from recon.errors import ReconError
from recon.seabed_irls import TilePairs, irls_planes

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class SeabedConfig:
    tile: float = 6.0  # m
    overlap: float = 0.5  # fraction of a tile added around each tile for its fit
    min_points: int = 8
    iterations: int = 5
    clip_sigma: float = 3.0
    sigma_floor: float = 0.05  # m
    ridge: float = 0.05  # pulls a tile's slope to the regional plane's (a tile its points do not span)
    regional_span: float = 2.0  # m: the regional plane's slope shrinks to 0 for points spanning much less
    min_height: float = 0.05  # m above the seabed to count as an object point (first detections: ~margin sin(t + s/2))
    max_height: float = 10.0  # m: higher returns (fish, surface) are dropped
    #: s a point removed as seabed is tested again by later polls: a survey line of the envelope and the turn to the
    #: next (50 m at 0.5-1.5 m/s: 35-100 s), so the adjacent line's seabed samples reach the model under it
    revisit_s: float = 120.0


def _key(ij: NDArray[np.int64]) -> NDArray[np.int64]:
    return (ij[..., 0] << 32) + (ij[..., 1] & 0xFFFFFFFF)


class SeabedModel:
    """Tiled robust plane fit of the seabed; see the module docstring."""

    def __init__(self, tile: float, ij: NDArray[np.int64], coef: F64, regional: F64 | None = None,
                 span: float = float("inf")) -> None:
        if ij.shape[0] == 0:
            raise ReconError("seabed model has no fitted tile (too few seabed points)")
        self.tile = float(tile)
        #: (depth at the centre, d depth / d north, d depth / d east, centre north, centre east): one plane
        #: through all the points, for tiles without points of their own
        self.regional = regional
        #: m: the larger horizontal extent of the points fitted (inf when not known)
        self.span = float(span)
        order = np.argsort(_key(ij))
        self.ij = ij[order]
        self.coef = coef[order]
        self._keys = _key(self.ij)
        self._tree = cKDTree(self.ij.astype(np.float64))

    @classmethod
    def fit(cls, points: ArrayLike, config: SeabedConfig | None = None) -> SeabedModel:
        cfg = config or SeabedConfig()
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        p = p[np.all(np.isfinite(p), axis=1)]
        t = cfg.tile
        regional = regional_plane(p, cfg)
        # each tile fits its departure from the regional plane; the ridge pulls its slope to the regional one
        base = _plane_depth(regional, p[:, :2]) if regional is not None else np.zeros(p.shape[0])
        # every (point, tile) pair: the point's tile and the neighbours whose expanded box holds it
        pairs = TilePairs(p, t, cfg.overlap)
        tix, counts, n_t = pairs.tix, pairs.counts, pairs.counts.size
        z = p[pairs.point, 2] - base[pairs.point]
        coef, w = irls_planes(pairs.dx, pairs.dy, z, tix, counts, cfg.ridge, cfg)
        good = np.bincount(tix, weights=w, minlength=n_t) >= cfg.min_points
        good &= counts >= cfg.min_points
        ij = pairs.ij
        if regional is not None:  # back to absolute planes
            coef[:, 0] += _plane_depth(regional, np.asarray((ij + 0.5) * t, np.float64))
            coef[:, 1] += regional[1] * t
            coef[:, 2] += regional[2] * t
        span = float(np.max(np.ptp(p[:, :2], axis=0))) if p.shape[0] else 0.0
        return cls(t, ij[good], coef[good], regional, span)

    def _lookup(self, ij: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """Index of each tile's plane (the nearest fitted tile where it has none) and whether it had one."""
        k = _key(ij)
        pos = np.clip(np.searchsorted(self._keys, k), 0, self._keys.size - 1)
        found = self._keys[pos] == k
        if not np.all(found):
            _, near = self._tree.query(ij[~found].astype(np.float64))
            pos[~found] = near
        return pos, found

    def _blend(self, q: F64) -> tuple[F64, F64]:
        """Depth and its horizontal gradient (N, 2) at ``q``: bilinear blend of the 4 tile planes."""
        u = q / self.tile - 0.5
        i0 = np.floor(u).astype(np.int64)
        fr = u - i0
        depth = np.zeros(q.shape[0])
        grad = np.zeros((q.shape[0], 2))
        for di in (0, 1):
            for dj in (0, 1):
                idx, found = self._lookup(i0 + np.array([di, dj]))
                c = self.coef[idx]
                d = q / self.tile - (self.ij[idx] + 0.5)
                wx = fr[:, 0] if di else 1.0 - fr[:, 0]
                wy = fr[:, 1] if dj else 1.0 - fr[:, 1]
                if self.regional is not None and not found.all():
                    # a tile without points: the regional plane (a neighbour's plane extrapolated over
                    # several metres put the onset ahead of a new line 0.5-1.5 m too deep)
                    c = c.copy()
                    lost = ~found
                    c[lost, 0] = _plane_depth(self.regional, q[lost])
                    c[lost, 1], c[lost, 2] = self.regional[1] * self.tile, self.regional[2] * self.tile
                    d = d.copy()
                    d[lost] = 0.0
                plane = c[:, 0] + c[:, 1] * d[:, 0] + c[:, 2] * d[:, 1]
                depth += wx * wy * plane
                grad[:, 0] += ((1.0 if di else -1.0) * wy * plane + wx * wy * c[:, 1]) / self.tile
                grad[:, 1] += ((1.0 if dj else -1.0) * wx * plane + wx * wy * c[:, 2]) / self.tile
        return depth, grad

    def depth_at(self, xy: ArrayLike) -> F64:
        """Seabed depth (NED z, m) below the horizontal positions ``xy`` (N, 2) (or (N, 3))."""
        q = np.asarray(xy, dtype=np.float64).reshape(-1, np.shape(xy)[-1])[:, :2]
        return self._blend(q)[0]

    def height_above(self, points: ArrayLike) -> F64:
        """Height (m) of NED points above the seabed: seabed depth - point depth."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return self.depth_at(p) - p[:, 2]

    def plane_at(self, xy: ArrayLike) -> tuple[F64, F64]:
        """Seabed points (N, 3) under ``xy`` and unit normals (N, 3) pointing up (into the water)."""
        q = np.asarray(xy, dtype=np.float64).reshape(-1, np.shape(xy)[-1])[:, :2]
        z, g = self._blend(q)
        n = np.column_stack([g, -np.ones(q.shape[0])])
        return np.column_stack([q, z]), n / np.linalg.norm(n, axis=1, keepdims=True)


def _plane_depth(plane: F64, q: F64) -> F64:
    """Depth of a :func:`regional_plane` at the horizontal positions ``q`` (N, 2)."""
    return np.asarray(plane[0] + plane[1] * (q[:, 0] - plane[3]) + plane[2] * (q[:, 1] - plane[4]), np.float64)


def regional_plane(p: F64, cfg: SeabedConfig) -> F64 | None:
    """One plane through all the points (N, 3), fitted as each tile's (deeper half first, then points
    within ``clip_sigma`` sigmas): (depth at the centre, gradient north, gradient east, centre north,
    centre east); None with fewer than ``min_points``."""
    if p.shape[0] < cfg.min_points:
        return None
    c = p[:, :2].mean(axis=0)
    d = p[:, :2] - c  # metres from the centre
    # the slope is trusted only where the points span more than ~regional_span m: on a rough seabed the
    # slope over a few metres is the texture's (10 deg and more), not the seabed's
    coef, _ = irls_planes(d[:, 0], d[:, 1], p[:, 2], np.zeros(p.shape[0], np.int64), np.array([p.shape[0]]),
                          cfg.regional_span**2, cfg)
    return np.array([coef[0, 0], coef[0, 1], coef[0, 2], c[0], c[1]])


def object_mask(points: ArrayLike, model: SeabedModel, config: SeabedConfig | None = None
                ) -> NDArray[np.bool_]:
    """True for the points to keep: min_height <= height above the local seabed <= max_height."""
    cfg = config or SeabedConfig()
    h = model.height_above(points)
    return (h >= cfg.min_height) & (h <= cfg.max_height)
