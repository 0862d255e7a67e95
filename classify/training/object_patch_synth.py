"""Objects on rough seabeds: what recon's own seabed removal and clustering make of a mesh lying on a drawn patch.

:mod:`classify.training.scan_synth` synthesizes an object's passes over a flat seabed and models recon's seabed error by
augmentation (a depth shift, a tilt, a crest attached). On a rough seabed what recon hands the classifier depends on
the texture under and around the object: the textured seabed fitted through it takes a bump under the object for
seabed or the object's foot for a bump, crests beside it join its cluster, the seabed depth under it is off by the
texture's height. Those views are synthesized here the way :mod:`classify.training.clutter_synth` synthesizes clutter,
from the geometry alone (no sonar image is rendered), with recon's code doing the rest:

* **Patch, object, lines** (drawn per view from :class:`classify.training.synthesis_settings.SynthesisSettings`): a
  seabed of roughness ``object_patch_roughness_m`` and slope ``clutter_slope_deg`` (any azimuth); the class's mesh at
  its origin, any heading, resting on the seabed and tilted with its mean plane (as the simulator places objects,
  :func:`auvlink.sim.object_meshes.object_pose`); 1-3 lawnmower lines (``object_patch_lines``, alternate directions, any
  heading) at an altitude ``clutter_altitude_m``, a tilt between the smallest and the largest of ``tilts_deg``, one
  frame every ``clutter_step_m`` metres, spaced ``clutter_spacing`` times the swath at the onset, the first line
  at a lateral offset that puts the object anywhere in its swath. Each line runs from where its onset is
  ``object_patch_lead_m`` before the object to past it, and is shifted by a misalignment of ``misalign_m``.
* **Returns**: :func:`classify.training.seabed_returns.line_returns` with the mesh as an obstacle (its material's return
  relative to steel's, :func:`auvlink.sim.object_meshes.class_material`).
* **Recon**: :func:`classify.training.clutter_synth.recon_clusters`; the view is the cluster (per line or fused over
  lines) holding the most points within the object's footprint, with the seabed depth recon gives it, after the
  front-slope correction blended by ``correction_blend``. A view whose cluster's centre lies more than
  ``object_patch_offset_m`` from the object (recon would report it elsewhere), or that gives none, is drawn again.

Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import numpy.typing as npt

from auvlink.sim.object_meshes import class_material, object_pose
from auvlink.sim.scene import SceneObject
from auvlink.sim.seabed import SeabedSurface
from classify.errors import SynthesisError
from classify.training.clutter_synth import recon_clusters
from classify.training.scan_synth import recon_correction
from classify.training.seabed_returns import LineReturns, draw_seabed, fly_lines, onset_geometry, relative_to_steel
from classify.training.synthesis_settings import SynthesisSettings
from classify.training.views import training_cloud
from recon.reconstructor import ReconConfig

F64 = npt.NDArray[np.float64]
MAX_TRIES_PER_VIEW = 6  # patches drawn per view asked before giving up


def _placed(class_name: str, vertices: F64, triangles: npt.NDArray[np.integer], seabed: SeabedSurface,
            heading_deg: float) -> tuple[F64, object]:
    """The mesh's world vertices (resting on ``seabed`` at the origin) and an Open3D raycasting scene of it."""
    import open3d as o3d  # lazy: Open3D loads only when clouds are synthesized

    pos, rot = object_pose(SceneObject(class_name, 0.0, 0.0, heading_deg), seabed)
    world = vertices @ rot.as_matrix().T + pos
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor.from_numpy(world.astype(np.float32)),
                        o3d.core.Tensor.from_numpy(np.ascontiguousarray(triangles, dtype=np.uint32)))
    return world, scene


