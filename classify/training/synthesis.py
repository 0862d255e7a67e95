"""Training clouds synthesized from a mesh, after Sung et al. (sections 3.4 and 4.2.1 of the
forward-scan-sonar PointNet paper): what a pass of the sonar would reconstruct of an object.

Per scan direction (heading ``psi`` of the pass, sonar tilt ``t``, vertical spread ``s``):

1. **Back-face culling** with the direction of the steepest ray, in the object's NED frame
   (z down; the paper's z is up, hence its ``-tan``)::

       v_fss = (cos psi, sin psi, +tan(t + s/2))

   A face with outward normal ``N`` is hidden when ``v_fss . N >= 0``.
2. **Hidden-surface removal**: points are sampled uniformly (area-weighted) on the remaining faces;
   from each, a ray is cast back along ``-v_fss`` (Open3D ``RaycastingScene``) and the point is
   dropped when other geometry lies on it. Options beyond the paper (off by default): faces are
   weighted by ``cos(a)^incidence_power`` (``a`` the angle between the face normal and ``-v_fss``;
   a sonar return scales with ``cos^2``) and faces with ``cos(a) < min_incidence_cos`` are dropped
   (too weak to pass the highlight threshold); points lower than a height drawn from
   ``seabed_cut_m`` above the seabed are dropped (recon's seabed removal takes that band);
   ``slope_only`` keeps only the sheared (front-slope) points, as a recon whose threshold loses the
   weaker returns of tops would see them.
3. **Front slope** (the paper's equation (5), derived here for the exact beam geometry): the
   reconstruction puts every highlight-extension return on the steepest ray, at elevation
   ``e = t + s/2`` below horizontal. Before the steepest ray reaches an object, the first return
   of a column is the top of its front (height ``H`` above the seabed); at range ``r`` it is
   placed at height ``h = A - r sin e`` for a sonar at altitude ``A``, i.e. *in front of* the
   object. The top front edge thus draws a slope that leaves the true edge (``h = H``) and
   reaches the seabed ahead of it. A point at height ``h`` on that slope lies a horizontal
   distance::

       delta(h) = sqrt((A - h)^2 / sin(e)^2 - (A - H)^2) - (A - h) / tan(e)

   ahead of the edge (towards the sonar). ``delta(H) = 0``; ``delta(0) ~= H tan(e)`` for
   ``A >> H``; at A = 5 m, H = 1 m, e = 37 deg it is 0.65 m. We implement it as a shear of the
   visible points along the scan's horizontal direction: the points are cut into columns across
   the scan (``column_m`` wide); in each column, with ``H`` the height of its highest point, every
   point in front of that top point (closer to the sonar) at height ``h`` is moved by
   ``-delta(h)`` along ``(cos psi, sin psi, 0)``. A vertical front face becomes the slope; tops
   and the far side of the top stay. ``A`` is drawn per view from ``altitude_m``.
4. **Noise**: ``round(f * n_points)`` 3D Gaussian points, ``f`` uniform in ``noise_fraction``,
   drawn around the surface points' mean with their per-axis standard deviation times
   ``noise_scale``.
5. **Sampling and scaling**: ``n_points`` points in all (surface without replacement where there
   are enough), centred on their mean and divided by the largest norm (unit sphere).

Every random draw comes from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from classify.errors import SynthesisError
from classify.normalize import normalize_cloud, normalize_unit_sphere
from classify.training.synthesis_settings import SynthesisSettings
from classify.training.views import scan_view, training_cloud

F64 = npt.NDArray[np.float64]
F32 = npt.NDArray[np.float32]
__all__ = ["MeshSynthesizer", "SynthesisSettings", "normalize_cloud", "normalize_unit_sphere"]


def scan_direction(heading_rad: float, tilt_rad: float, spread_rad: float) -> F64:
    """The steepest ray's direction ``(cos psi, sin psi, tan(t + s/2))`` in NED (not normalized)."""
    e = tilt_rad + spread_rad / 2.0
    if not 0.0 < e < math.pi / 2:
        raise SynthesisError(f"steepest-ray elevation t + s/2 = {math.degrees(e):.1f} deg not in (0, 90)")
    return np.array([math.cos(heading_rad), math.sin(heading_rad), math.tan(e)])


