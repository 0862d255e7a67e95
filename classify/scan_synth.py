"""Synthesis mode ``scan``: what recon's highlight extension makes of a mesh on a straight pass.

Geometry only (the mesh; no sonar image is rendered). The paper's shear (:mod:`classify.synthesis`)
models the front slope for one scan direction; here it arises from the beam geometry itself, as in
the reconstruction (``recon.highlight``, exact mode):

* The sonar (96 beams, azimuth -14.5..14.5 deg, ``rays_per_beam`` rays over the vertical spread
  ``s``, pitched down by the tilt ``t``) flies level at altitude ``A`` along the heading ``psi``,
  ``L`` metres to the side of the object, every ``step_m`` metres (10 fps at 1 m/s: 0.1 m).
* Per position and beam, every ray is cast against the mesh (Open3D) and the flat seabed ``z = 0``;
  an object hit nearer than the ray's seabed hit is a return when ``|cos|`` of its incidence angle
  is at least ``c_min`` (the simulator's return scales with ``cos^2``; recon's threshold keeps only
  strong ones), each ``cos`` first multiplied by ``exp(cos_jitter * N(0, 1))`` (speckle: a return
  near the threshold passes or not at random). The beam's first return is the nearest such hit.
* It is a highlight extension when it is closer than the beam's seabed onset (the steepest ray's
  range to the seabed) minus ``onset_margin_m``; recon then places it on the steepest ray
  (elevation ``+s/2`` in the sonar frame, the beam's azimuth) at that range, jittered by a range
  bin (``range_sigma_m``). The front slope, the missing far side and the sparse rows follow.
* Seabed removal: points lower than ``min_height_m`` above the seabed are dropped.

Per view ``A``, ``L``, ``c_min`` and ``min_height_m`` are drawn uniformly from their ranges in
:class:`classify.synthesis.SynthesisSettings` (``altitude_m``, ``lateral_m``, ``min_cos``,
``min_height_m``). Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from classify.synthesis import SynthesisSettings

F64 = npt.NDArray[np.float64]
HALF_FOV_DEG = 14.5
N_BEAMS = 96


def sonar_rays(heading_rad: float, tilt_rad: float, spread_rad: float, k: int) -> tuple[F64, F64]:
    """Unit ray directions ``(k, beams, 3)`` (NED, level vehicle) and the steepest ray per beam ``(beams, 3)``."""
    az = np.radians(np.linspace(-HALF_FOV_DEG, HALF_FOV_DEG, N_BEAMS))
    el = np.linspace(-spread_rad / 2, spread_rad / 2, k)
    ph, th = np.meshgrid(el, az, indexing="ij")
    d_s = np.stack([np.cos(ph) * np.cos(th), np.cos(ph) * np.sin(th), np.sin(ph)], axis=-1)
    ct, st = math.cos(tilt_rad), math.sin(tilt_rad)
    r_bs = np.array([[ct, 0.0, -st], [0.0, 1.0, 0.0], [st, 0.0, ct]])  # pitched down by the tilt
    cp, sp = math.cos(heading_rad), math.sin(heading_rad)
    r_wb = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
    d_w = d_s @ (r_wb @ r_bs).T
    return d_w, d_w[-1]


def scan_points(scene: Any, vertices: F64, heading_rad: float, tilt_rad: float, settings: SynthesisSettings,
                rng: np.random.Generator) -> F64:
    """Highlight-extension points (metres, object frame NED, seabed at ``z = 0``) of one pass."""
    import open3d as o3d

    spread = math.radians(settings.spread_deg)
    alt = float(rng.uniform(*settings.altitude_m))
    lateral = float(rng.uniform(*settings.lateral_m))
    c_min = float(rng.uniform(*settings.min_cos))
    min_h = float(rng.uniform(*settings.min_height_m))
    d, steep = sonar_rays(heading_rad, tilt_rad, spread, settings.rays_per_beam)
    u = np.array([math.cos(heading_rad), math.sin(heading_rad), 0.0])
    w = np.array([-math.sin(heading_rad), math.cos(heading_rad), 0.0])
    radius = float(np.linalg.norm(vertices[:, :2], axis=1).max())
    e = tilt_rad + spread / 2
    # from where the steepest ray meets the seabed a little beyond the object, to past the object
    xs = np.arange(-(alt / math.tan(e) + radius + 1.0), radius + 0.5, settings.step_m)
    xs = xs + rng.uniform(0.0, settings.step_m)
    origins = xs[:, None] * u + lateral * w + np.array([0.0, 0.0, -alt])
    n_pos, k = len(xs), d.shape[0]
    rays = np.empty((n_pos, k, N_BEAMS, 6), dtype=np.float32)
    rays[..., :3] = origins[:, None, None, :]
    rays[..., 3:] = d[None]
    ans = scene.cast_rays(o3d.core.Tensor.from_numpy(rays.reshape(-1, 6)))
    t_hit = ans["t_hit"].numpy().astype(np.float64).reshape(n_pos, k, N_BEAMS)
    cos_a = np.abs((ans["primitive_normals"].numpy().reshape(n_pos, k, N_BEAMS, 3) * d[None]).sum(axis=-1))
    with np.errstate(divide="ignore"):
        r_sea = np.where(d[..., 2] > 0, alt / d[..., 2], np.inf)  # (k, beams): flat seabed, level vehicle
    if settings.cos_jitter > 0:  # speckle: a return near the threshold passes or fails at random
        cos_a = cos_a * np.exp(settings.cos_jitter * rng.standard_normal(cos_a.shape))
    hit = np.isfinite(t_hit) & (t_hit < r_sea[None]) & (cos_a >= c_min)
    first = np.where(hit, t_hit, np.inf).min(axis=1)  # (positions, beams)
    onset = r_sea.min(axis=0)  # the steepest ray's seabed range per beam
    ok = first < onset[None] - settings.onset_margin_m
    pi, bi = np.nonzero(ok)
    r = first[pi, bi] + rng.normal(0.0, settings.range_sigma_m, size=len(pi))
    pts = origins[pi] + r[:, None] * steep[bi]
    return np.asarray(pts[-pts[:, 2] >= min_h])
