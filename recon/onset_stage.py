"""Recon's first stage: where each beam of a frame meets the seabed (the expected onset), and the frame's threshold.

Per batch of frames (poses interpolated at the frame times): the onset predicted by the seabed fitted so far
around the vehicle (:class:`recon.seabed.SeabedModel`, from the seabed samples of :mod:`recon.seabed_memory`;
a flat seabed at the DVL altitude until there are enough), the frame's highlight threshold from the water
column before it (:func:`recon.highlight.frame_thresholds`), each column's seabed return near it
(:func:`recon.seabed_band.seabed_returns`) and the onset corrected by those returns
(:class:`recon.seabed_band.OnsetTracker`). The later stages search the highlight returns before the corrected
onset and take the seabed returns as seabed samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from recon.errors import ReconError
from recon.highlight import MIN_STAT_ROWS, frame_thresholds, onset_rows
from recon.recon_config import ReconConfig
from recon.seabed import SeabedModel
from recon.seabed_band import SEABED_BAND, OnsetTracker, seabed_returns
from recon.seabed_memory import SeabedMemory
from recon.sonar_geometry import SonarGeometry
from recon.water_threshold import WaterThreshold

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: m of seabed samples around the frames' positions behind the seabed fitted for the expected onset: the fit's box
#: holds the fan's footprint ahead (the range window's end, 11 m) and 19 m of travel (13 s at 1.5 m/s) before a refit
ONSET_RADIUS_M = 30.0
#: frames between refits of that seabed while the vehicle stays inside it (10 s at 10 frames/s)
ONSET_REFIT_FRAMES = 100


@dataclass(frozen=True, eq=False)
class FrameOnsets:
    """The onset stage's result for a batch of F frames: ``onset`` (F, beams) corrected expected onset ranges (m),
    ``threshold`` (F,) grey levels, ``row_threshold`` (F, bins) the threshold of each row (at least ``threshold`` and
    the background before the onsets of the frames so far, :mod:`recon.water_threshold`), and the seabed returns
    ``seabed`` as (frame, beam, row) arrays."""

    onset: F64
    threshold: F64
    row_threshold: F64
    seabed: tuple[I64, I64, I64]


class OnsetStage:
    """The expected onset of every frame and beam (module docstring); holds the seabed fit behind it."""

    def __init__(self, geometry: SonarGeometry, config: ReconConfig, memory: SeabedMemory) -> None:
        self.geometry, self.config, self.memory = geometry, config, memory
        self._tracker = OnsetTracker(geometry.n_beams, SEABED_BAND)
        self._cache: tuple[F64, F64, int, SeabedModel] | None = None
        self._model: SeabedModel | None = None  # the fit behind the latest expected onsets
        self._fit_frame = 0
        self._water = WaterThreshold(geometry.n_bins)  # the background before the onsets (recon.water_threshold)

    def run(self, frames_before: int, images: NDArray[np.uint8], pos: F64, rot: Rotation, alt: F64,
            floor: float = float("nan")) -> FrameOnsets:
        """The onsets, thresholds and seabed returns of ``images`` (F, bins, beams) at poses ``pos``, ``rot`` and
        DVL altitudes ``alt``; ``frames_before`` counts the frames recon took before this batch; every row's
        threshold is at least ``floor`` (grey levels; NaN: none), the level at which the seabed shows at the
        effective edge (:attr:`recon.beam_edge.BeamEdge.level`)."""
        g, hc, band = self.geometry, self.config.highlight, SEABED_BAND
        onset = self._predicted(frames_before, pos, rot, alt)
        # the threshold's statistics come from the water column before the widest seabed search
        water = int(onset_rows(g, onset, hc.margin_m + max(band.lead_m, band.lead_flat_m)).min(initial=g.n_bins))
        thr = frame_thresholds(images, water, hc)
        # while the seabed fitted so far spans only a few metres (the first seconds of a survey) its slope is
        # unknown (the regional plane is level; recon.seabed): search much wider
        known = self._slope_known(self._model)
        self._tracker.set_known(known)
        lead_m = band.lead_m if known else band.lead_flat_m
        # a column's seabed return is where it reaches the seabed's own level (the half step at which the
        # effective edge is measured, recon.beam_edge) over the frame's water: not over the background pooled from
        # earlier frames (recon.water_threshold), which near the onset holds the seabed's glow and crests of frames
        # whose onset lay nearer; above the seabed's level the search finds the seabed past its onset, and its
        # return, placed on the steepest ray, lies under the seabed (0.25 m at the median under a Gaussian pattern
        # 2.9 widths wide: tests/test_recon_seabed_band.py)
        rows = np.fmax(np.broadcast_to(thr[:, None], (thr.shape[0], g.n_bins)), floor)
        sf, sb, sr = seabed_returns(g, images, onset, rows, hc.margin_m, band, lead_m)
        onset = self._tracker.correct(g, onset, sf, sb, sr)
        if self.config.calibrate:
            self._water.update(images, onset_rows(g, onset, hc.margin_m))
            rows = self._highlight_rows(thr, water, floor)
        return FrameOnsets(onset, thr, rows, (sf, sb, sr))

    def _highlight_rows(self, thr: F64, water_rows: int, floor: float) -> F64:
        """(F, bins) thresholds of the highlight search with calibration: at least the background before the
        onsets (:mod:`recon.water_threshold`), the seabed's onset level ``floor`` and the frame's threshold ``thr``
        (F,) where that came from the water column; with fewer than ``MIN_STAT_ROWS`` water rows before the widest
        seabed search (:func:`recon.highlight.frame_thresholds` then reads the whole image, the seabed band
        included, and its threshold lies above the seabed's own level) the background and the level alone."""
        background = self._water.thresholds
        frame = thr if water_rows >= MIN_STAT_ROWS or not np.isfinite(background).any() else np.full_like(thr, np.nan)
        return np.asarray(np.fmax(np.fmax(frame[:, None], background[None, :]), floor), dtype=np.float64)

    def _predicted(self, frames_before: int, pos: F64, rot: Rotation, alt: F64) -> F64:
        """Expected seabed onset per frame and beam: the fitted seabed plane where the fan looks, else a flat
        seabed at the DVL altitude."""
        model = self._seabed_model(frames_before, pos)
        onset = self._onset_of(model, pos, rot, alt)
        if model is not self._model:  # a new fit: the tracked correction stays on the same seabed
            self._tracker.rebase(self._onset_of(self._model, pos[:1], rot[:1], alt[:1])[0] - onset[0])
            self._model = model
        return onset

    def _onset_of(self, model: SeabedModel | None, pos: F64, rot: Rotation, alt: F64) -> F64:
        """Onset ranges (F, beams) predicted by ``model`` (None: a flat seabed at the DVL altitude)."""
        if model is None:
            return self.geometry.flat_onset_ranges(pos, rot, alt)
        return self.geometry.onset_ranges(pos, rot, *self.seabed_planes(pos, rot, alt, model))

    def seabed_planes(self, pos: F64, rot: Rotation, alt: F64, model: SeabedModel | None = None,
                      frames_before: int | None = None) -> tuple[F64, F64]:
        """Per frame the seabed plane where the fan's edge looks: a point (F, 3) and the unit normal into the water
        (F, 3), from ``model`` (default: the seabed fitted around ``pos`` for the expected onsets of a batch after
        ``frames_before`` frames, or the latest fit when that is None), else the flat seabed at the DVL altitude
        ``alt`` under the vehicle (NaN where that is unknown)."""
        if model is None:
            model = self._model if frames_before is None else self._seabed_model(frames_before, pos)
        if model is None:
            q = np.array(pos, dtype=np.float64)
            q[:, 2] += alt
            return q, np.tile([0.0, 0.0, -1.0], (q.shape[0], 1))
        g = self.geometry
        known = np.isfinite(alt)
        h = alt if known.all() else np.where(known, alt, model.depth_at(pos) - pos[:, 2])
        fwd = rot.as_matrix().reshape(-1, 3, 3)[:, :2, 0]
        fwd = fwd / np.maximum(np.linalg.norm(fwd, axis=1, keepdims=True), 1e-9)
        look = pos[:, :2] + fwd * (np.maximum(h, 0.0) / np.tan(g.tilt + 0.5 * g.spread))[:, None]
        q, n = model.plane_at(look)
        return np.asarray(q, np.float64).reshape(-1, 3), np.broadcast_to(np.asarray(n, np.float64), (len(pos), 3))

    def _slope_known(self, model: SeabedModel | None) -> bool:
        """True when ``model`` was fitted over ``SEABED_BAND.known_span_m`` of seabed or more (its slope ahead is
        known)."""
        return model is not None and model.span >= SEABED_BAND.known_span_m

    def _seabed_model(self, frames_before: int, pos: F64) -> SeabedModel | None:
        """Seabed model around ``pos`` for the onset, refitted when the data or the area changed."""
        n_sb = self.memory.n_planes
        lo, hi = pos[:, :2].min(axis=0), pos[:, :2].max(axis=0)
        if self._cache is not None:
            c_lo, c_hi, c_n, model = self._cache
            inside = bool(np.all(lo >= c_lo) and np.all(hi <= c_hi))
            # a fit spanning only a few metres (a survey's first seconds) knows little of the slope ahead: refit
            # ten times as often while the data grow (the fit is small then)
            every = ONSET_REFIT_FRAMES if self._slope_known(model) else max(1, ONSET_REFIT_FRAMES // 10)
            if inside and (n_sb == c_n or frames_before - self._fit_frame < every):
                return model
        if n_sb < self.config.seabed.min_points:
            return None
        near = self.memory.within(lo - ONSET_RADIUS_M, hi + ONSET_RADIUS_M)
        if near is None:
            return None
        try:
            model = SeabedModel.fit(near, self.config.seabed)
        except ReconError:
            return None
        ahead = self.geometry.max_range  # m: the fan's seabed footprint, ahead of the vehicle, stays inside the fit
        self._cache = (lo - ONSET_RADIUS_M + ahead, hi + ONSET_RADIUS_M - ahead, n_sb, model)
        self._fit_frame = frames_before
        return model
