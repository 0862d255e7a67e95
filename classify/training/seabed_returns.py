"""The returns of one straight level line over the simulator's rough seabed (and, where given, an object's mesh), as
recon's highlight search and seabed sampling see them: the ray model shared by :mod:`classify.training.clutter_synth`
(seabed patches with no object) and :mod:`classify.training.object_patch_synth` (an object lying on a patch).

Every ray of the fan (``clutter_rays_per_beam`` per beam) is intersected with the seabed
(:meth:`auvlink.sim.seabed.SeabedSurface.intersect_soa`) and, with an obstacle, with its mesh (Open3D); its return
is that of :func:`classify.training.scan_synth.energy_first_return` (the simulator's ``cos^2 / r^2``, speckle
``cos_jitter``, recon's threshold and run rule), times the reflection of what it met relative to the steel the object
synthesis is calibrated on (:data:`auvlink.sim.object_meshes.MATERIALS`). A first return closer than the steepest ray's
onset on the mean plane less ``onset_margin_m`` is a highlight-extension point, placed on the steepest ray (range lag
``range_bias_m``, jitter ``range_sigma_m``); the first return in the band after the onset is a seabed return
(recon's ``returns_between``), and the seabed under the vehicle a DVL bottom point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.sim.object_meshes import MATERIALS, Material
from auvlink.sim.scene import Seabed
from auvlink.sim.seabed import SeabedSurface
from classify.training.scan_synth import HALF_FOV_DEG, arc_vectors, energy_first_return, sonar_rays
from classify.training.synthesis_settings import SynthesisSettings
from recon.range_arcs import RangeArcs, arc_record
from recon.seabed_memory import PLANE_BEAM_STEP, PLANE_FRAME_STEP, TEXTURE_BEAM_STEP

F64 = npt.NDArray[np.float64]
_CHUNK = 64  # positions per energy evaluation


def relative_to_steel(material: Material) -> float:
    """A material's return (weight x reflection coefficient) relative to the steel the object synthesis is
    calibrated on (:data:`auvlink.sim.object_meshes.MATERIALS`)."""
    steel = MATERIALS["steel"]
    return (material.weight * material.reflection) / (steel.weight * steel.reflection)


#: the seabed's return relative to steel's (sand / steel, ~0.36)
SEABED_REFLECTION = relative_to_steel(MATERIALS["sand"])


@dataclass
class LineReturns:
    """What one line gives recon, world NED m: highlight points (with their arcs and times), seabed samples."""

    points: F64  # (n, 3) highlight-extension points on the steepest ray
    arcs: F64  # (n, 10) their range arcs (origin, u, w, range), as recon.range_arcs.arc_columns
    times: F64  # (n,) s
    frame: npt.NDArray[np.int64]  # (n,) position index along the line
    dvl: F64  # (P, 3) the DVL's bottom point under the vehicle, one per frame (texture grid and planes)
    texture: F64  # (m, 3) seabed returns of every 2nd beam (the texture grid's samples)
    sparse: F64  # (k, 3) seabed returns of every 5th frame, every 4th beam (the tiled planes' samples)
    texture_frame: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))
    sparse_frame: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))

    def shift(self, offset: F64) -> None:
        """Move everything by ``offset`` (3,) m: the line's navigation error."""
        for a in (self.points, RangeArcs.of(self.arcs).origin, self.dvl, self.texture, self.sparse):
            a += offset


def _plane_ranges(seabed: SeabedSurface, origins: F64, d: F64) -> F64:
    """Ranges (P, beams) along unit directions ``d`` (beams, 3) from ``origins`` (P, 3) to the mean plane."""
    g = seabed.grad_plane
    gap = seabed.plane_depth(origins[:, 0], origins[:, 1]) - origins[:, 2]
    denom = d[:, 2] - d[:, :2] @ g
    with np.errstate(divide="ignore"):
        return np.where(denom[None] > 1e-9, gap[:, None] / denom[None], np.inf)


