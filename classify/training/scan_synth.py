"""Synthesis mode ``scan``: what recon's highlight extension makes of a mesh on a straight pass.

Geometry only (the mesh; no sonar image is rendered). The paper's shear (:mod:`classify.training.synthesis`)
models the front slope for one scan direction; here it arises from the beam geometry itself, as in
the reconstruction (``recon.highlight``, exact mode):

* The sonar (the DIDSON's beams and azimuths, :data:`auvlink.sonar.DIDSON`, ``rays_per_beam`` rays over the
  vertical spread ``s``, pitched down by the tilt ``t``) flies level at altitude ``A`` along the heading ``psi``,
  ``L`` metres to the side of the object, every ``step_m`` metres (10 fps at 1 m/s: 0.1 m).
* Per position and beam, every ray is cast against the mesh (Open3D) and the flat seabed ``z = 0``;
  an object hit nearer than the ray's seabed hit is a return when ``|cos|`` of its incidence angle
  is at least ``c_min`` (the simulator's return scales with ``cos^2``; recon's threshold keeps only
  strong ones), each ``cos`` first multiplied by ``exp(cos_jitter * N(0, 1))`` (speckle: a return
  near the threshold passes or not at random). The beam's first return is the nearest such hit.
* Detection ``"energy"`` (the shipped model's) replaces the per-ray ``|cos|`` test: each ray returns
  ``cos^2 (r0 / r)^2 / K`` into its range bin (the simulator's and the sonar equation's ``cos^2 / r^2``),
  a beam's rays are summed per bin, and the first bin that, with ``min_run - 1`` more among the ``run_span_m``
  after it, holds at least a threshold drawn from ``energy_threshold`` is the beam's first return (recon's
  threshold and run length on the image). A grazing hit on a rounded top, alone in its bin, is too
  weak: the return comes from lower down the front, and more so at a low tilt, as on rendered frames
  (heights of simulated passes within 0.03 m of what recon reconstructs, per class and tilt).
* It is a highlight extension when it is closer than the beam's seabed onset (the steepest ray's
  range to the seabed) minus ``onset_margin_m``; recon then places it on the steepest ray
  (elevation ``+s/2`` in the sonar frame, the beam's azimuth) at that range, jittered by a range
  bin (``range_sigma_m``) and lengthened by a lag drawn from ``range_bias_m`` (on rendered frames
  recon's threshold and run length detect a return some bins after the geometric first hit: its
  points of simulated passes lie 0.06-0.16 m lower than the mesh's top edges).
  The front slope, the missing far side and the sparse rows follow.
* Seabed removal: points lower than ``min_height_m`` above the seabed are dropped.
* Front-slope correction (``correction = "arc"``, what the pipeline applies before it classifies):
  recon's own :func:`recon.front_slope.replace_on_arcs` moves each point up its range arc to the
  height of the highest point within ``correction_length_m`` behind it along the beam
  (``correction_width_m`` across); ``"none"`` keeps the uncorrected steepest-ray cloud. A fraction
  drawn from ``correction_blend`` of each move is applied: on rendered frames recon's correction
  leaves part of the slope (its detections lag the geometric first return).

Per view ``A``, ``L``, ``c_min`` and ``min_height_m`` are drawn uniformly from their ranges in
:class:`classify.training.synthesis.SynthesisSettings` (``altitude_m``, ``lateral_m``, ``min_cos``,
``min_height_m``). Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.sonar import DIDSON
from classify.training.scan_acoustics import draw_acoustics, ray_elevations, ray_weights, tvg_gain
from classify.training.synthesis_settings import SynthesisSettings
from recon.arc_consensus import consensus_points
from recon.front_slope import replace_on_arcs
from recon.range_arcs import arc_record

F64 = npt.NDArray[np.float64]
#: the fan the classifier learns: the DIDSON's (its data sheet's beams, linear over +-half the field, deg)
N_BEAMS = DIDSON.n_beams
HALF_FOV_DEG = DIDSON.bearings_deg[-1]
DENSE_MAX = 20_000_000  # energy_first_return: (cells x bins) above this, the sparse search


def sonar_rays(heading_rad: float, tilt_rad: float, spread_rad: float, k: int,
               elevations: F64 | None = None) -> tuple[F64, F64]:
    """Unit ray directions ``(k, beams, 3)`` (NED, level vehicle) and the steepest ray per beam ``(beams, 3)``;
    ``elevations`` (rad off the axis, +: down; default ``k`` evenly over ``+-spread / 2``) replaces ``k``."""
    az = np.radians(np.linspace(-HALF_FOV_DEG, HALF_FOV_DEG, N_BEAMS))
    el = np.linspace(-spread_rad / 2, spread_rad / 2, k) if elevations is None else np.asarray(elevations, float)
    ph, th = np.meshgrid(el, az, indexing="ij")
    d_s = np.stack([np.cos(ph) * np.cos(th), np.cos(ph) * np.sin(th), np.sin(ph)], axis=-1)
    ct, st = math.cos(tilt_rad), math.sin(tilt_rad)
    r_bs = np.array([[ct, 0.0, -st], [0.0, 1.0, 0.0], [st, 0.0, ct]])  # pitched down by the tilt
    cp, sp = math.cos(heading_rad), math.sin(heading_rad)
    r_wb = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]])
    d_w = d_s @ (r_wb @ r_bs).T
    return d_w, d_w[-1]


def arc_vectors(heading_rad: float, tilt_rad: float) -> tuple[F64, F64]:
    """Per beam the unit vector ``u = R_WS [cos th, sin th, 0]`` ``(beams, 3)`` and ``w = R_WS [0, 0, 1]`` (3,):
    a return at range ``r`` and elevation ``phi`` lies at ``o + r (cos phi u + sin phi w)``."""
    az = np.radians(np.linspace(-HALF_FOV_DEG, HALF_FOV_DEG, N_BEAMS))
    ct, st = math.cos(tilt_rad), math.sin(tilt_rad)
    cp, sp = math.cos(heading_rad), math.sin(heading_rad)
    r_ws = np.array([[cp, -sp, 0.0], [sp, cp, 0.0], [0.0, 0.0, 1.0]]) @ np.array(
        [[ct, 0.0, -st], [0.0, 1.0, 0.0], [st, 0.0, ct]])
    u = np.stack([np.cos(az), np.sin(az), np.zeros_like(az)], axis=1) @ r_ws.T
    return u, r_ws[:, 2].copy()


def energy_first_return(t_hit: F64, cos_a: F64, hit: npt.NDArray[np.bool_], threshold: float, bin_m: float,
                        min_run: int, r0: float = 6.0, span: int = 0, leak: tuple[float, ...] = (1.0,),
                        pulse_bins: int = 1, speckle: tuple[np.random.Generator, float] | None = None) -> F64:
    """Per position and beam ``(P, beams)`` the range of the first bin whose summed return reaches ``threshold``
    with at least ``min_run`` such bins (itself included) among the ``span`` bins from it (recon's rule,
    :func:`recon.highlight.first_returns`; ``span`` <= ``min_run``: consecutive bins); ``inf`` where none does.

    ``t_hit``, ``cos_a``, ``hit``: ``(P, K, beams)`` per ray. A ray returns ``cos^2 (r0 / r)^2 / K`` (the
    simulator's ``cos^2 / r^2`` per ray, a beam of K rays at normal incidence at ``r0`` summing to 1)
    into its range bin. A grazing hit on a rounded top, alone in its bin, stays below the threshold;
    a face that many rays strike at nearly one range passes. ``leak``: the energy each beam also receives from
    the beams ``-L..+L`` off (:func:`classify.training.scan_acoustics.beam_leak`); ``pulse_bins``: each bin's
    energy spread evenly over it and the next ``pulse_bins - 1``; ``speckle``: (generator, looks), each (beam, bin)
    times a unit-mean gamma of that many looks (pulse and speckle: the dense search only).
    """
    p_n, _, n_beams = t_hit.shape
    out = np.full((p_n, n_beams), np.inf)
    cell, b, e = _ray_returns(t_hit, cos_a, hit, bin_m, r0, leak)
    if cell.size == 0:
        return out
    starts = np.flatnonzero(np.r_[True, cell[1:] != cell[:-1]])
    ci = np.cumsum(np.r_[False, cell[1:] != cell[:-1]])  # index of each ray's cell among the cells hit
    b0 = np.minimum.reduceat(b, starts)
    off = b - b0[ci]
    run = max(1, min_run)
    span = max(run, span)
    width = int(off.max()) + run + max(pulse_bins, 1) - 1
    if starts.size * width > DENSE_MAX:  # rays spread over a long range: bins of the sparse (cell, bin) keys
        return _first_run_sparse(out, cell, b, e, threshold, bin_m, run, span)
    energy: F64 = np.asarray(np.bincount(ci * width + off, weights=e, minlength=starts.size * width),
                             dtype=np.float64).reshape(-1, width)
    if pulse_bins > 1:  # the echo of a bin spread over [r, r + pulse]
        spread = energy / pulse_bins
        for d in range(1, pulse_bins):
            spread[:, d:] += energy[:, :-d] / pulse_bins
        energy = spread
    if speckle is not None and speckle[1] > 0:
        energy = energy * speckle[0].gamma(speckle[1], 1.0 / speckle[1], energy.shape)
    enough = energy >= threshold
    count = enough.astype(np.int32)
    for d in range(1, min(span, width)):  # bins b .. b + span - 1 holding enough
        count[:, : width - d] += enough[:, d:]
    ok = enough & (count >= run)
    ok[:, width - run + 1:] = False
    found = ok.any(axis=1)
    first = b0[found] + np.argmax(ok[found], axis=1)
    out.reshape(-1)[cell[starts[found]]] = first * bin_m + 0.5 * bin_m
    return out


def _ray_returns(t_hit: F64, cos_a: F64, hit: npt.NDArray[np.bool_], bin_m: float, r0: float,
                 leak: tuple[float, ...]) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], F64]:
    """Every hit ray's cell ``position * beams + beam``, range bin and energy ``cos^2 (r0 / r)^2 / K``, ordered by
    cell; with ``leak`` (more than one weight) also its copies into the neighbouring beams, scaled by their weight."""
    _, k, n_beams = t_hit.shape
    pi, bi, ki = np.nonzero(hit.transpose(0, 2, 1))  # ordered by cell (position, beam)
    t = t_hit[pi, ki, bi]
    e = cos_a[pi, ki, bi] ** 2 * (r0 / np.maximum(t, 1e-6)) ** 2 / k
    b = np.floor(t / bin_m).astype(np.int64)
    if len(leak) <= 1 or pi.size == 0:
        return pi * n_beams + bi, b, e
    half = len(leak) // 2
    parts = [(pi, bi + o, b, e * leak[o + half]) for o in range(-half, half + 1) if leak[o + half] > 0]
    pa, ba, bb, ea = (np.concatenate(x) for x in zip(*parts, strict=True))
    inside = (ba >= 0) & (ba < n_beams)
    cell = (pa * n_beams + ba)[inside]
    order = np.argsort(cell, kind="stable")
    return cell[order], bb[inside][order], ea[inside][order]


def _first_run_sparse(out: F64, cell: npt.NDArray[np.int64], b: npt.NDArray[np.int64], e: F64, threshold: float,
                      bin_m: float, run: int, span: int) -> F64:
    """:func:`energy_first_return` over the sorted unique (cell, bin) keys (memory by rays, not by bins)."""
    lo = int(b.min())
    b = b - lo
    nb = int(b.max()) + span + 1  # a span never reaches the next cell's keys
    keys, inv = np.unique(cell * nb + b, return_inverse=True)
    good = keys[np.bincount(inv.ravel(), weights=e) >= threshold]
    # good bins in [key, key + span) (sorted keys, within the cell: nb leaves room for the span)
    start = good[np.searchsorted(good, good + span, side="left") - np.arange(good.size) >= run]
    if start.size:
        cells, first = np.unique(start // nb, return_index=True)  # sorted keys: a cell's first run comes first
        out.reshape(-1)[cells] = (start[first] % nb + lo) * bin_m + 0.5 * bin_m
    return out


def partial_pass(xs: F64, lateral: float, alt: float, elevation: float, radius: float, rng: np.random.Generator
                 ) -> tuple[F64, float]:
    """A pass that sees only part of an object (of horizontal radius ``radius`` m): half of the time the
    object lies at the edge of the swath (the lateral offset is the fan's half width at the seabed onset, give
    or take half the radius: part of the object is outside every beam), else the line ends or starts while
    the steepest ray is over the object (``xs``, the positions along the pass, cut where the onset, ``alt /
    tan(elevation)`` ahead, crosses a random point of the middle of the object)."""
    if rng.random() < 0.5:
        half = alt / math.sin(elevation) * math.sin(math.radians(HALF_FOV_DEG))
        side = 1.0 if rng.random() < 0.5 else -1.0
        return xs, side * (half + float(rng.uniform(-0.5, 0.3)) * radius)
    cut = float(rng.uniform(-0.5, 0.5)) * radius - alt / math.tan(elevation)
    keep = xs < cut if rng.random() < 0.5 else xs >= cut
    return xs[keep], lateral


def scan_points(scene: Any, vertices: F64, heading_rad: float, tilt_rad: float, settings: SynthesisSettings,
                rng: np.random.Generator, *, altitude: float | None = None, partial: bool = False) -> F64:
    """Highlight-extension points (metres, object frame NED, seabed at ``z = 0``) of one pass, under acoustic
    conditions drawn by :func:`classify.training.scan_acoustics.draw_acoustics` (the idealized sonar unless
    ``settings.dr_prob`` > 0): the points lie on the ray at the drawn effective lower edge.

    ``altitude`` (m): that of the pass (None: drawn from ``settings.altitude_m``). ``partial``: the pass sees
    only part of the object (:func:`partial_pass`)."""
    spread = math.radians(settings.spread_deg)
    alt = float(rng.uniform(*settings.altitude_m)) if altitude is None else float(altitude)
    lateral = float(rng.uniform(*settings.lateral_m))
    c_min = float(rng.uniform(*settings.min_cos))
    min_h = float(rng.uniform(*settings.min_height_m))
    bias = float(rng.uniform(*settings.range_bias_m))
    ac = draw_acoustics(settings, spread, rng)
    elevations = None if ac.ideal else ray_elevations(ac, spread, settings.rays_per_beam)
    d, _ = sonar_rays(heading_rad, tilt_rad, spread, settings.rays_per_beam, elevations)
    steep = sonar_rays(heading_rad, tilt_rad, spread, 1, np.array([ac.edge_rad]))[0][0]  # where recon places
    u = np.array([math.cos(heading_rad), math.sin(heading_rad), 0.0])
    w = np.array([-math.sin(heading_rad), math.cos(heading_rad), 0.0])
    radius = float(np.linalg.norm(vertices[:, :2], axis=1).max())
    e = tilt_rad + ac.edge_rad
    # from where the placement ray meets the seabed a little beyond the object, to past the object
    xs = np.arange(-(alt / math.tan(e) + radius + 1.0), radius + 0.5, settings.step_m)
    xs = xs + rng.uniform(0.0, settings.step_m)
    if partial:
        xs, lateral = partial_pass(xs, lateral, alt, e, radius, rng)
        if xs.size == 0:
            return np.zeros((0, 3))
    origins = xs[:, None] * u + lateral * w + np.array([0.0, 0.0, -alt])
    t_hit, cos_a = _cast(scene, origins, d)
    with np.errstate(divide="ignore"):
        r_sea = np.where(d[..., 2] > 0, alt / d[..., 2], np.inf)  # (k, beams): flat seabed, level vehicle
    if settings.cos_jitter > 0:  # speckle: a return near the threshold passes or fails at random
        cos_a = cos_a * np.exp(settings.cos_jitter * rng.standard_normal(cos_a.shape))
    if settings.detect == "energy":
        hit = np.isfinite(t_hit) & (t_hit < r_sea[None])
        if not ac.ideal:  # each ray's share of the beam pattern and the TVG error, folded into its cos^2
            share = ray_weights(ac, spread, np.asarray(elevations)) * d.shape[0]
            cos_a = cos_a * np.sqrt(share[None, :, None] * tvg_gain(ac, t_hit))
        threshold = float(rng.uniform(*settings.energy_threshold)) * ac.threshold_factor
        first = energy_first_return(t_hit, cos_a, hit, threshold, settings.bin_m, settings.min_run,
                                    span=settings.span_bins, leak=ac.leak, pulse_bins=ac.pulse_bins,
                                    speckle=(rng, ac.speckle_looks) if ac.speckle_looks > 0 else None) + bias
    else:
        hit = np.isfinite(t_hit) & (t_hit < r_sea[None]) & (cos_a >= c_min)
        first = np.where(hit, t_hit, np.inf).min(axis=1) + bias  # (positions, beams)
    onset = alt / steep[:, 2]  # the placement ray's seabed range per beam
    ok = first < onset[None] - settings.onset_margin_m
    pi, bi = np.nonzero(ok)
    r = first[pi, bi] + rng.normal(0.0, settings.range_sigma_m, size=len(pi))
    pts = origins[pi] + r[:, None] * steep[bi]
    keep = ac.seabed_bias_m - pts[:, 2] >= min_h  # recon's seabed removal, above its seabed
    lift = np.array([0.0, 0.0, ac.seabed_bias_m])  # heights above recon's seabed (fitted that much deeper)
    if settings.correction == "none" or not keep.any():
        return np.asarray(pts[keep] - lift)
    return _corrected(pts[keep], origins[pi[keep]], bi[keep], r[keep], heading_rad, tilt_rad, spread,
                      settings, rng, (pi[keep].astype(np.float64), ac.seabed_bias_m)) - lift


def _cast(scene: Any, origins: F64, d: F64) -> tuple[F64, F64]:
    """Range ``t_hit`` and ``|cos|`` of the incidence ``(positions, K, beams)`` of rays ``d`` ``(K, beams, 3)`` from
    every origin ``(positions, 3)`` against the mesh (Open3D); ``inf`` where a ray misses."""
    import open3d as o3d  # lazy: Open3D loads only when clouds are synthesized (not for inference)

    n_pos, k = len(origins), d.shape[0]
    rays = np.empty((n_pos, k, N_BEAMS, 6), dtype=np.float32)
    rays[..., :3] = origins[:, None, None, :]
    rays[..., 3:] = d[None]
    ans = scene.cast_rays(o3d.core.Tensor.from_numpy(rays.reshape(-1, 6)))
    t_hit = ans["t_hit"].numpy().astype(np.float64).reshape(n_pos, k, N_BEAMS)
    cos_a = np.abs((ans["primitive_normals"].numpy().reshape(n_pos, k, N_BEAMS, 3) * d[None]).sum(axis=-1))
    return t_hit, cos_a


def _corrected(pts: F64, origins: F64, beams: npt.NDArray[np.int64], r: F64, heading_rad: float, tilt_rad: float,
               spread: float, settings: SynthesisSettings, rng: np.random.Generator, frames: tuple[F64, float]
               ) -> F64:
    """:func:`recon_correction` of one pass's points on the arcs of their beams (``frames``: each point's position
    index along the pass and recon's seabed depth, m)."""
    u, w_vec = arc_vectors(heading_rad, tilt_rad)
    arcs = arc_record(origins, u[beams], np.broadcast_to(w_vec, (len(pts), 3)), r)
    return recon_correction(pts, arcs, frames[0], frames[1], spread, settings.correction_length_m,
                            settings.correction_width_m, settings, rng)


def recon_correction(points: F64, arcs: F64, times: F64, seabed_depth: float, spread: float, length: float,
                     width: float, settings: SynthesisSettings, rng: np.random.Generator) -> F64:
    """Recon's placement of a cluster's final points (m): with ``settings.arc_consensus`` re-placed where their
    frames' arcs meet (:func:`recon.arc_consensus.consensus_points`, frames by ``times``, the seabed at
    ``seabed_depth``), then the front-slope correction (:func:`recon.front_slope.replace_on_arcs`, the nominal fan
    of ``spread`` rad, ``length`` and ``width`` m, as recon's) of which a fraction drawn from
    ``settings.correction_blend`` is applied (recon's correction is partial on real frames)."""
    pts, steep = consensus_points(points, arcs, times, spread, seabed_depth) if settings.arc_consensus \
        else (points, None)
    fixed = replace_on_arcs(pts, arcs, spread, length, width, steepest=steep)
    blend = float(rng.uniform(*settings.correction_blend))
    return np.asarray(pts + blend * (fixed - pts), dtype=np.float64)