def draw_object_survey(class_name: str, vertices: F64, triangles: npt.NDArray[np.integer],
                       settings: SynthesisSettings, rng: np.random.Generator
                       ) -> tuple[list[LineReturns], int, F64, float, float]:
    """The returns of the lines flown past one object on a drawn patch (module docstring), the frames per poll,
    the object's world vertices, and the first line's heading and the tilt (deg)."""
    seabed = draw_seabed(settings, rng, settings.object_patch_roughness_m)
    world, scene = _placed(class_name, vertices, triangles, seabed, float(rng.uniform(0.0, 360.0)))
    reflection = relative_to_steel(class_material(class_name))
    tilt = math.radians(float(rng.uniform(min(settings.tilts_deg), max(settings.tilts_deg))))
    alt = float(rng.uniform(*settings.clutter_altitude_m))
    ground, swath = onset_geometry(alt, tilt, settings)
    spacing = float(rng.uniform(*settings.clutter_spacing)) * swath * (1.0 if rng.random() < 0.5 else -1.0)
    step = float(rng.uniform(*settings.clutter_step_m))
    lo, hi = (round(v) for v in settings.object_patch_lines)
    n_lines = int(rng.integers(lo, hi + 1))
    psi = float(rng.uniform(0.0, 2 * math.pi))
    threshold = float(rng.uniform(*settings.clutter_energy_threshold))
    radius = float(np.linalg.norm(world[:, :2], axis=1).max())
    y0 = float(rng.uniform(-0.45, 0.45)) * swath  # the object anywhere in the first line's swath
    start = ground + radius + settings.object_patch_lead_m  # the onset object_patch_lead_m before the object
    xs = np.arange(-start, radius + 1.0, step) + rng.uniform(0.0, step)
    paths = [(-xs if j % 2 == 1 else xs, y0 + j * spacing) for j in range(n_lines)]
    lines = fly_lines(seabed, paths, psi, tilt, alt, settings, rng, threshold, (scene, reflection))
    return lines, max(1, round(settings.clutter_poll_m / step)), world, math.degrees(psi) % 360.0, math.degrees(tilt)


def object_patch_view(class_name: str, vertices: F64, triangles: npt.NDArray[np.integer],
                      settings: SynthesisSettings, rng: np.random.Generator, cfg: ReconConfig | None = None
                      ) -> tuple[F64, float, float, float] | None:
    """One view (module docstring): the cluster's points (n, 3) world NED m after the front-slope correction, the
    seabed depth recon gives it (m), and the first line's heading and the tilt (deg); None when the patch gave no
    cluster on the object."""
    cfg = cfg or ReconConfig()
    lines, poll, world, heading, tilt = draw_object_survey(class_name, vertices, triangles, settings, rng)
    c = (world[:, :2].min(axis=0) + world[:, :2].max(axis=0)) / 2
    half = (world[:, :2].max(axis=0) - world[:, :2].min(axis=0)) / 2 + 0.1
    best, best_n = None, 0
    for o, depth in recon_clusters(lines, cfg, poll):
        n_on = int(np.all(np.abs(o.points[:, :2] - c) <= half, axis=1).sum())
        if n_on > best_n:
            best, best_n = (o, depth), n_on
    if best is None:
        return None
    o, depth = best
    if np.linalg.norm(o.centroid[:2] - c) > settings.object_patch_offset_m:
        return None
    spread = math.radians(settings.spread_deg)
    return recon_correction(o.points, o.extra, o.times, depth, spread, cfg.front_slope_length, cfg.front_slope_width,
                            settings, rng), depth, heading, tilt


def synthesize_object_patches(class_name: str, vertices: F64, triangles: npt.NDArray[np.integer],
                              settings: SynthesisSettings, count: int
                              ) -> tuple[npt.NDArray[np.float32], F64]:
    """``count`` views of one class on rough patches as training clouds (:func:`classify.training.views.training_cloud`)
    and their (heading, tilt) in degrees. View ``i`` draws from ``SeedSequence([seed, crc32(class), 7, i, try])``."""
    crc = zlib.crc32(class_name.encode())
    clouds: list[npt.NDArray[np.float32]] = []
    meta: list[tuple[float, float]] = []
    v = np.asarray(vertices, dtype=np.float64)
    for i in range(count):
        for t in range(MAX_TRIES_PER_VIEW):
            rng = np.random.default_rng(np.random.SeedSequence([settings.seed, crc, 7, i, t]))
            got = object_patch_view(class_name, v, triangles, settings, rng)
            if got is None:
                continue
            pts, depth, heading, tilt = got
            cloud, _ = training_cloud(pts, settings, rng, min(len(pts), settings.n_points), depth)
            clouds.append(cloud)
            meta.append((heading, tilt))
            break
    if not clouds:
        raise SynthesisError(f"no view of {class_name!r} on a rough patch gave a cluster on the object "
                             f"({count} asked, {MAX_TRIES_PER_VIEW} patches each)")
    return np.stack(clouds), np.asarray(meta, dtype=np.float64)