def line_returns(seabed: SeabedSurface, origins: F64, heading: float, tilt: float, settings: SynthesisSettings,
                 rng: np.random.Generator, t0: float, dt: float, threshold: float,
                 obstacle: tuple[Any, float] | None = None) -> LineReturns:
    """Returns of one straight level line over ``seabed`` (sonar at ``origins`` (P, 3), NED m); see the module doc.

    ``obstacle``: an Open3D ``RaycastingScene`` of an object's mesh (world NED m) and its return relative to
    steel's (:mod:`classify.training.object_patch_synth`); a ray returns from whichever it meets first."""
    spread = math.radians(settings.spread_deg)
    k = settings.clutter_rays_per_beam
    d, steep = sonar_rays(heading, tilt, spread, k)  # (k, beams, 3), (beams, 3)
    n_beams = steep.shape[0]
    d_soa = np.ascontiguousarray(d.reshape(-1, 3).T)
    onset = _plane_ranges(seabed, origins, steep)  # (P, beams): the steepest ray's onset on the mean plane
    far = float(np.nanmax(np.where(np.isfinite(onset), onset, np.nan))) + 2.0
    # a ray's return does not depend on how many rays the fan has; energy_first_return divides by k
    amp = math.sqrt(SEABED_REFLECTION * k / settings.rays_per_beam)
    margin, band = settings.onset_margin_m, 1.0
    bias = float(rng.uniform(*settings.range_bias_m))
    first = np.full(onset.shape, np.inf)
    in_band = np.full(onset.shape, np.inf)
    for s in range(0, len(origins), _CHUNK):
        sl = slice(s, s + _CHUNK)
        o = origins[sl]
        t_hit = np.empty((len(o), k, n_beams))
        cos_a = np.empty((len(o), k, n_beams))
        for i, oi in enumerate(o):
            r, nrm = seabed.intersect_soa(oi, d_soa, max_range=far)
            t_hit[i] = r.reshape(k, n_beams)
            cos_a[i] = np.abs((nrm * d_soa).sum(axis=0)).reshape(k, n_beams)
        cos_a *= amp
        if obstacle is not None:
            _hit_obstacle(obstacle, o, d, t_hit, cos_a, math.sqrt(k / settings.rays_per_beam))
        if settings.cos_jitter > 0:
            cos_a *= np.exp(settings.cos_jitter * rng.standard_normal(cos_a.shape))
        hit = np.isfinite(t_hit) & (t_hit < far)
        first[sl] = energy_first_return(t_hit, cos_a, hit, threshold, settings.bin_m, settings.min_run,
                                        span=settings.span_bins)
        lo = (onset[sl] - margin)[:, None, :]
        in_band[sl] = energy_first_return(t_hit, cos_a, hit & (t_hit >= lo) & (t_hit < lo + band), threshold,
                                          settings.bin_m, settings.min_run, span=settings.span_bins)
    first = first + bias
    pi, bi = np.nonzero(first < onset - margin)
    r = first[pi, bi] + rng.normal(0.0, settings.range_sigma_m, size=pi.size)
    pts = origins[pi] + r[:, None] * steep[bi]
    u, w = arc_vectors(heading, tilt)
    arcs = arc_record(origins[pi], u[bi], np.broadcast_to(w, (pi.size, 3)), r)
    # seabed returns (as recon: every frame, every TEXTURE_BEAM_STEP-th beam for the texture grid; every
    # PLANE_FRAME_STEP-th frame, every PLANE_BEAM_STEP-th beam for the tiled planes) and the DVL's bottom points
    sp, sb = np.nonzero(np.isfinite(in_band))
    rs = in_band[sp, sb] + bias + rng.normal(0.0, settings.range_sigma_m, size=sp.size)
    sea = origins[sp] + rs[:, None] * steep[sb]
    tex = sb % TEXTURE_BEAM_STEP == 0
    sparse = (sb % PLANE_BEAM_STEP == 0) & (sp % PLANE_FRAME_STEP == 0)
    dvl = np.column_stack([origins[:, :2], seabed.depth(origins[:, 0], origins[:, 1])])
    times = np.asarray(t0 + dt * pi, dtype=np.float64)
    return LineReturns(pts, arcs, times, pi, dvl, sea[tex], sea[sparse], sp[tex], sp[sparse])


