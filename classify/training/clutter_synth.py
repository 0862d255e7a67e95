"""Clutter: what recon makes of a rough seabed with no object on it (the classifier's "not an object").

On a rough seabed (the simulator's model, :class:`auvlink.sim.seabed.SeabedSurface`: a sum of sinusoids of
0.5-8 m wavelength) a crest that faces the sonar returns before the seabed onset the fitted planes predict,
and some of those highlight-extension returns stand higher above recon's textured seabed than its threshold:
they become clusters, which the classifier must call ``clutter``. They are synthesized the way
:mod:`classify.training.scan_synth` synthesizes object clouds, from the geometry alone (no sonar image is rendered):

* **Patch and survey** (every value drawn per patch from
  :class:`classify.training.synthesis_settings.SynthesisSettings`): a seabed of roughness ``clutter_roughness_m``
  (m rms) and slope ``clutter_slope_deg`` (any azimuth), no object; 2-3 lawnmower lines (``clutter_lines``,
  alternate directions, any heading) ``clutter_line_m`` long,
  spaced ``clutter_spacing`` times the swath at the onset, at an altitude ``clutter_altitude_m`` above the
  mean plane, a tilt between the smallest and the largest of ``tilts_deg``, one frame every ``clutter_step_m``
  metres. Each line is shifted by a misalignment of ``misalign_m`` metres in a random direction (what dead
  reckoning leaves between lines).
* **Returns per frame and beam** (:func:`classify.training.seabed_returns.line_returns`): each ray of the fan meets the
  seabed; the returns summed per range bin against recon's threshold give the highlight-extension points before
  the onset, the seabed returns after it, and the DVL's bottom points.
* **Recon's own code** (:func:`recon_clusters`) with its default settings (:class:`recon.reconstructor.ReconConfig`):
  the seabed samples fill a :class:`recon.seabed_memory.SeabedMemory` as in
  :meth:`recon.reconstructor.Reconstructor.add_frames`; every ``poll_m`` metres of a line (a poll), the points of
  that stretch are filtered by :func:`recon.poll_seabed.object_points` against the seabed
  :meth:`recon.seabed_memory.SeabedMemory.fit` gives from what was seen so far (tiled planes and
  texture grid); the points kept are clustered by :func:`recon.cluster.cluster` per line (the cloud of a first
  emission) and over all lines (the fused cloud), clusters :func:`recon.poll_seabed.on_seabed` calls too wide
  or too low are dropped, and the front-slope correction (:func:`recon.front_slope.replace_on_arcs`, blended
  by ``correction_blend``) is applied as the pipeline does.

Each remaining cluster is one clutter cloud, with the seabed depth recon gives it (the median of the tiled
planes under its points). Every draw comes from the generator passed in.
"""

from __future__ import annotations

import math
import zlib

import numpy as np
import numpy.typing as npt

from auvlink.progress import progress_bar
from classify.errors import SynthesisError
from classify.labels import CLUTTER
from classify.training.scan_synth import recon_correction
from classify.training.seabed_returns import LineReturns, draw_seabed, fly_lines, onset_geometry
from classify.training.synthesis_settings import SynthesisSettings
from classify.training.views import training_cloud
from recon.cluster import DetectedObject, cluster
from recon.poll_seabed import object_points, on_seabed
from recon.reconstructor import ReconConfig
from recon.seabed_memory import SeabedMemory
from recon.seabed_texture import SEABED_TEXTURE

F64 = npt.NDArray[np.float64]
MAX_PATCHES_PER_CLOUD = 20  # patches drawn per clutter cloud asked before giving up


def draw_survey(settings: SynthesisSettings, rng: np.random.Generator
                ) -> tuple[list[LineReturns], int, float, float]:
    """The returns of the 2-3 lines flown over one drawn seabed patch (see the module docstring), the frames
    per poll (``clutter_poll_m`` of travel), and the first line's heading and the tilt (deg)."""
    seabed = draw_seabed(settings, rng, settings.clutter_roughness_m)
    tilt = math.radians(float(rng.uniform(min(settings.tilts_deg), max(settings.tilts_deg))))
    alt = float(rng.uniform(*settings.clutter_altitude_m))
    _, swath = onset_geometry(alt, tilt, settings)
    spacing = float(rng.uniform(*settings.clutter_spacing)) * swath
    step = float(rng.uniform(*settings.clutter_step_m))
    n_lines = int(rng.integers(int(settings.clutter_lines[0]), int(settings.clutter_lines[1]) + 1))
    psi = float(rng.uniform(0.0, 2 * math.pi))
    threshold = float(rng.uniform(*settings.clutter_energy_threshold))
    half = settings.clutter_line_m / 2
    xs = np.arange(-half, half, step) + rng.uniform(0.0, step)
    paths = [(xs[::-1] if j % 2 == 1 else xs, j * spacing) for j in range(n_lines)]
    lines = fly_lines(seabed, paths, psi, tilt, alt, settings, rng, threshold)
    return lines, max(1, round(settings.clutter_poll_m / step)), math.degrees(psi) % 360.0, math.degrees(tilt)


