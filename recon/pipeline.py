"""The reconstruction pipeline: sonar frames + poses -> object points -> objects.

:class:`Reconstructor` consumes frames (time, (n_bins, n_beams) uint8 image) and a pose source (a
:class:`recon.trajectory.Trajectory` or anything with ``pose_at`` and ``altitude_at``). Per frame:
pose interpolated at the frame time, expected seabed onset per beam (flat seabed at the DVL
altitude, or the seabed fitted so far), highlight-extension points (:mod:`recon.highlight`) and,
the seabed returns at the onset (:mod:`recon.seabed_memory`). Points wait in a pending buffer
with the range arc they came from; :meth:`poll` (streaming) or :meth:`finish` (batch) removes the
seabed (:mod:`recon.seabed`, fitted from the DVL seabed points and the sonar seabed returns),
clusters (:mod:`recon.cluster`) and, with ``front_slope``, moves each final
object's front-slope points up their arcs (:mod:`recon.front_slope`) and its centroid away from the
sonar by the far side it could not see (:mod:`recon.far_side`). Pure computation: no ports, no files.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.cluster import ClusterConfig, DetectedObject, cluster, make_object
from recon.cluster_stream import StreamingClusterer
from recon.errors import GeometryError, ReconError
from recon.far_side import FarSideConfig, far_side_centre
from recon.frames import check_attitude
from recon.front_slope import replace_on_arcs
from recon.highlight import HighlightConfig, first_returns, frame_thresholds, onset_rows, project, run_span_bins
from recon.poll_seabed import object_points, on_seabed
from recon.range_arcs import arc_columns
from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_band import BandConfig, OnsetTracker, seabed_returns
from recon.seabed_memory import PLANE_BEAM_STEP, PLANE_FRAME_STEP, TEXTURE_BEAM_STEP, SeabedMemory
from recon.seabed_texture import TextureConfig, TexturedSeabed
from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]

#: m of seabed samples around the frames' positions behind the seabed fitted for the expected onset: the fit's box
#: holds the fan's footprint ahead (the range window's end, 11 m) and 19 m of travel (13 s at 1.5 m/s) before a refit
ONSET_RADIUS_M = 30.0
#: frames between refits of that seabed while the vehicle stays inside it (10 s at 10 frames/s)
ONSET_REFIT_FRAMES = 100


class PoseSource(Protocol):
    def pose_at(self, t: ArrayLike) -> tuple[F64, Rotation]: ...

    def altitude_at(self, t: ArrayLike) -> F64: ...


@dataclass(frozen=True)
class ReconConfig:
    highlight: HighlightConfig = field(default_factory=HighlightConfig)
    seabed: SeabedConfig = field(default_factory=SeabedConfig)
    cluster: ClusterConfig = field(default_factory=ClusterConfig)
    front_slope: bool = True  # correct the front slope: points re-placed on their range arcs (recon.front_slope)
    front_slope_length: float = 1.0  # m: how far behind a point its object's top is sought
    front_slope_width: float = 0.25  # m: across the look direction
    far_side: FarSideConfig = field(default_factory=FarSideConfig)  # with front_slope: centroid (recon.far_side)
    band: BandConfig = field(default_factory=BandConfig)  # each column's seabed return (recon.seabed_band)
    texture: TextureConfig = field(default_factory=TextureConfig)  # the seabed at the scale of its texture


class Reconstructor:
    """Accumulates highlight-extension points and turns them into objects; see the module doc."""

    def __init__(self, geometry: SonarGeometry, poses: PoseSource, config: ReconConfig | None = None,
                 seabed_points: ArrayLike | None = None) -> None:
        self.geometry = geometry
        self.poses = poses
        self.config = config or ReconConfig()
        self._pending: list[tuple[F64, F64, F64]] = []
        self.memory = SeabedMemory(self.config.seabed, self.config.texture)  # seabed samples (recon.seabed_memory)
        self._raw: list[F64] = []
        self._onset_cache: tuple[F64, F64, int, SeabedModel] | None = None
        self._onset_model: SeabedModel | None = None  # the fit behind the latest expected onsets
        self._tracker = OnsetTracker(geometry.n_beams, self.config.band)
        self._onset_fit_frame = 0
        self._stream: StreamingClusterer | None = None
        self.seabed: TexturedSeabed | SeabedModel | None = None  # the model of the latest poll
        self.rejected: dict[str, int] = {"too_wide": 0, "too_low": 0}
        self.objects: list[DetectedObject] = []
        self.frames = 0
        self.frames_with_points = 0
        self.points_total = 0
        self.seabed_removed = 0
        self._t_last = -np.inf
        #: the first returns of the last :meth:`add_frames` call: (frame index in that call, beam,
        #: row) arrays, before any front-slope carving (what a viewer marks on the frames)
        self.last_returns: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]] = (
            np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64))
        if seabed_points is None and hasattr(poses, "seabed_points"):
            seabed_points = poses.seabed_points()
        if seabed_points is not None:
            self.add_seabed_points(seabed_points)

    # ---------------------------------------------------------------- frames
    def add_seabed_points(self, points: ArrayLike) -> None:
        """Seabed points (the DVL's bottom points, world NED m) for the tiled planes and the texture grid."""
        self.memory.add(points)

    def add_frame(self, t: float, image: NDArray[np.uint8]) -> int:
        """One frame; returns the number of highlight-extension points it gave."""
        return self.add_frames(np.array([t], dtype=np.float64), np.asarray(image)[None])

    def add_frames(self, times: ArrayLike, images: NDArray[np.uint8]) -> int:
        """A stack of frames (F, n_bins, n_beams) at ``times`` (F,); returns the points added."""
        g, hc = self.geometry, self.config.highlight
        ts = np.asarray(times, dtype=np.float64).reshape(-1)
        imgs = np.asarray(images)
        if imgs.dtype != np.uint8 or imgs.shape != (ts.size, g.n_bins, g.n_beams):
            raise GeometryError(f"expected uint8 frames {(ts.size, g.n_bins, g.n_beams)}, "
                                f"got {imgs.dtype} {imgs.shape}")
        if ts.size == 0:  # an empty batch (e.g. the tail of a replay): nothing to add
            return 0
        pos, rot = self.poses.pose_at(ts)
        check_attitude(rot)
        alt = self.poses.altitude_at(ts)
        onset = self._onset(pos, rot, alt)
        band = self.config.band
        # the threshold's statistics come from the water column before the widest seabed search
        water = onset_rows(g, onset, hc.margin_m + max(band.lead_m, band.lead_flat_m))
        thr = frame_thresholds(imgs, int(water.min(initial=g.n_bins)), hc)
        # each column's seabed return, and the expected onset corrected by them (recon.seabed_band); while the
        # seabed fitted so far spans only a few metres (the first seconds of a survey) its slope is unknown
        # (the regional plane is level; recon.seabed): search much wider
        known = self._slope_known(self._onset_model)
        lead_m = band.lead_m if known else band.lead_flat_m
        self._tracker.set_known(known)
        sf, sb, sr = seabed_returns(g, imgs, onset, thr, hc.margin_m, band, lead_m)
        if band.correct_onset:
            onset = self._tracker.correct(g, onset, sf, sb, sr)
        limits = onset_rows(g, onset, hc.margin_m)
        fi, bi, ri = first_returns(imgs, limits, thr, hc, run_span_bins(hc, g.bin_size))
        self.last_returns = (fi, bi, ri)
        self._add_seabed_samples(sf, sb, sr, fi, bi, ri, onset, pos, rot)
        pts = project(g, fi, bi, ri, pos, rot, hc.geometry, hc.dtype)
        self.memory.add_highlights(pts)
        arcs = arc_columns(g, fi, bi, ri, pos, rot) if self._arc else np.zeros((fi.size, 0))
        self.frames += ts.size
        self.frames_with_points += int(np.unique(fi).size)
        self.points_total += int(fi.size)
        self._t_last = max(self._t_last, float(ts.max(initial=-np.inf)))
        if fi.size:
            self._pending.append((np.asarray(pts, dtype=np.float64), ts[fi], arcs))
            self._raw.append(np.asarray(pts, dtype=np.float64))
        return int(fi.size)

    def _add_seabed_samples(self, sf: NDArray[np.int64], sb: NDArray[np.int64], sr: NDArray[np.int64],
                            fi: NDArray[np.int64], bi: NDArray[np.int64], ri: NDArray[np.int64], onset: F64,
                            pos: F64, rot: Rotation) -> None:
        """The seabed returns ``(sf, sb, sr)`` of a batch as seabed samples: every ``TEXTURE_BEAM_STEP``-th beam
        into the texture grid, every ``PLANE_BEAM_STEP``-th beam of every ``PLANE_FRAME_STEP``-th frame into the
        tiled planes' points. Left out: returns more than ``band.sample_lead_m`` before the (corrected) onset
        (an object's front, a high crest) and columns whose highlight return came before the seabed return
        (the seabed return is then not the column's first: it lies under the seabed); ``(fi, bi, ri)`` are the
        batch's highlight returns."""
        g, cfg = self.geometry, self.config
        tex = cfg.texture.enabled
        if sf.size == 0:
            return
        first = np.full((onset.shape[0], g.n_beams), g.n_bins, np.int64)
        first[fi, bi] = ri
        near = g.ranges[sr] >= onset[sf, sb] - cfg.highlight.margin_m - cfg.band.sample_lead_m
        ok = near & (first[sf, sb] >= sr)
        sf, sb, sr = sf[ok], sb[ok], sr[ok]
        every_frame = (self.frames + np.arange(onset.shape[0])) % PLANE_FRAME_STEP == 0
        dense = (sb % TEXTURE_BEAM_STEP == 0) & tex
        sparse = (sb % PLANE_BEAM_STEP == 0) & every_frame[sf]
        keep = dense | sparse
        sp = project(g, sf[keep], sb[keep], sr[keep], pos, rot, "exact")
        self.memory.add_texture(sp[dense[keep]])
        self.memory.add_planes(sp[sparse[keep]])

    def _onset(self, pos: F64, rot: Rotation, alt: F64) -> F64:
        """Expected seabed onset per frame and beam: the fitted seabed plane where the fan looks
        (DVL + sonar seabed points), else a flat seabed at the DVL altitude."""
        model = self._seabed_model(pos)
        onset = self._onset_of(model, pos, rot, alt)
        if model is not self._onset_model:  # a new fit: the tracked correction stays on the same seabed
            self._tracker.rebase(self._onset_of(self._onset_model, pos[:1], rot[:1], alt[:1])[0] - onset[0])
            self._onset_model = model
        return onset

    def _onset_of(self, model: SeabedModel | None, pos: F64, rot: Rotation, alt: F64) -> F64:
        """Onset ranges (F, beams) predicted by ``model`` (None: a flat seabed at the DVL altitude)."""
        g = self.geometry
        if model is None:
            return g.flat_onset_ranges(pos, rot, alt)
        known = np.isfinite(alt)
        h = alt if known.all() else np.where(known, alt, model.depth_at(pos) - pos[:, 2])
        fwd = rot.as_matrix().reshape(-1, 3, 3)[:, :2, 0]
        fwd = fwd / np.maximum(np.linalg.norm(fwd, axis=1, keepdims=True), 1e-9)
        look = pos[:, :2] + fwd * (np.maximum(h, 0.0) / np.tan(g.tilt + 0.5 * g.spread))[:, None]
        q, n = model.plane_at(look)
        return g.onset_ranges(pos, rot, q, n)

    def _slope_known(self, model: SeabedModel | None) -> bool:
        """True when ``model`` was fitted over ``band.known_span_m`` of seabed or more (its slope ahead is known)."""
        return model is not None and model.span >= self.config.band.known_span_m

    def _seabed_model(self, pos: F64) -> SeabedModel | None:
        """Seabed model around ``pos`` for the onset, refitted when the data or the area changed."""
        n_sb = self.memory.n_planes
        lo, hi = pos[:, :2].min(axis=0), pos[:, :2].max(axis=0)
        cached = self._onset_cache
        if cached is not None:
            c_lo, c_hi, c_n, model = cached
            inside = bool(np.all(lo >= c_lo) and np.all(hi <= c_hi))
            # a fit spanning only a few metres (a survey's first seconds) knows little of the slope ahead: refit
            # ten times as often while the data grow (the fit is small then)
            every = ONSET_REFIT_FRAMES
            if not self._slope_known(model):
                every = max(1, every // 10)
            recent = self.frames - self._onset_fit_frame < every
            if inside and (n_sb == c_n or recent):
                return model
        if n_sb < self.config.seabed.min_points:
            return None
        pad = ONSET_RADIUS_M
        near = self.memory.within(lo - pad, hi + pad)
        if near is None:
            return None
        try:
            model = SeabedModel.fit(near, self.config.seabed)
        except ReconError:
            return None
        ahead = self.geometry.max_range  # m: the fan's seabed footprint, ahead of the vehicle, stays inside the fit
        self._onset_cache = (lo - pad + ahead, hi + pad - ahead, n_sb, model)
        self._onset_fit_frame = self.frames
        return model

    # ---------------------------------------------------------------- objects
    @property
    def raw_points(self) -> F64:
        """Every highlight-extension point so far (before seabed removal), world NED."""
        return np.concatenate(self._raw) if self._raw else np.zeros((0, 3))

    @property
    def seabed_points(self) -> F64:
        """Every plane sample so far (the DVL's bottom points and the sparse sonar seabed returns), world NED."""
        return self.memory.points

    def seabed_depth_at(self, xy: ArrayLike, radius: float = 8.0) -> F64:
        """Depth (m, NED) of the seabed fitted under each horizontal position ``xy`` ``(n, 2)``
        (:meth:`recon.seabed_memory.SeabedMemory.depth_at`)."""
        return self.memory.depth_at(xy, radius)

    @property
    def _arc(self) -> bool:
        return self.config.front_slope

    def fit_seabed(self, lo: F64, hi: F64) -> TexturedSeabed | SeabedModel | None:
        """The seabed over the box ``lo``-``hi`` (north, east), fitted once per poll: tiled planes from the
        seabed points around it, and on them the texture grid (:meth:`recon.seabed_memory.SeabedMemory.fit`)."""
        return self.memory.fit(lo, hi)

    def _filtered_pending(self) -> tuple[F64, F64, F64]:
        if not self._pending:
            p, t, e = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 10 if self._arc else 0))
        else:
            p = np.concatenate([a for a, _, _ in self._pending])
            t = np.concatenate([b for _, b, _ in self._pending])
            e = np.concatenate([c for _, _, c in self._pending])
        self._pending = []
        if not self.memory:
            return p, t, e
        if p.shape[0] == 0:
            return p, t, e
        model = self.fit_seabed(p[:, :2].min(axis=0), p[:, :2].max(axis=0))
        if model is None:
            return p, t, e
        self.seabed = model
        keep = object_points(p, model, self.config.seabed)
        self.seabed_removed += int((~keep).sum())
        return p[keep], t[keep], e[keep]

    def _objects_on_seabed(self, objects: list[DetectedObject]) -> list[DetectedObject]:
        """Each object with the seabed depth under it, clutter rejected (:func:`recon.poll_seabed.on_seabed`)."""
        model = self.seabed
        if objects and isinstance(model, TexturedSeabed):
            lo = np.min([o.points[:, :2].min(axis=0) for o in objects], axis=0)
            hi = np.max([o.points[:, :2].max(axis=0) for o in objects], axis=0)
            if not model.covers(lo, hi):  # objects finalized away from this poll's new points
                model = self.fit_seabed(lo, hi) or model
        return on_seabed(objects, model, self.rejected)

    def _finalize(self, objects: list[DetectedObject]) -> list[DetectedObject]:
        """Front-slope correction (arc method) of final objects: points, extent, centroid (+ hidden far side)."""
        if not self._arc:
            return objects
        c, out = self.config, []
        for o in objects:
            f = make_object(o.id, replace_on_arcs(o.points, o.extra, self.geometry.spread, c.front_slope_length,
                                                  c.front_slope_width), o.times, o.extra, o.passes)
            out.append(replace(f, centroid=far_side_centre(f.centroid, f.points, f.extra, c.far_side),
                               seabed_depth=o.seabed_depth))
        return out

    def poll(self, vehicle_position: ArrayLike, t_now: float | None = None) -> list[DetectedObject]:
        """Streaming: objects the vehicle is past, final from now on (classify them now)."""
        if self._stream is None:
            self._stream = StreamingClusterer(self.config.cluster)
        p, t, e = self._filtered_pending()
        self._stream.add(p, t, e)
        out = self._finalize(self._objects_on_seabed(
            self._stream.poll(vehicle_position, self._t_last if t_now is None else t_now)))
        self.objects.extend(out)
        return out

    def finish(self) -> list[DetectedObject]:
        """End of the mission: the remaining objects (all of them when :meth:`poll` was never used)."""
        p, t, e = self._filtered_pending()
        if self._stream is None:
            out = cluster(p, t, self.config.cluster, e)
        else:
            self._stream.add(p, t, e)
            out = self._stream.flush()
        out = self._finalize(self._objects_on_seabed(out))
        self.objects.extend(out)
        return out
