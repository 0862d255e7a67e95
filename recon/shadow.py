"""Object heights from their acoustic shadows: the top of an object seen in the seabed band, where its shadow
starts and ends along each beam.

Beyond the seabed onset an object standing on the seabed echoes brighter than the seabed before it and hides the
seabed behind it: along a beam, after the object's echo, the image falls to the water's level until the ray that
grazes the object's top meets the seabed. On that ray the top lies at the shadow's start range ``r_top`` and the
seabed at its end ``r_s``: the ray is the one of the beam that meets the frame's seabed plane at ``r_s``, and the top
is its point at ``r_top``, ``h = H (1 - r_top / r_s)`` over a level seabed (``H`` the sonar's height). Two ranges
fix it; the vertical beam pattern, the gain and the time-varied gain that shape the highlight extension's points
(:mod:`recon.highlight`, lifted 0.1-0.45 m by soft patterns) do not enter.

:class:`ShadowTops` takes a frame each :data:`SAMPLE_M` of the vehicle's path (vectorized over rows and beams):

1. a reference per (range row, beam): the median of the frames taken :data:`REFERENCE_M` of path before, the
   seabed at that row and beam without the object (the object moves through the rows from frame to frame, while
   across the fan a long object can shadow most of a row);
2. in the seabed band (the reference :data:`BAND_FRACTION` of the way from the water's level to the seabed's), a
   shadow is a run of :data:`DARK_M` of range darker than the reference by :data:`DARK_FRACTION` of the reference's
   step over the water, starting within :data:`ECHO_GAP_M` after an echo brighter than the reference by
   :data:`ECHO_FRACTION` of the seabed's step; it ends where :data:`BACK_M` of range come back within
   :data:`BACK_FRACTION` (and no brighter than an echo); a dark gap inside an object's echo (one that resumes
   before the seabed does) is no shadow; a shadow still dark near the window's end is not measured;
3. each shadow gives a shadow top: its horizontal position (world NED) and its height over the plane.

:meth:`ShadowTops.height` gives a finalized object its top's height from the shadow tops over its footprint, when
it stands out of the shadow tops of the seabed around (a rough seabed, or a sand ripple, casts shadows too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d
from scipy.spatial.transform import Rotation

from recon.beam_edge import plane_elevation, plane_terms
from recon.exact_stats import median_stack_u8, split_medians_halves
from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]

#: m of path between the frames read: an object stays in the seabed band over several metres of approach (the band
#: from ~6 m to the window's end), so ten or more frames see it, each over every beam it spans
SAMPLE_M = 0.5
#: m of path behind a frame whose frames make its reference: far enough that an object's echo no longer lies in
#: the rows it shadows now (a 1 m high object 2.2 m under the sonar at 9 m casts a 2.4 m shadow starting at its
#: top), near enough that the rows still see the same seabed band (the vehicle's altitude and attitude alike)
REFERENCE_M = (2.0, 6.0)
#: frames a reference needs (the median of fewer follows a passing object)
MIN_REFERENCE = 5
#: m of range per row of the reference: the seabed band's level, a median over frames at other positions, changes
#: over metres of range (pattern, grazing angle, TVG), not within 0.1 m
REFERENCE_ROW_M = 0.1
#: m of range each column is averaged over before the search (speckle: the shortest shadow, DARK_M, keeps its
#: start and end to a few cm)
SMOOTH_M = 0.1
#: of the way from the water's level to the seabed's, where the reference is seabed band
BAND_FRACTION = 0.6
#: of the reference's step over the water: how much darker a shadow is (the shadow falls to the water's level)
DARK_FRACTION = 0.25
#: m: the shortest shadow measured (a 0.1 m high object 2 m under the sonar at 6 m casts 0.3 m; seabed roughness a
#: few cm)
DARK_M = 0.09
#: of the seabed's step over the water: how much brighter than the reference an object's echo is
ECHO_FRACTION = 0.25
#: m: the longest range between an object's echo and its shadow's start (its lit face, ~1 m for the largest
#: objects of recon.target_envelope)
ECHO_GAP_M = 1.2
#: of the reference's step: within how much of the reference the seabed behind a shadow returns
BACK_FRACTION = 0.10
#: m of range the seabed must hold for the shadow's end
BACK_M = 0.06
#: m before the window's end where a shadow's end no longer tells (the seabed beyond the window)
END_MARGIN_M = 0.2
#: m the object's points' box is widened by for its shadow tops (the cluster's placement scatter)
FOOTPRINT_M = 0.25
#: shadow tops an object's height needs, and the quantile of their heights taken as the top: readings fall below a
#: top far more often than above it (a ray grazing a rounded top off its crest reads lower; a long shadow's end is
#: read early where the reference frames held the object's own shadow), few are speckle above it
MIN_TOPS = 8
TOP_QUANTILE = 0.9
#: m around an object's footprint whose shadow tops are the seabed's own (roughness, texture): its height must
#: stand BACKGROUND_MARGIN_M above their TOP_QUANTILE, twice the 5 cm error of a level top's reading, or it is
#: not the object's (too few of its own shadows seen); the ring starts 0.25 m beyond the footprint's margin and
#: leaves out the tops seen over the footprint (the segment from the top back to the sonar crosses it: the object's
#: own shadow, read where its rounded or far side ends, not the seabed's)
RING_M = 3.0
BACKGROUND_MARGIN_M = 0.1
#: the quantiles of the shadow tops' heights a reading reports, over the footprint and over the ring (the classifier's
#: evidence of how the tops spread: a rounded top reads low off its crest, a rough seabed's own shadows reach high)
READING_QUANTILES = (0.5, 0.75, TOP_QUANTILE)
#: m of path the shadow tops are kept for (an object is finalized after the vehicle passed it; 100 m covers the
#: slowest finalization of recon.cluster_stream)
KEEP_M = 100.0


def _levels(ref: F32, on: NDArray[np.int64]) -> tuple[float, float] | None:
    """The water's level (the reference's median before each beam's onset row ``on``) and the seabed's (beyond it),
    grey levels; None without 8 rows of each or without a seabed band (4 grey levels over the water: 1 dB of a
    60 dB display). Beams whose onset lies beyond the reference's rows (none found) do not count."""
    keep = on < ref.shape[0]
    if not keep.any():
        return None
    ref, on = ref[:, keep], on[keep]
    before = np.arange(ref.shape[0])[:, None] < on[None, :]
    if before.sum() < 8 * ref.shape[1] or (~before).sum() < 8 * ref.shape[1]:
        return None
    water, seabed = split_medians_halves(ref, before)
    return (water, seabed) if seabed > water + 4.0 else None