def recon_clusters(lines: list[LineReturns], cfg: ReconConfig, poll_frames: int
                   ) -> list[tuple[DetectedObject, float]]:
    """Recon's seabed removal poll by poll, then clusters per line and over all lines (see the module doc):
    each with its seabed depth, after :func:`recon.poll_seabed.on_seabed`."""
    memory = SeabedMemory(cfg.seabed, SEABED_TEXTURE)  # what recon keeps of the seabed (recon.seabed_memory)
    kept: list[tuple[F64, F64, F64, int]] = []
    for j, ln in enumerate(lines):
        for s in range(0, len(ln.dvl), poll_frames):
            e = s + poll_frames
            sel = (ln.frame >= s) & (ln.frame < e)
            memory.add(ln.dvl[s:e])  # as Reconstructor.add_seabed_points: planes and texture grid
            memory.add_planes(ln.sparse[(ln.sparse_frame >= s) & (ln.sparse_frame < e)])
            memory.add_texture(ln.texture[(ln.texture_frame >= s) & (ln.texture_frame < e)])
            memory.add_highlights(ln.points[sel])  # as Reconstructor.add_frames
            if not sel.any():
                continue
            p = ln.points[sel]
            model = memory.fit(p[:, :2].min(axis=0), p[:, :2].max(axis=0))
            if model is None:
                continue
            keep = object_points(p, model, cfg.seabed)
            if keep.any():
                kept.append((p[keep], ln.times[sel][keep], ln.arcs[sel][keep], j))
    if not kept:
        return []
    groups = [[k for k in kept if k[3] == j] for j in range(len(lines))]
    if len(lines) > 1:
        groups.append(kept)
    out: list[tuple[DetectedObject, float]] = []
    seen: set[tuple[int, float, float]] = set()  # a fused cluster that one line alone gave is not repeated
    for g in groups:
        if not g:
            continue
        p = np.concatenate([k[0] for k in g])
        objs = cluster(p, np.concatenate([k[1] for k in g]), cfg.cluster, np.concatenate([k[2] for k in g]))
        if not objs:
            continue
        lo = np.min([o.points[:, :2].min(axis=0) for o in objs], axis=0)
        hi = np.max([o.points[:, :2].max(axis=0) for o in objs], axis=0)
        model = memory.fit(lo, hi)
        rejected: dict[str, int] = {}
        for o in on_seabed(objs, model, rejected):
            key = (o.n_points, round(float(o.centroid[0]), 6), round(float(o.centroid[1]), 6))
            if key not in seen:
                seen.add(key)
                out.append((o, float(o.seabed_depth)))
    return out


def clutter_clouds(settings: SynthesisSettings, rng: np.random.Generator, cfg: ReconConfig | None = None
                   ) -> tuple[list[tuple[F64, float]], float, float]:
    """The clutter clusters of one drawn patch: points (n, 3) world NED m, after the front-slope correction,
    and the seabed depth under each (m); and the heading and tilt (deg) of the patch's first line."""
    cfg = cfg or ReconConfig()
    lines, poll, heading, tilt = draw_survey(settings, rng)
    out = []
    spread = math.radians(settings.spread_deg)
    for o, depth in recon_clusters(lines, cfg, poll):
        out.append((recon_correction(o.points, o.extra, o.times, depth, spread, cfg.front_slope_length,
                                     cfg.front_slope_width, settings, rng), depth))
    return out, heading, tilt


def synthesize_clutter(settings: SynthesisSettings, count: int, progress: bool = False
                       ) -> tuple[npt.NDArray[np.float32], F64]:
    """``count`` clutter clouds ``(count, n_points, 3)`` as training clouds
    (:func:`classify.training.views.training_cloud`) and, per cloud, the heading and tilt (deg) of the patch's first
    line. Patch ``i`` draws from
    ``SeedSequence([seed, crc32("clutter"), i])``; patches are drawn until ``count`` clusters came (a cluster
    that one line alone gave is not repeated as the fused cloud of all lines)."""
    crc = zlib.crc32(CLUTTER.encode())
    clouds: list[npt.NDArray[np.float32]] = []
    meta: list[tuple[float, float]] = []
    bar = progress_bar(total=count, enabled=progress, desc="clutter", leave=False)
    for i in range(MAX_PATCHES_PER_CLOUD * max(count, 1)):
        if len(clouds) >= count:
            break
        rng = np.random.default_rng(np.random.SeedSequence([settings.seed, crc, i]))
        found, heading, tilt = clutter_clouds(settings, rng)
        for pts, depth in found[: count - len(clouds)]:
            cloud, _ = training_cloud(pts, settings, rng, min(len(pts), settings.n_points), depth)
            clouds.append(cloud)
            meta.append((heading, tilt))
            bar.update(1)
    bar.close()
    if len(clouds) < count:
        raise SynthesisError(f"{len(clouds)} clutter clouds from {MAX_PATCHES_PER_CLOUD * count} seabed patches, "
                             f"{count} asked (clutter_clouds); widen clutter_roughness_m or ask fewer")
    return np.stack(clouds), np.asarray(meta, dtype=np.float64)
