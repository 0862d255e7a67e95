"""Synthetic sonar frames from known geometry, for tests and benchmarks (not the simulator).

A ray caster on analytic shapes: each beam's vertical fan is sampled by ``n_elev`` rays, intersected
with a seabed plane, spheres and yawed boxes resting anywhere. Per beam the image holds the seabed
band (from the beam's first seabed hit to its last, ``seabed_level``), object hits
(``object_level``, ``thickness`` bins deep) and speckle noise; so the first return above the seabed
onset is known exactly (:func:`render` also returns it). :func:`surface_distance` measures how far
reconstructed points are from the true surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.sonar_geometry import SonarGeometry, points_sonar

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Sphere:
    center: tuple[float, float, float]
    radius: float


@dataclass(frozen=True)
class Box:
    """Box centred at ``center`` (NED), ``size`` (length along its x, width, height), yawed."""

    center: tuple[float, float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0


@dataclass(frozen=True)
class Scene:
    seabed_point: tuple[float, float, float] = (0.0, 0.0, 20.0)
    seabed_normal: tuple[float, float, float] = (0.0, 0.0, -1.0)  # up, into the water
    spheres: tuple[Sphere, ...] = ()
    boxes: tuple[Box, ...] = ()
    seabed_level: int = 110
    object_level: int = 210
    noise_level: int = 14
    thickness: int = 4
    rayleigh: bool = False  # speckle: Rayleigh background of scale noise_level (else uniform 0..noise_level)
    extra: dict[str, float] = field(default_factory=dict)

    def seabed_depth(self, xy: ArrayLike) -> F64:
        q = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        n = np.asarray(self.seabed_normal, float)
        p0 = np.asarray(self.seabed_point, float)
        return p0[2] - (n[0] * (q[:, 0] - p0[0]) + n[1] * (q[:, 1] - p0[1])) / n[2]


def sloped_scene(depth: float, slope_deg: float, azimuth_deg: float = 0.0, **kw: object) -> Scene:
    """Seabed ``depth`` m at the origin, depth increasing by tan(slope) towards ``azimuth``."""
    s, a = np.deg2rad(slope_deg), np.deg2rad(azimuth_deg)
    grad = np.tan(s) * np.array([np.cos(a), np.sin(a)])
    n = np.array([grad[0], grad[1], -1.0])
    n /= np.linalg.norm(n)
    return Scene(seabed_point=(0.0, 0.0, depth), seabed_normal=(float(n[0]), float(n[1]), float(n[2])), **kw)  # type: ignore[arg-type]


def _ray_hits(o: F64, d: F64, scene: Scene) -> tuple[F64, F64]:
    """Ranges to the seabed and to the nearest object along rays o + t d (inf = no hit)."""
    n = np.asarray(scene.seabed_normal, float)
    q = np.asarray(scene.seabed_point, float)
    nd = d @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t_sb = np.where(nd < -1e-12, ((q - o) @ n) / nd, np.inf)
    t_sb = np.where(t_sb > 0, t_sb, np.inf)
    t_obj = np.full(d.shape[:-1], np.inf)
    for s in scene.spheres:
        oc = o - np.asarray(s.center, float)
        b = d @ oc
        c = oc @ oc - s.radius**2
        disc = b * b - c
        t = -b - np.sqrt(np.maximum(disc, 0.0))
        t_obj = np.minimum(t_obj, np.where((disc >= 0) & (t > 0), t, np.inf))
    for bx in scene.boxes:
        rot = Rotation.from_euler("z", bx.yaw)
        ol = rot.inv().apply(o - np.asarray(bx.center, float))
        dl = rot.inv().apply(d.reshape(-1, 3)).reshape(d.shape)
        half = 0.5 * np.asarray(bx.size, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-half - ol) / dl
            t2 = (half - ol) / dl
        tmin = np.nanmax(np.minimum(t1, t2), axis=-1)
        tmax = np.nanmin(np.maximum(t1, t2), axis=-1)
        t_obj = np.minimum(t_obj, np.where((tmax >= tmin) & (tmin > 0), tmin, np.inf))
    return t_sb, np.where(t_obj < t_sb, t_obj, np.inf)


def render(geometry: SonarGeometry, position: ArrayLike, rotation: Rotation, scene: Scene,
           rng: np.random.Generator, n_elev: int = 48, gain: float = 1.0) -> tuple[NDArray[np.uint8], F64]:
    """One frame: the (n_bins, n_beams) uint8 image and per beam the true first-return point (NaN)."""
    g = geometry
    m_wb = rotation.as_matrix().reshape(3, 3)
    m_ws = m_wb @ g.mounting.rotation.as_matrix()
    o = np.asarray(position, float).reshape(3) + m_wb @ g.mounting.lever
    phi = np.linspace(-0.5 * g.spread, 0.5 * g.spread, n_elev)
    d = points_sonar(1.0, g.azimuths[:, None], phi[None, :]) @ m_ws.T  # (beams, elev, 3)
    t_sb, t_obj = _ray_hits(o, d, scene)
    if scene.rayleigh:
        img = rng.rayleigh(scene.noise_level, size=(g.n_bins, g.n_beams))
    else:
        img = rng.integers(0, max(1, scene.noise_level), size=(g.n_bins, g.n_beams)).astype(np.float64)
    rows = np.arange(g.n_bins)[:, None]
    sb_lo = np.floor(g.range_to_row(np.min(t_sb, axis=1)) + 0.5)
    sb_hi = np.floor(g.range_to_row(np.max(np.where(np.isfinite(t_sb), t_sb, -np.inf), axis=1)) + 0.5)
    band = (rows >= sb_lo[None]) & (rows <= sb_hi[None])
    img = np.where(band, scene.seabed_level * rng.uniform(0.7, 1.3, img.shape), img)
    hit_rows = np.floor(g.range_to_row(t_obj) + 0.5)
    for k in range(scene.thickness):
        bi, ei = np.nonzero(np.isfinite(t_obj) & (hit_rows + k < g.n_bins) & (hit_rows + k >= 0))
        img[(hit_rows[bi, ei] + k).astype(int), bi] = scene.object_level * rng.uniform(0.85, 1.15, bi.size)
    first = np.min(np.minimum(t_sb, t_obj), axis=1)
    arg = np.argmin(np.minimum(t_sb, t_obj), axis=1)
    truth = o + first[:, None] * d[np.arange(g.n_beams), arg]
    truth[~np.isfinite(np.min(t_obj, axis=1))] = np.nan
    return np.clip(img * gain, 0, 255).astype(np.uint8), truth


def surface_distance(points: ArrayLike, scene: Scene) -> F64:
    """Distance (m) of each point to the nearest object surface of ``scene``."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    best = np.full(p.shape[0], np.inf)
    for s in scene.spheres:
        best = np.minimum(best, np.abs(np.linalg.norm(p - np.asarray(s.center), axis=1) - s.radius))
    for bx in scene.boxes:
        loc = Rotation.from_euler("z", bx.yaw).inv().apply(p - np.asarray(bx.center, float))
        q = np.abs(loc) - 0.5 * np.asarray(bx.size, float)
        outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
        inside = np.minimum(q.max(axis=1), 0.0)
        best = np.minimum(best, np.abs(outside + inside))
    return best
