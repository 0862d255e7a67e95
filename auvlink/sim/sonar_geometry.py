"""Geometry of the simulated forward-scan sonar: beams, rays, range bins, mounting.

Sonar frame S: x boresight, y starboard, z down. A return at range ``r``, azimuth ``theta``
(+ to starboard) and elevation ``phi`` (+ downward from the boresight) is
``p_S = r [cos(phi) cos(theta), cos(phi) sin(theta), sin(phi)]``.

- The beams of the scene's sonar model (:attr:`auvlink.sonar.Sonar.description`: the DIDSON's 96 beams
  linear over +-14.5 deg by default, the ARIS SDK tables, the Oculus' sine-law table); beam ``n`` is
  column ``n`` of the image, port first.
- K rays per beam at elevations ``phi_k`` linear from ``-s/2`` to ``+s/2`` (both ends included), i.e.
  ``t - s/2`` .. ``t + s/2`` below the vehicle's horizontal: the steepest ray (``phi = +s/2``) is
  the highlight-extension ray and always present.
- Mounting: ``R_BS = Ry(-tilt)`` (a pitch-down tilt, positive looks down), sonar origin at the
  body-frame lever arm. ``R_WS = R_WB R_BS``.
- ``n_bins`` range bins (the model's samples per beam, 512 for DIDSON/ARIS, or the window over an
  Oculus' range resolution) over ``[start, start + length)``: bin ``m`` covers
  ``start + [m, m + 1) * length / n_bins``, centre ``r_m = start + (m + 0.5) * length / n_bins``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from auvlink.sim.scene import SonarConfig
from auvlink.sonar import DEFAULT_SONAR, DIDSON, SonarDescription

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: range bins of the default (DIDSON) image: its samples per beam
N_BINS = DIDSON.range_lines(DEFAULT_SONAR.window_length)


class RayFan:
    """The simulator's rays of one device: ray directions in S and B, beam per ray, range bins. (Recon's view of
    the same sonar, beams and bins without rays, is :class:`recon.sonar_geometry.SonarGeometry`.)"""

    def __init__(self, config: SonarConfig, rays_per_beam: int | None = None, n_bins: int | None = None,
                 description: SonarDescription | None = None) -> None:
        """The fan of ``config``'s sonar model (or of ``description``); ``n_bins`` overrides its range lines."""
        self.config = config
        self.description = description if description is not None else config.description
        self.n_beams = self.description.n_beams
        if self.description.samples is not None:  # the configured window, as DIDSON and ARIS sample it
            start, length, end = config.window_start, config.window_length, config.window_end
        else:  # an Oculus' range lines start at the transducer
            start, length = self.description.image_window(config.window_start, config.window_length)
            end = start + length
        self.n_bins = n_bins = n_bins if n_bins is not None else self.description.range_lines(length)
        self.k = int(rays_per_beam if rays_per_beam is not None else config.rays_per_beam)
        if self.k < 2:
            raise ValueError("rays_per_beam must be >= 2 (the spread's two edges)")
        self.tilt = math.radians(config.tilt_deg)
        self.spread = math.radians(config.spread_deg)
        self.azimuth = np.radians(np.asarray(self.description.bearings_deg, dtype=np.float64))
        self.elevation = np.linspace(-self.spread / 2.0, self.spread / 2.0, self.k)
        # elevation-major ray order, ray index = k * n_beams + beam: the rays that reach the seabed
        # within a range form (nearly) one contiguous tail, which the seabed refines as a slice
        ph, th = np.meshgrid(self.elevation, self.azimuth, indexing="ij")  # (K, beams)
        d_s = np.stack([np.cos(ph) * np.cos(th), np.cos(ph) * np.sin(th), np.sin(ph)], axis=-1)
        self.dir_s = d_s.reshape(-1, 3)
        self.beam_of_ray = np.tile(np.arange(self.n_beams), self.k)
        self.r_bs = Rotation.from_euler("y", -self.tilt)
        self.dir_b = self.r_bs.apply(self.dir_s)
        self.dir_b_soa = np.ascontiguousarray(self.dir_b.T)  # (3, N) rows for fast per-frame math
        self.lever_arm = np.asarray(config.lever_arm, float)
        self.window_start, self.window_end = start, end
        self.bin_width = length / n_bins
        self.range_of_bin = start + (np.arange(n_bins) + 0.5) * self.bin_width
        self._inv_bin = n_bins / length

    @property
    def n_rays(self) -> int:
        return self.n_beams * self.k

    def bin_of_range(self, r: F64) -> I64:
        """Range bin of each range; -1 outside the window (and for ``inf``)."""
        r = np.asarray(r, float)
        with np.errstate(invalid="ignore"):
            m = np.floor((r - self.window_start) * self._inv_bin)
        ok = np.isfinite(m) & (m >= 0) & (m < self.n_bins)
        return np.where(ok, m, -1).astype(np.int64)

    def cells_of_rays(self, r: F64) -> tuple[NDArray[np.bool_], I64]:
        """Rays whose range falls in the window, and their flat cells ``bin * n_beams + beam``."""
        x = (r - self.window_start) * self._inv_bin  # inf stays inf
        ok = (x >= 0.0) & (x < self.n_bins)
        return ok, x[ok].astype(np.int64) * self.n_beams + self.beam_of_ray[ok]

    def rays_world(self, position: F64, r_wb: F64) -> tuple[F64, F64]:
        """Sonar origin (3,) and unit ray directions as (3, N) rows, world frame, for ``R_WB``."""
        origin = np.asarray(position, float).reshape(3) + r_wb @ self.lever_arm
        return origin, np.dot(r_wb, self.dir_b_soa)

    def sonar_rotation(self, rotation: Rotation) -> Rotation:
        """``R_WS`` from ``R_WB``."""
        return rotation * self.r_bs

    def candidate_rays(self, origin: F64, r_wb: F64, d: F64, centres: F64, radii: F64,
                       current: F64, reach: float) -> tuple[list[int], list[I64]]:
        """Objects whose bounding sphere a ray can reach before its current return, with the rays.

        ``d`` holds the unit world ray directions as (3, N) rows; a ray's limit is
        ``min(current + 1 mm, reach)`` (its seabed range, the window end). Three stages, each
        conservative (a ray left out cannot hit the mesh inside the sphere before its limit): the
        sphere's distance against ``reach``; its direction against the fan (elevation within
        ``s/2 + a``, azimuth within the haversine bound, ``a`` the sphere's angular radius), which
        also narrows the beams to test; then an exact ray-sphere test on those beams' rays.
        """
        vc = centres - origin
        dist = np.sqrt((vc * vc).sum(axis=1))
        near = np.flatnonzero(dist - radii <= reach)
        objects: list[int] = []
        rays: list[I64] = []
        if not near.size:
            return objects, rays
        v_s = vc[near] @ (r_wb @ self.r_bs.as_matrix())  # rows: centres in the sonar frame
        half_s = self.spread / 2.0
        for j, v, dj in zip(near, v_s, dist[near], strict=True):
            r = float(radii[j])
            lo, hi = 0, self.n_beams
            if dj > r:
                a = math.asin(r / dj)
                el = math.asin(max(-1.0, min(1.0, v[2] / dj)))
                if abs(el) > half_s + a:
                    continue
                cos_els = math.cos(half_s) * math.cos(min(abs(el), math.pi / 2))
                hav = math.sin(a / 2.0) ** 2 / (cos_els + 1e-300)
                if hav < 1.0:
                    az, daz = math.atan2(v[1], v[0]), 2.0 * math.asin(math.sqrt(hav)) + 1e-9
                    lo = int(np.searchsorted(self.azimuth, az - daz, side="left"))
                    hi = int(np.searchsorted(self.azimuth, az + daz, side="right"))
                    if lo >= hi:
                        continue
            d_sub = d.reshape(3, self.k, self.n_beams)[:, :, lo:hi]  # (3, K, beams lo..hi)
            proj = np.tensordot(vc[j], d_sub, axes=1)
            disc = r * r - (dj * dj - proj * proj)
            half = np.sqrt(np.maximum(disc, 0.0))
            limit = np.minimum(current.reshape(self.k, self.n_beams)[:, lo:hi] + 1e-3, reach)
            kk, nn = np.nonzero((disc >= 0.0) & (proj + half >= 0.0) & (proj - half <= limit))
            if kk.size:
                objects.append(int(j))
                rays.append(kk * self.n_beams + nn + lo)
        return objects, rays