def face_normals(vertices: F64, triangles: npt.NDArray[np.integer[Any]]) -> tuple[F64, F64]:
    """Unnormalized face normals ``(v1 - v0) x (v2 - v0)`` and the face areas."""
    v0, v1, v2 = (vertices[triangles[:, i]] for i in range(3))
    n = np.cross(v1 - v0, v2 - v0)
    return n, 0.5 * np.linalg.norm(n, axis=1)


def front_faces(vertices: F64, triangles: npt.NDArray[np.integer[Any]], v_fss: F64) -> npt.NDArray[np.bool_]:
    """Faces not culled: ``v_fss . N < 0`` (and of non-zero area)."""
    n, area = face_normals(vertices, triangles)
    return (n @ v_fss < 0.0) & (area > 0.0)


def sample_surface(vertices: F64, triangles: npt.NDArray[np.integer[Any]], mask: npt.NDArray[np.bool_],
                   n: int, rng: np.random.Generator, weights: F64 | None = None) -> F64:
    """``n`` points uniform over the area of the faces in ``mask`` (times ``weights[mask]`` if given)."""
    tri = triangles[mask]
    if len(tri) == 0 or n <= 0:
        return np.empty((0, 3))
    _, area = face_normals(vertices, tri)
    w = area if weights is None else area * weights[mask]
    if not w.sum() > 0:
        return np.empty((0, 3))
    idx = rng.choice(len(tri), size=n, p=w / w.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1.0
    u[flip], v[flip] = 1.0 - u[flip], 1.0 - v[flip]
    v0, v1, v2 = (vertices[tri[idx, i]] for i in range(3))
    return v0 + u[:, None] * (v1 - v0) + v[:, None] * (v2 - v0)


def unoccluded(scene: Any, points: F64, v_fss: F64, eps: float = 1e-4) -> npt.NDArray[np.bool_]:
    """Points from which a ray cast back along ``-v_fss`` hits no geometry (``scene``: Open3D)."""
    import open3d as o3d  # lazy: Open3D loads only when clouds are synthesized (not for inference)

    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    back = -v_fss / np.linalg.norm(v_fss)
    rays = np.empty((len(points), 6), dtype=np.float32)
    rays[:, :3] = points + eps * back
    rays[:, 3:] = back
    t_hit = scene.cast_rays(o3d.core.Tensor.from_numpy(rays))["t_hit"].numpy()
    return np.asarray(~np.isfinite(t_hit))


def slope_offset(h: F64, top: F64, altitude: float, elevation_rad: float) -> F64:
    """``delta(h)``: horizontal distance of the front slope ahead of a top edge at height ``top``."""
    s, c = math.sin(elevation_rad), math.cos(elevation_rad)
    h = np.minimum(np.maximum(h, 0.0), top)
    arg = np.maximum((altitude - h) ** 2 / s**2 - (altitude - top) ** 2, 0.0)
    return np.asarray(np.maximum(np.sqrt(arg) - (altitude - h) * c / s, 0.0))


def front_slope(points: F64, heading_rad: float, elevation_rad: float, altitude: float,
                column_m: float) -> F64:
    """Shear the points in front of each column's top into the highlight-extension slope."""
    if len(points) == 0:
        return points
    u_dir = np.array([math.cos(heading_rad), math.sin(heading_rad), 0.0])
    w_dir = np.array([-math.sin(heading_rad), math.cos(heading_rad), 0.0])
    height = -points[:, 2]
    if float(height.max()) >= altitude:
        raise SynthesisError(f"object height {height.max():.2f} m reaches the sonar altitude {altitude} m")
    u = points @ u_dir
    col = np.floor((points @ w_dir) / column_m).astype(np.int64)
    col -= col.min()
    order = np.lexsort((height, col))  # by column, then height: the last of each column is its top
    last = np.r_[np.nonzero(np.diff(col[order]))[0], len(order) - 1]
    top_idx = np.empty(int(col.max()) + 1, dtype=np.int64)
    top_idx[col[order][last]] = order[last]
    top_h, top_u = height[top_idx[col]], u[top_idx[col]]
    front = u < top_u
    delta = np.zeros(len(points))
    delta[front] = slope_offset(height[front], top_h[front], altitude, elevation_rad)
    return points - delta[:, None] * u_dir


class MeshSynthesizer:
    """Synthesizes views of one mesh (vertices ``(N,3)``, triangles ``(M,3)``; object frame, NED)."""

    def __init__(self, vertices: npt.ArrayLike, triangles: npt.ArrayLike) -> None:
        import open3d as o3d  # lazy: Open3D loads only when clouds are synthesized (not for inference)

        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.triangles = np.asarray(triangles, dtype=np.int64)
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3 or self.triangles.ndim != 2 \
                or self.triangles.shape[1] != 3 or len(self.triangles) == 0:
            raise SynthesisError("a mesh needs vertices (N, 3) and triangles (M, 3), M > 0")
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor.from_numpy(self.vertices.astype(np.float32)),
                                 o3d.core.Tensor.from_numpy(self.triangles.astype(np.uint32)))

    def visible_points(self, heading_rad: float, tilt_rad: float, settings: SynthesisSettings,
                       rng: np.random.Generator) -> F64:
        """Steps 1-3: culled, occlusion-filtered, sheared surface points (metres, object frame)."""
        spread = math.radians(settings.spread_deg)
        v = scan_direction(heading_rad, tilt_rad, spread)
        mask = front_faces(self.vertices, self.triangles, v)
        weights = None
        if settings.incidence_power > 0 or settings.min_incidence_cos > 0:
            n, area = face_normals(self.vertices, self.triangles)
            cos = -(n @ v) / np.maximum(area * 2.0, 1e-300) / np.linalg.norm(v)
            mask &= cos >= settings.min_incidence_cos
            weights = np.clip(cos, 0.0, 1.0) ** settings.incidence_power
        pts = sample_surface(self.vertices, self.triangles, mask, settings.candidates, rng, weights)
        pts = pts[unoccluded(self.scene, pts, v)]
        if settings.seabed_cut_m[1] > 0:
            cut = float(rng.uniform(*settings.seabed_cut_m))
            above = pts[:, 2] <= -cut
            if above.any():  # never cut a whole (very flat) object away
                pts = pts[above]
        if settings.front_slope and len(pts):
            altitude = float(rng.uniform(*settings.altitude_m))
            sheared = front_slope(pts, heading_rad, tilt_rad + spread / 2, altitude, settings.column_m)
            moved = np.abs(sheared - pts).max(axis=1) > 1e-6  # moved by more than rounding
            pts = sheared[moved] if settings.slope_only and moved.sum() >= 8 else sheared
        return pts

    def view(self, heading_rad: float, tilt_rad: float, settings: SynthesisSettings,
             rng: np.random.Generator) -> tuple[F32, npt.NDArray[np.bool_]]:
        """One training cloud ``(n_points, 3)`` float32 in the unit sphere, and its noise mask.

        Mode ``scan``: a view (:func:`classify.training.views.scan_view`: one pass, or fused passes, whole or partial)
        whose highlight extension gave fewer than 8 points is drawn again (up to 20 times; altitude, lateral
        offset and thresholds are drawn per pass); noise points are a fraction of the surface points found (a
        sparse cloud keeps its duplicates)."""
        n = settings.n_points
        if settings.mode == "scan":
            for _ in range(20):
                surf = scan_view(self.scene, self.vertices, heading_rad, tilt_rad, settings, rng)
                if len(surf) >= 8:
                    break
            else:
                raise SynthesisError("no highlight extension in 20 passes from this scan direction")
            n_found = min(len(surf), n)
        else:
            surf = self.visible_points(heading_rad, tilt_rad, settings, rng)
            n_found = n
        if len(surf) == 0:
            raise SynthesisError("no surface is visible from this scan direction")
        return training_cloud(surf, settings, rng, n_found)