def _hit_obstacle(obstacle: tuple[Any, float], origins: F64, d: F64, t_hit: F64, cos_a: F64, steel_amp: float) -> None:
    """Where a ray ``d`` (k, beams, 3) from ``origins`` (P, 3) meets the obstacle's mesh before the seabed, its range
    and return (``|cos|`` times the obstacle's amplitude) replace the seabed's in ``t_hit``, ``cos_a`` (P, k, beams)."""
    import open3d as o3d  # lazy: Open3D loads only when clouds are synthesized

    scene, reflection = obstacle
    n_pos, k, n_beams = t_hit.shape
    rays = np.empty((n_pos, k, n_beams, 6), dtype=np.float32)
    rays[..., :3] = origins[:, None, None, :]
    rays[..., 3:] = d[None]
    ans = scene.cast_rays(o3d.core.Tensor.from_numpy(rays.reshape(-1, 6)))
    t_obj = ans["t_hit"].numpy().astype(np.float64).reshape(t_hit.shape)
    nearer = np.isfinite(t_obj) & (t_obj < t_hit)
    if nearer.any():
        cos_obj = np.abs((ans["primitive_normals"].numpy().reshape(n_pos, k, n_beams, 3) * d[None]).sum(axis=-1))
        t_hit[nearer] = t_obj[nearer]
        cos_a[nearer] = cos_obj[nearer] * steel_amp * math.sqrt(reflection)


def draw_seabed(settings: SynthesisSettings, rng: np.random.Generator, roughness_m: tuple[float, float]
                ) -> SeabedSurface:
    """A patch's seabed: 30 m deep, a slope drawn from ``clutter_slope_deg`` (any azimuth), a roughness drawn from
    ``roughness_m`` (m rms), its texture seeded from ``rng``."""
    sb = Seabed(depth=30.0, slope_deg=float(rng.uniform(*settings.clutter_slope_deg)),
                slope_azimuth_deg=float(rng.uniform(0.0, 360.0)), roughness=float(rng.uniform(*roughness_m)))
    return SeabedSurface(sb, int(rng.integers(0, 2**31 - 1)))


def onset_geometry(altitude: float, tilt: float, settings: SynthesisSettings) -> tuple[float, float]:
    """The horizontal distance (m) from the sonar to the steepest ray's onset on a level seabed ``altitude`` m
    below, and the swath's width there (m); ``tilt`` in radians."""
    ground = altitude / math.tan(tilt + math.radians(settings.spread_deg) / 2)
    return ground, 2.0 * math.hypot(ground, altitude) * math.sin(math.radians(HALF_FOV_DEG))


def fly_lines(seabed: SeabedSurface, paths: list[tuple[F64, float]], psi: float, tilt: float, altitude: float,
              settings: SynthesisSettings, rng: np.random.Generator, threshold: float,
              obstacle: tuple[Any, float] | None = None) -> list[LineReturns]:
    """The returns of lawnmower lines ``altitude`` m above the seabed's mean plane: line ``j`` runs through the
    positions ``paths[j][0]`` (m along the heading ``psi``, rad) at ``paths[j][1]`` m to its right, along ``psi``
    for even ``j`` and back for odd ones; each line shifted by a misalignment of ``misalign_m`` in a random
    direction (dead reckoning between lines), one frame per position, a 30-frame turn between lines."""
    fwd = np.array([math.cos(psi), math.sin(psi)])
    side = np.array([-math.sin(psi), math.cos(psi)])
    lines, t0 = [], 0.0
    for j, (along, lateral) in enumerate(paths):
        xy = along[:, None] * fwd + lateral * side
        origins = np.column_stack([xy, seabed.plane_depth(xy[:, 0], xy[:, 1]) - altitude])
        heading = psi + math.pi if j % 2 == 1 else psi
        lr = line_returns(seabed, origins, heading, tilt, settings, rng, t0, 1.0, threshold, obstacle)
        a = float(rng.uniform(0.0, 2 * math.pi))
        lr.shift(np.array([math.cos(a), math.sin(a), 0.0]) * float(rng.uniform(*settings.misalign_m)))
        lines.append(lr)
        t0 += len(origins) + 30.0  # frames, and a turn between lines
    return lines