def _row_type(largest: int) -> type[np.int16] | type[np.int32]:
    """The integer type of row counts and indices up to +-``largest``: 16 bits where they fit (half the memory
    traffic of the scans over every row and beam), else 32."""
    return np.int16 if largest < 2**15 else np.int32


def _runs(mask: NDArray[np.bool_], n: int) -> NDArray[np.bool_]:
    """(rows, beams): where ``mask`` holds over the ``n`` rows from each row on."""
    c = np.zeros((mask.shape[0] + 1, mask.shape[1]), _row_type(mask.shape[0]))
    np.cumsum(mask, axis=0, out=c[1:])
    out = np.zeros(mask.shape, bool)
    if n <= mask.shape[0]:
        out[: mask.shape[0] - n + 1] = (c[n:] - c[:-n]) == n
    return out


def _crosses(a: F64, b: F64, lo: F64, hi: F64) -> NDArray[np.bool_]:
    """(n,): whether each segment from ``a`` to ``b`` (n, 2) crosses the box ``[lo, hi]`` (2,) (slab test)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - a) / d, (hi - a) / d
    inside = (a >= lo) & (a <= hi)
    near = np.where(d == 0, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    far = np.where(d == 0, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    t_in, t_out = near.max(axis=1), far.min(axis=1)
    return (t_in <= t_out) & (t_out >= 0.0) & (t_in <= 1.0)


@dataclass(frozen=True)
class ShadowReading:
    """What the shadow tops say of one object (:meth:`ShadowTops.reading`): its top height (m, NaN: not measured),
    the :data:`READING_QUANTILES` of the heights of the shadow tops over its footprint and of those in the ring of
    seabed around it (m; NaN with fewer than :data:`MIN_TOPS`), and how many tops each holds."""

    height: float = math.nan
    footprint_quantiles_m: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    ring_quantiles_m: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    footprint_tops: int = 0
    ring_tops: int = 0


def _quantiles(heights: F64) -> tuple[float, float, float]:
    """The :data:`READING_QUANTILES` of ``heights`` (m); NaN with fewer than :data:`MIN_TOPS`."""
    if heights.size < MIN_TOPS:
        return (math.nan, math.nan, math.nan)
    a, b, c = (float(v) for v in np.quantile(heights, READING_QUANTILES))
    return (a, b, c)


class ShadowTops:
    """The shadow tops of the frames so far, per horizontal position (module docstring)."""

    def __init__(self) -> None:
        self._ring: list[tuple[float, NDArray[np.uint8]]] = []  # (path length m, decimated smoothed frame)
        self._path = 0.0  # m of horizontal path so far
        self._last_xy: F64 | None = None
        self._last_sample = -math.inf
        # (n, 6) chunks: north, east, height over the seabed plane (m), path length (m), the sonar's north, east (m)
        self._tops: list[F64] = []
        self.frames_read = 0
        self.shadows = 0
        #: objects given a height (``measured``) or not: fewer than MIN_TOPS shadow tops over the footprint
        #: (``too_few_shadows``), not BACKGROUND_MARGIN_M above the seabed's own around (``not_above_seabed``)
        self.outcomes = {"measured": 0, "too_few_shadows": 0, "not_above_seabed": 0}

    def add(self, images: NDArray[np.uint8], geometry: SonarGeometry, onset: F64, pos: F64, rot: Rotation,
            point: F64, normal: F64) -> None:
        """Take frames (F, bins, beams) with each beam's onset range (F, beams, m), the poses and the seabed plane
        each frame was predicted with (``point``, unit ``normal`` into the water, (F, 3) each)."""
        smooth = max(1, round(SMOOTH_M / geometry.bin_size))
        dec = max(1, round(REFERENCE_ROW_M / geometry.bin_size))
        gap = round(ECHO_GAP_M / geometry.bin_size) + smooth
        n_bins = images.shape[1]
        n_dec = n_bins // dec
        terms = plane_terms(geometry, rot, pos, point, normal, geometry.azimuths)  # per frame, all beams at once
        for f in range(images.shape[0]):
            xy = pos[f, :2]
            if self._last_xy is not None:
                self._path += float(np.hypot(*(xy - self._last_xy)))
            self._last_xy = xy.copy()
            if self._path < self._last_sample + SAMPLE_M:
                continue
            self._last_sample = self._path
            small = images[f, : n_dec * dec].reshape(n_dec, dec, -1).mean(axis=1, dtype=np.float32)
            ref = self._reference(n_dec, small.shape[1])
            self._ring.append((self._path, np.rint(small).astype(np.uint8)))
            self._ring = [e for e in self._ring if e[0] >= self._path - REFERENCE_M[1] - SAMPLE_M]
            if ref is None:
                continue
            self.frames_read += 1
            # (beams,); a beam without an onset (NaN) has no row beyond it
            on_rows = np.nan_to_num(np.ceil(geometry.range_to_row(onset[f])), nan=n_bins)
            on = np.clip(on_rows, 0, n_bins).astype(np.int64)
            levels = _levels(ref, on // dec)
            if levels is None:
                continue
            row0 = max(0, int(on.min()) - gap)  # the rows an object's echo and shadow beyond the onset can hold
            sm = uniform_filter1d(images[f, row0:].astype(np.float32), smooth, axis=0, mode="nearest")
            full = ref[np.minimum(np.arange(row0, n_bins) // dec, n_dec - 1)]  # each row's reference row
            plane = (float(terms[0][f]), terms[1][f], terms[2][f])
            tops = self._frame_tops(sm, full, row0, on, levels, geometry, pos[f], rot[f], point[f], normal[f], plane)
            if tops.shape[0]:
                self.shadows += tops.shape[0]
                self._tops.append(np.column_stack([tops, np.full(tops.shape[0], self._path),
                                                   np.broadcast_to(pos[f, :2], (tops.shape[0], 2))]))
        if len(self._tops) > 64:
            t = np.concatenate(self._tops)
            self._tops = [t[t[:, 3] >= self._path - KEEP_M]]

    def _reference(self, rows: int, beams: int) -> F32 | None:
        """The median of the frames :data:`REFERENCE_M` of path behind; None with fewer than :data:`MIN_REFERENCE`."""
        lo, hi = self._path - REFERENCE_M[1], self._path - REFERENCE_M[0]
        sel = [img for p, img in self._ring if lo <= p <= hi and img.shape == (rows, beams)]
        if len(sel) < MIN_REFERENCE:
            return None
        return median_stack_u8(sel).astype(np.float32)

    def _frame_tops(self, img: F32, ref: F32, row0: int, on: NDArray[np.int64], levels: tuple[float, float],
                    g: SonarGeometry, pos: F64, rot: Rotation, point: F64, normal: F64,
                    plane: tuple[float, F64, F64]) -> F64:
        """(n, 3) shadow tops of one frame: north, east, height. ``img`` and ``ref``: the smoothed image and the
        reference (rows from ``row0``, beams), ``on`` each beam's onset row, ``levels`` the water's and the
        seabed's level (:func:`_levels`), ``plane`` the sonar's height over the seabed plane and each beam's terms
        ``a``, ``b`` (beams,) (:func:`recon.beam_edge.plane_terms`)."""
        n_rows = img.shape[0]
        rows = np.arange(n_rows)
        before = (rows + row0)[:, None] < on[None, :]
        water, seabed = levels
        depth = ref - water
        band = ~before & (depth >= BAND_FRACTION * (seabed - water))
        diff = img - ref
        dark = band & (diff < -DARK_FRACTION * depth)
        echo = diff > ECHO_FRACTION * (seabed - water)
        back = _runs(band & (diff > -BACK_FRACTION * depth) & ~echo, max(1, round(BACK_M / g.bin_size)))
        dark_n = _runs(dark, max(2, round(DARK_M / g.bin_size)))
        prev = np.zeros_like(dark)
        prev[1:] = dark[:-1]
        starts = dark_n & ~prev
        if not starts.any():
            return np.zeros((0, 3))
        idx = _row_type(2 * n_rows)  # the row indices below, -n_rows .. 2 n_rows
        rows_i = rows.astype(idx)[:, None]
        last_echo = np.maximum.accumulate(np.where(echo, rows_i, idx(-n_rows)), axis=0)
        next_back = np.minimum.accumulate(np.where(back, rows_i, idx(2 * n_rows))[::-1], axis=0)[::-1]
        r0, b0 = np.nonzero(starts & (rows[:, None] - last_echo <= ECHO_GAP_M / g.bin_size))
        r1 = next_back[r0, b0]
        ok = r1 < n_rows - END_MARGIN_M / g.bin_size
        r0, b0, r1 = r0[ok], b0[ok], r1[ok]
        # the shadow lies between the object's last echo and the seabed's return: a dark gap inside an echo (the
        # echo resumes before the seabed does) is not one, and of the dark runs between that echo and the seabed
        # the first starts the shadow
        ok = last_echo[r1, b0] == last_echo[r0, b0]
        r0, b0, r1 = r0[ok], b0[ok], r1[ok]
        first = np.unique(b0 * (2 * n_rows) + r1, return_index=True)[1]  # starts in row order: the first kept
        r0, b0, r1 = r0[first], b0[first], r1[first]
        if r0.size == 0:
            return np.zeros((0, 3))
        r_top, r_s = g.ranges[r0 + row0], g.ranges[r1 + row0]
        az = g.azimuths[b0]
        height, a, b = plane[0], plane[1][b0], plane[2][b0]
        k = height / r_s
        ok = k <= np.hypot(a, b)
        phi = plane_elevation(a, b, k)
        p_b = r_top[:, None] * g.directions_body(phi, az) + g.mounting.lever
        world = rot.apply(p_b) + pos
        h = (world - point) @ normal
        ok &= (h > 0.0) & (h < height)
        return np.column_stack([world[ok, :2], h[ok]])

    def height(self, points: F64) -> float:
        """An object's top height over the seabed (m) from its points (N, 3, world NED): :attr:`ShadowReading.height`
        of :meth:`reading`."""
        return self.reading(points).height

    def reading(self, points: F64) -> ShadowReading:
        """What the shadow tops say of an object with points (N, 3, world NED): its top height, the
        :data:`TOP_QUANTILE` of the heights of the shadow tops over the points' box widened by :data:`FOOTPRINT_M`
        (NaN with fewer than :data:`MIN_TOPS` there, or when it does not stand :data:`BACKGROUND_MARGIN_M` above the
        same quantile of the seabed's shadow tops in the ring :data:`RING_M` around, with :data:`MIN_TOPS` there),
        and the quantiles and counts of both sets of tops (:class:`ShadowReading`)."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        if p.shape[0] == 0 or not self._tops:
            self.outcomes["too_few_shadows"] += 1
            return ShadowReading()
        t = self.tops
        lo, hi = p[:, :2].min(axis=0) - FOOTPRINT_M, p[:, :2].max(axis=0) + FOOTPRINT_M
        inside = np.all((t[:, :2] >= lo) & (t[:, :2] <= hi), axis=1)
        near = np.all((t[:, :2] >= lo - FOOTPRINT_M) & (t[:, :2] <= hi + FOOTPRINT_M), axis=1)
        ring = np.all((t[:, :2] >= lo - RING_M) & (t[:, :2] <= hi + RING_M), axis=1) & ~near
        ring[ring] = ~_crosses(t[ring, :2], t[ring, 4:6], lo, hi)  # the object's own shadow is not the seabed's
        own, around = t[inside, 2], t[ring, 2]
        reading = ShadowReading(math.nan, _quantiles(own), _quantiles(around), int(own.size), int(around.size))
        if own.size < MIN_TOPS:
            self.outcomes["too_few_shadows"] += 1
            return reading
        top = float(np.quantile(own, TOP_QUANTILE))
        if around.size >= MIN_TOPS and top < float(np.quantile(around, TOP_QUANTILE)) + BACKGROUND_MARGIN_M:
            self.outcomes["not_above_seabed"] += 1
            return reading
        self.outcomes["measured"] += 1
        return replace(reading, height=top)

    @property
    def tops(self) -> F64:
        """Every shadow top kept: (n, 6) north, east (m, world NED), height over the seabed (m), path length (m), and
        the sonar's north, east when it was seen (m)."""
        return np.concatenate(self._tops) if self._tops else np.zeros((0, 4))
