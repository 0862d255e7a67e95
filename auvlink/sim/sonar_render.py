"""Simulated forward-scan sonar images (Sung et al. 2021, section 4.1.1), n_bins x n_beams of the sonar model.

For one sonar pose: K rays per beam (:mod:`auvlink.sim.sonar_geometry`) are intersected with the
seabed analytically (:mod:`auvlink.sim.seabed`) and with the scene's object meshes by Open3D's
``RaycastingScene`` (Embree); each ray keeps its nearest hit, so objects cast shadows on the
seabed behind them. Each hit returns ``I = w R I0 cos^2(alpha) / r^2`` into its (range bin, beam)
cell (equation 9), then speckle and log quantization give the uint8 image
(:mod:`auvlink.sim.speckle`). Image layout: ``image[m, n]`` = range bin ``m`` (near to far),
beam ``n`` (port to starboard).

Skipping what a frame does not need (``cull``):

- ``"rays"`` (default): one raycasting scene with every object; only rays whose line passes through
  the bounding sphere of an object, before both the seabed hit and the window end, are cast.
  A frame with no object in view casts nothing and costs only the analytic seabed.
- ``"objects"``: one raycasting scene per object; each in-view object gets only its own rays.
- ``"none"``: every ray is cast against every object (reference; same image bytes).

Acoustic profile: the scene's ``[acoustics]`` table (:mod:`auvlink.sim.acoustics`); without one, or with one
that names no profile, the realistic profile of the scene's sonar model
(:func:`~auvlink.sim.acoustics.rendered_table`). A realistic profile samples ``elevation_samples`` rays per
beam over its vertical extent (:func:`sampled_aperture`) and forms the image with
:class:`~auvlink.sim.acoustic_image.AcousticImager` (:meth:`SonarRenderer.realistic`); ``profile = "ideal"``
renders the idealized model above.

Randomness: all draws go through the ``numpy.random.Generator`` passed in; :func:`frame_rng`
derives one per frame from the run's seed, so a frame renders the same bytes in any order.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
import open3d as o3d
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from auvlink.sim.acoustic_image import AcousticImager
from auvlink.sim.acoustics import Acoustics, rendered_table, resolve
from auvlink.sim.object_meshes import bounding_sphere, class_material, object_pose, placed_mesh
from auvlink.sim.scene import Scene, SonarConfig
from auvlink.sim.seabed import SeabedSurface
from auvlink.sim.sonar_geometry import RayFan
from auvlink.sim.speckle import AcousticModel

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
U8 = NDArray[np.uint8]
Cull = Literal["rays", "objects", "none"]

SONAR_STREAM = 0x50AA
MISS, SEABED, OBJECT = 0, 1, 2


def frame_rng(seed: int, frame: int) -> np.random.Generator:
    """The generator for sonar frame ``frame`` of a run seeded with ``seed``."""
    return np.random.default_rng(np.random.SeedSequence([seed, SONAR_STREAM, frame]))


@dataclass(frozen=True)
class RayHits:
    """Nearest hit of every ray of one frame (ray index = k * n_beams + beam, k = elevation index)."""

    origin: F64  # (3,) sonar origin, world NED
    dirs: F64  # (3, N) unit ray directions, world NED, as rows
    range: F64  # (N,) m, inf where the ray hits nothing
    intensity: F64  # (N,) return strength (0 for a miss)
    kind: NDArray[np.int8]  # MISS, SEABED or OBJECT
    object_index: NDArray[np.int32]  # index into scene.objects, -1 unless kind == OBJECT

    @property
    def directions(self) -> F64:
        """(N, 3) unit ray directions."""
        return self.dirs.T

    @property
    def points(self) -> F64:
        """(N, 3) hit points in the world frame (non-finite rows for misses)."""
        with np.errstate(invalid="ignore"):
            return self.origin + self.range[:, None] * self.dirs.T


class SonarRenderer:
    """Renders sonar frames of a scene from vehicle (body) poses."""

    def __init__(self, scene: Scene, *, rays_per_beam: int | None = None, cull: Cull = "rays",
                 speckle: bool = True, model: AcousticModel | None = None,
                 seabed: SeabedSurface | None = None) -> None:
        if cull not in ("rays", "objects", "none"):
            raise ValueError(f"cull must be 'rays', 'objects' or 'none', not {cull!r}")
        self.scene, self.cull, self.speckle = scene, cull, speckle
        self.model = model if model is not None else AcousticModel()
        self.seabed = seabed if seabed is not None else SeabedSurface(scene.seabed, scene.seed)
        self.acoustics = resolve(rendered_table(scene.acoustics, scene.sonar), scene.sonar.frequency_mode or "high")
        self.imager: AcousticImager | None = None
        if self.acoustics is None:
            self.geometry = RayFan(scene.sonar, rays_per_beam)
        else:
            self.geometry = RayFan(sampled_aperture(scene.sonar, self.acoustics), rays_per_beam)
            self.imager = AcousticImager(self.acoustics, self.geometry, scene.seed)
        n_obj = len(scene.objects)
        self.centres, self.radii = np.zeros((n_obj, 3)), np.zeros(n_obj)
        self.gain = np.zeros(n_obj)
        sb = self.model.seabed_material
        self.seabed_gain = self.model.source_level * sb.weight * sb.reflection
        self._all = o3d.t.geometry.RaycastingScene()
        self._each: list[o3d.t.geometry.RaycastingScene] = []
        for j, obj in enumerate(scene.objects):
            mat = class_material(obj.class_name)
            self.gain[j] = self.model.source_level * mat.weight * mat.reflection
            v, f = placed_mesh(obj, self.seabed)
            vt = o3d.core.Tensor.from_numpy(np.ascontiguousarray(v, np.float32))
            ft = o3d.core.Tensor.from_numpy(np.ascontiguousarray(f, np.uint32))
            if self._all.add_triangles(vt, ft) != j:
                raise RuntimeError("Open3D geometry ids do not follow insertion order")
            one = o3d.t.geometry.RaycastingScene()
            one.add_triangles(vt, ft)
            self._each.append(one)
            c, r = bounding_sphere(obj.class_name)
            pos, rot = object_pose(obj, self.seabed)
            self.centres[j], self.radii[j] = rot.as_matrix() @ c + pos, r

    # --- rays --------------------------------------------------------------------------------
    def trace(self, position: F64, yaw: float, pitch: float, roll: float) -> RayHits:
        """Nearest hit and return strength of every ray for a body pose (NED m, rad)."""
        return self.trace_matrix(position, Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix())

    def trace_matrix(self, position: F64, r_wb: F64) -> RayHits:
        """As :meth:`trace` with the attitude given as the matrix ``R_WB`` (3, 3)."""
        g = self.geometry
        origin, d = g.rays_world(position, r_wb)
        rng_, nrm = self.seabed.intersect_soa(origin, d, max_range=g.window_end)
        if nrm.strides[1] == 0:  # one normal for every ray (a plane)
            cos_a = np.abs(np.dot(nrm[:, 0], d))
        else:
            cos_a = np.abs((nrm * d).sum(axis=0))
        cos_a *= cos_a
        inten = self.seabed_gain * cos_a / (rng_ * rng_)  # 0 where the range is inf (a miss)
        kind = np.isfinite(rng_).astype(np.int8)  # MISS = 0, SEABED = 1
        obj_idx = np.full(rng_.size, -1, np.int32)
        if self.scene.objects:
            self._cast_objects(origin, r_wb, d, rng_, inten, kind, obj_idx)
        return RayHits(origin, d, rng_, inten, kind, obj_idx)

    def _cast_objects(self, origin: F64, r_wb: F64, d: F64, rng_: F64, inten: F64,
                      kind: NDArray[np.int8], obj_idx: NDArray[np.int32]) -> None:
        """Replace seabed returns by nearer object hits, in place."""
        if self.cull == "none":
            self._cast(self._all, origin, d, np.arange(d.shape[1]), rng_, inten, kind, obj_idx)
            return
        g = self.geometry
        objects, rays = g.candidate_rays(origin, r_wb, d, self.centres, self.radii, rng_, g.window_end)
        if self.cull == "rays":
            if objects:
                sel = rays[0] if len(rays) == 1 else np.unique(np.concatenate(rays))
                self._cast(self._all, origin, d, sel, rng_, inten, kind, obj_idx)
            return
        for j, sel in zip(objects, rays, strict=True):
            self._cast(self._each[j], origin, d, sel, rng_, inten, kind, obj_idx, only=j)

    def _cast(self, scene: o3d.t.geometry.RaycastingScene, origin: F64, d: F64, sel: I64, rng_: F64,
              inten: F64, kind: NDArray[np.int8], obj_idx: NDArray[np.int32], only: int = -1) -> None:
        """Cast rays ``sel``; where a hit is nearer than the current return and within the range window, it
        replaces it (an object past the window's end is left out as the seabed is, whatever the culling)."""
        rays = np.empty((sel.size, 6), np.float32)
        rays[:, :3] = origin
        rays[:, 3:] = d[:, sel].T
        ans = scene.cast_rays(o3d.core.Tensor.from_numpy(rays))
        t = ans["t_hit"].numpy().astype(np.float64)
        better = np.flatnonzero((t < rng_[sel]) & (t <= self.geometry.window_end))
        if not better.size:
            return
        idx = sel[better]
        t = t[better]
        if only >= 0:
            ids = np.full(idx.size, only, np.int32)
        else:
            ids = ans["geometry_ids"].numpy()[better].astype(np.int32)
        cos_a = np.abs((ans["primitive_normals"].numpy()[better] * d[:, idx].T).sum(axis=1))
        rng_[idx] = t
        inten[idx] = self.gain[ids] * cos_a * cos_a / (t * t)
        kind[idx] = OBJECT
        obj_idx[idx] = ids

    # --- image -------------------------------------------------------------------------------
    def returns(self, hits: RayHits) -> tuple[I64, F64]:
        """Equation (9), sparse: sorted unique flat cells ``bin * n_beams + beam`` and their sums."""
        g = self.geometry
        ok, cells = g.cells_of_rays(hits.range)
        total = np.bincount(cells, weights=hits.intensity[ok], minlength=g.n_bins * g.n_beams)
        seen = np.zeros(g.n_bins * g.n_beams, bool)
        seen[cells] = True
        uniq = np.flatnonzero(seen).astype(np.int64)
        return uniq, np.asarray(total[uniq], np.float64)

    def intensity(self, hits: RayHits) -> F64:
        """Equation (9), dense: returns summed per (range bin, beam); float64 (n_bins, n_beams)."""
        g = self.geometry
        cells, values = self.returns(hits)
        img = np.zeros(g.n_bins * g.n_beams)
        img[cells] = values
        return img.reshape(g.n_bins, g.n_beams)

    def realistic(self, hits: RayHits, rng: np.random.Generator | None = None) -> U8:
        """One frame under the scene's realistic profile (:mod:`auvlink.sim.acoustic_image`)."""
        if self.imager is None:
            raise ValueError("the scene's acoustic profile is ideal: use image()")
        obj = hits.kind == OBJECT
        surface = hits.object_index  # -1 unless the sample hit an object
        strength = np.append(self.gain, self.seabed_gain)[hits.object_index]  # index -1: the seabed
        with np.errstate(invalid="ignore"):
            cos2 = np.where(hits.kind == MISS, 0.0, hits.intensity * hits.range * hits.range / strength)
        # objects: the seabed's mu times the ideal model's contrast (material gain over the seabed's)
        diffuse = self.imager.mu * np.where(obj, strength / self.seabed_gain * self.imager.object_scale, 1.0)
        paths = surface_paths(hits) if self.imager.multipath else None  # multipath ghosts (shallow water)
        energy = self.imager.expected(hits.range, cos2, diffuse, surface, paths)
        return self.imager.display(energy, rng if self.speckle else None)

    def image(self, hits: RayHits, rng: np.random.Generator | None = None) -> U8:
        """Speckle (if enabled; needs ``rng``) and quantize one frame's returns to uint8 (n_bins, n_beams)."""
        if self.imager is not None:
            return self.realistic(hits, rng)
        g = self.geometry
        size = g.n_bins * g.n_beams
        cells, values = self.returns(hits)
        if self.speckle:
            if rng is None:
                raise ValueError("speckle needs a numpy Generator (see frame_rng)")
            flat = self.model.speckle_cells(size, cells, values, rng)
        else:
            flat = np.zeros(size, np.uint8)
            flat[cells] = self.model.quantize(values)
        return flat.reshape(g.n_bins, g.n_beams)

    def render(self, position: F64, yaw: float, pitch: float, roll: float,
               rng: np.random.Generator | None = None) -> U8:
        """One uint8 frame (n_bins range bins x n_beams beams, :class:`RayFan`) for a body pose (NED m, rad)."""
        return self.image(self.trace(position, yaw, pitch, roll), rng)

    def render_sequence(self, positions: F64, rotations: Rotation, seed: int,
                        first_frame: int = 0) -> Iterator[U8]:
        """Frames for body poses (F, 3) and ``R_WB`` (F); frame ``i`` uses ``frame_rng(seed, i)``."""
        mats = rotations.as_matrix().reshape(-1, 3, 3)
        for i, (p, m) in enumerate(zip(np.asarray(positions, float), mats, strict=True)):
            rng = frame_rng(seed, first_frame + i) if self.speckle else None
            yield self.image(self.trace_matrix(p, m), rng)


def surface_paths(hits: RayHits) -> F64:
    """Each sample's path (m) from the sonar's image above the sea surface (``z = 0``, world NED) to its hit:
    the leg over the surface of its multipath echo (inf for a miss)."""
    image = hits.origin * np.array([1.0, 1.0, -1.0])
    with np.errstate(invalid="ignore"):
        return np.asarray(np.linalg.norm(hits.points - image, axis=1), np.float64)


def sampled_aperture(sonar: SonarConfig, acoustics: Acoustics) -> SonarConfig:
    """The scene's sonar with the realistic profile's sampled elevations: ``elevation_samples`` over
    ``vertical_extent`` times the vertical width, kept below the vertical and within 60 deg."""
    extent = acoustics.vertical_extent * acoustics.vertical_width_deg
    extent = min(extent, 60.0, 2.0 * (89.0 - sonar.tilt_deg))
    return replace(sonar, spread_deg=extent, rays_per_beam=acoustics.elevation_samples)
