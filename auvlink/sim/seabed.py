"""The simulated seabed: an analytic sloped plane plus a seeded, smooth rough surface.

Depth (m, NED z, positive down) at north ``n`` and east ``e``::

    D(n, e) = depth + tan(slope) * (n cos(az) + e sin(az)) + h(n, e)

where ``az`` is ``slope_azimuth_deg`` (the direction in which depth increases) and ``h`` is the
roughness: a sum of ``M`` sinusoids with seeded directions, wavelengths (log-uniform in
0.5..8 m) and phases, each of amplitude ``roughness * sqrt(2 / M)`` so that the rms of ``h`` over
the plane is ``roughness``. ``h`` is smooth, so the surface normal is analytic.

Rays are intersected analytically with the plane; the roughness is then handled by iterations
along the ray from the plane hit, kept inside the band ``|h| <= h_max``: fixed-point steps (the
plane shifted by ``h`` at the last iterate), the last one a Newton step whose gradient also gives
the hit's normal (``iterations``, default 2: within 0.2 mm for 99 % of rays, 2 mm at most, at
2 cm rms and sonar depression angles). The trigonometry of ``h`` runs in float32 (phase error
~1e-4 rad at 1 km from the origin).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from auvlink.sim.scene import Seabed

F64 = NDArray[np.float64]

#: SeedSequence stream tag for the seabed's roughness draws (so other streams stay independent).
SEABED_STREAM = 0x5EABED
N_WAVES = 8


class SeabedSurface:
    """Analytic seabed of a scene; vectorized depth, gradient, normal and ray intersection."""

    def __init__(self, seabed: Seabed, seed: int = 0, *, iterations: int = 2) -> None:
        self.seabed = seabed
        self.iterations = iterations
        slope = math.tan(math.radians(seabed.slope_deg))
        az = math.radians(seabed.slope_azimuth_deg)
        self.grad_plane = np.array([slope * math.cos(az), slope * math.sin(az)])
        rng = np.random.default_rng(np.random.SeedSequence([seed, SEABED_STREAM]))
        wavelength = np.exp(rng.uniform(math.log(0.5), math.log(8.0), N_WAVES))
        direction = rng.uniform(0.0, 2.0 * math.pi, N_WAVES)
        k = 2.0 * math.pi / wavelength
        # wave vectors as a (2, M) matrix so that phase = [n, e] @ kvec + phase0
        self.kvec = np.stack([k * np.cos(direction), k * np.sin(direction)])
        self.phase0 = rng.uniform(0.0, 2.0 * math.pi, N_WAVES)
        self.amplitude = seabed.roughness * math.sqrt(2.0 / N_WAVES)
        self.rough = seabed.roughness > 0.0
        self.h_max = N_WAVES * self.amplitude  # bound on |h|
        self._plane_normal = _up_normal(self.grad_plane)
        self._denom_row = np.array([-self.grad_plane[0], -self.grad_plane[1], 1.0])
        self._k32 = self.kvec.astype(np.float32)
        self._phase32 = self.phase0.astype(np.float32)
        self._amp32 = np.full(N_WAVES, self.amplitude, np.float32)
        self._kamp32 = (self.kvec * self.amplitude).astype(np.float32)

    # --- surface ----------------------------------------------------------------------------
    def plane_depth(self, north: F64 | float, east: F64 | float) -> F64:
        """Depth of the mean (smooth) plane."""
        g = self.grad_plane
        return np.asarray(self.seabed.depth + g[0] * np.asarray(north) + g[1] * np.asarray(east))

    def roughness_height(self, north: F64 | float, east: F64 | float) -> tuple[F64, F64]:
        """``h`` (positive = deeper) and its gradient ``(dh/dn, dh/de)`` stacked on the last axis."""
        n, e = np.broadcast_arrays(np.asarray(north, float), np.asarray(east, float))
        h, grad = self._rough_soa(n.reshape(-1), e.reshape(-1))
        return h.reshape(n.shape), np.moveaxis(grad, 0, -1).reshape((*n.shape, 2))

    def _rough_soa(self, north: F64, east: F64, gradient: bool = True) -> tuple[F64, F64]:
        """``h`` (N,) and gradient (2, N) at flat positions (float32 trigonometry: ~10x faster).

        With ``gradient=False`` the returned gradient is an empty (2, 0) array.
        """
        if not self.rough:
            return np.zeros(north.shape), np.zeros((2, *north.shape))
        ne = np.stack([north, east]).astype(np.float32)  # (2, N)
        phase = np.dot(self._k32.T, ne)  # (M, N)
        phase += self._phase32[:, None]
        h = np.dot(self._amp32, np.sin(phase)).astype(np.float64)
        if not gradient:
            return h, np.zeros((2, 0))
        return h, np.dot(self._kamp32, np.cos(phase)).astype(np.float64)  # (2, N)

    def depth(self, north: F64 | float, east: F64 | float) -> F64:
        """Seabed depth (m, positive down) at the given north/east positions."""
        h, _ = self.roughness_height(north, east)
        return self.plane_depth(north, east) + h

    def gradient(self, north: F64 | float, east: F64 | float) -> F64:
        """``(dD/dn, dD/de)`` on the last axis."""
        _, grad = self.roughness_height(north, east)
        return np.asarray(grad + self.grad_plane)

    def normal(self, north: F64 | float, east: F64 | float) -> F64:
        """Unit surface normal pointing up, out of the seabed into the water (NED)."""
        return _up_normal(self.gradient(north, east))

    # --- rays -------------------------------------------------------------------------------
    def intersect(self, origin: F64, directions: F64) -> tuple[F64, F64]:
        """Ranges along unit ``directions`` (N, 3) from ``origin`` (3,) to the seabed.

        Returns ``(r, normals)``: ``r`` is ``inf`` where the ray never reaches the seabed (points up
        or runs parallel to it); ``normals`` (N, 3) are the up-pointing unit normals at the hits.
        """
        r, normals = self.intersect_soa(np.asarray(origin, float).reshape(3),
                                        np.ascontiguousarray(np.asarray(directions, float).T))
        return r, np.ascontiguousarray(normals.T)

    def intersect_soa(self, origin: F64, d: F64, max_range: float = math.inf) -> tuple[F64, F64]:
        """As :meth:`intersect` with directions and normals laid out as (3, N) rows.

        Rays whose plane hit lies beyond ``max_range`` plus the roughness band are not refined for
        the roughness (their range and normal are the plane's): for callers that ignore ranges past
        ``max_range`` (the sonar's window end). On a plane the normals are one broadcast column.
        """
        g = self.grad_plane
        denom = np.dot(self._denom_row, d)  # d_z - g . d_ne
        gap = self.seabed.depth + g[0] * origin[0] + g[1] * origin[1] - origin[2]  # plane depth - z
        if gap <= 0.0:  # at or below the seabed: nothing to see
            return np.full(denom.size, np.inf), np.broadcast_to(self._plane_normal[:, None], d.shape)
        hit = denom > 1e-9
        r = np.full(denom.size, np.inf)
        np.divide(gap, denom, out=r, where=hit)
        if not self.rough:
            return r, np.broadcast_to(self._plane_normal[:, None], d.shape)
        normals = np.empty_like(d)
        normals[:] = self._plane_normal[:, None]
        idx = np.flatnonzero(r <= max_range + self.h_max / np.where(hit, denom, 1.0))
        if idx.size == r.size:
            r, normals = self._refine(origin, d, r, denom, gap)
        elif idx.size:
            sl = slice(int(idx[0]), int(idx[-1]) + 1)
            if hit[sl].all():  # refine the span from the first to the last such ray: views, no gather
                r[sl], normals[:, sl] = self._refine(origin, d[:, sl], r[sl], denom[sl], gap)
            else:
                r[idx], normals[:, idx] = self._refine(origin, d[:, idx], r[idx], denom[idx], gap)
        return r, normals

    def _refine(self, origin: F64, d: F64, r: F64, den: F64, gap: float) -> tuple[F64, F64]:
        """Ranges and normals on the rough surface for rays that hit the plane at ``r``.

        Fixed-point steps (the plane shifted by ``h`` at the last iterate), the last one a Newton
        step on ``f(r) = z(r) - D(n(r), e(r))`` whose gradient also gives the normal; the iterate
        stays in the band ``|h| <= h_max``. Along a ray each wave's phase is linear in ``r``.
        """
        band = self.h_max / den
        lo, hi = r - band, r + band
        a = (self._k32.T @ origin[:2].astype(np.float32) + self._phase32)[:, None]  # (M, 1)
        b = np.dot(self._k32.T, d[:2].astype(np.float32))  # (M, N)
        grad = np.zeros((2, r.size))
        for i in range(self.iterations):
            phase = b * r.astype(np.float32)
            phase += a
            last = i == self.iterations - 1
            if last:
                grad = np.dot(self._kamp32, np.cos(phase)).astype(np.float64)
            h = np.dot(self._amp32, np.sin(phase, out=phase)).astype(np.float64)
            step = den
            if last:
                slope = den - grad[0] * d[0] - grad[1] * d[1]
                step = np.where(slope > 0.5 * den, slope, den)  # fixed point where ill-conditioned
            r = np.clip(r - (r * den - gap - h) / step, lo, hi)
        gx, gy = grad[0] + self.grad_plane[0], grad[1] + self.grad_plane[1]
        inv = 1.0 / np.sqrt(gx * gx + gy * gy + 1.0)
        return r, np.stack([gx * inv, gy * inv, -inv])


def _up_normal(grad: F64) -> F64:
    """Normal ``(D_n, D_e, -1) / norm`` of the surface ``z = D(n, e)`` (points to smaller z, up)."""
    grad = np.asarray(grad, float)
    n = np.concatenate([grad, -np.ones((*grad.shape[:-1], 1))], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
