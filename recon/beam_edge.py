"""The effective lower edge of the fan, estimated online from the seabed onset against the DVL's altitude.

A real beam has no hard vertical edge: its two-way pattern falls smoothly beyond the nominal -3 dB spread, and
the seabed comes back as a ramp of rising intensity well before the range at which the nominal edge
(``tilt + spread / 2``) meets it. The highlight-extension method needs the *effective* steepest elevation: the
one at which the seabed first shows in the image, under this sonar's pattern, gain and TVG.

Per frame (:func:`frame_edges`): each central beam's column, as its upper envelope (each row's maximum over the
:data:`ENVELOPE_M` of range ending at it: the comb of bright bins a sampled surface makes and the speckle's dark
samples fill in, while a surface's first bright bin stays where it is), in the image's own grey levels. The
central beams' median envelope gives the frame's water level ``N`` (its median at ranges shorter than the
sonar's height above the seabed plane: no seabed can return there; its 5th percentile when the window starts
beyond that) and seabed level ``P`` (its 90th percentile beyond that height). Each central beam's onset is the
first range beyond that height at which its envelope reaches the midpoint ``(N + P) / 2`` of that log-intensity
step (the edge of a step at half its height, the usual edge convention; gain and TVG shift both levels alike).
Under the time-varied gain the water's noise climbs with range (spreading and absorption: 20 dB over 6 m at
1.8 MHz); from under the display's floor, where the water shows no level or slope to follow, it can climb through
half the step before the seabed shows, and the edge would be where the noise crosses it, degrees too steep. The
noise climbs, the seabed steps: where the median envelope reaches the half step before the foot of its steepest
rise over :data:`STEP_M`, and that rise is :data:`CLIMB_RATIO` times as steep as any before the crossing
(:func:`_noise_climb`), the step is that rise's, from its foot to its top, and the onsets are sought from its foot.
The seabed plane is the one the onset stage predicts the onset with
(:meth:`recon.onset_stage.OnsetStage.seabed_planes`: the seabed fitted so far where the fan looks, else the flat
seabed at the DVL altitude under the vehicle), seen with the vehicle's attitude: per beam, the elevation (in the
sonar frame, above the fan's axis) whose ray meets that plane at the beam's onset range; their median (an object
in a few beams, a sloped or rolled seabed moving the onset across the fan) is the frame's edge. Frames with a
step smaller than :data:`MIN_STEP_MAD` MADs of the water (no seabed in the window), or with fewer than half the
central beams showing the onset, give none.

:class:`BeamEdge` keeps the running median of the last ``window`` frame edges (re-estimated as the survey goes
on: gain, TVG and seabed type change) and gives the effective half-spread: the nominal ``spread / 2`` until
``min_frames`` frames gave an edge, and never less than it afterwards (the data sheet's spread is the two-way
-3 dB width; a real beam has energy beyond it, so the seabed shows at or beyond the nominal edge, and an estimate
inside it is the range quantization of a hard edge).
"""

from __future__ import annotations

import warnings
from collections import deque

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from recon.exact_stats import masked_percentile, median_u8
from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]

#: beams within this fraction of the fan's half-width of its centre give the profile (the central third)
CENTRAL_FRACTION = 1.0 / 3.0
#: m of range behind each row's upper envelope (recon.highlight's return span: a surface's bright bins lie closer
#: than that, and it is well under the 1-2 m of range over which the onset moves with the altitude)
ENVELOPE_M = 0.25
#: m of range over which the seabed's onset rises (two envelope spans: the first bright bins of a lit seabed and
#: the rows before them; the water's noise, lifted by the time-varied gain by 30 log r + 2 alpha r dB, climbs
#: ~10 grey levels over it on a 60 dB display at 10 m and 1.8 MHz)
STEP_M = 2 * ENVELOPE_M
#: how many times steeper than anything before it the seabed's step rises over STEP_M where the water's noise
#: climbed over the half step first (DIDSON at 1.8 MHz: the noise ~10 grey levels per 0.5 m at 10 m, the hard edge
#: of a seabed 25-45; a vertical sidelobe's band and the main lobe after it step alike, within a factor of 1.5)
CLIMB_RATIO = 2.0
#: water-to-seabed steps smaller than this many MADs of the water profile are not a seabed onset (Gaussian
#: 6 sigma: a false step once in ~5e8 rows)
MIN_STEP_MAD = 6.0
#: the fraction of the water-to-seabed step (grey levels: dB on a log display) at which the seabed's onset is taken,
#: and the level a return must reach (:attr:`BeamEdge.level`): half (an edge at half its height, the usual edge
#: convention; there the beam pattern falls fastest with elevation, so a reflector brighter or fainter than the
#: seabed by a few dB is still placed near the elevation it was seen at, where deeper in the pattern's flat tail the
#: same few dB move it by degrees; a reflector as bright as the seabed shows where the effective edge meets it)
ONSET_STEP = 0.5

#: frames behind the running median: 60 s at 10 frames/s (the DVL altitude's noise, the crests and troughs of a
#: rough seabed under the fan's edge for a few seconds each and the objects passing through it average out; gain,
#: TVG and seabed type change from survey to survey, and a change shows within the window)
WINDOW_FRAMES = 600
#: frames with an edge before the estimate replaces the nominal edge (1 s at 10 frames/s)
MIN_FRAMES = 10


def _envelope(images: NDArray[np.uint8], geometry: SonarGeometry) -> tuple[F64, NDArray[np.uint8]]:
    """The central beams' azimuths (C,) and their columns' upper envelope (F, bins, C): each row's maximum over
    the :data:`ENVELOPE_M` of range that end at it (a sampled surface's comb of bright bins and the speckle's dark
    samples fill in; a surface's first bright bin stays where it is)."""
    az = geometry.azimuths
    central = np.abs(az) <= CENTRAL_FRACTION * np.abs(az).max()
    idx = np.flatnonzero(central)
    # a run of beams (a bearing table in order) is a slice: a view, where a mask gathers beam by beam
    run = idx.size > 0 and idx[-1] - idx[0] + 1 == idx.size
    cols = images[:, :, idx[0] : idx[-1] + 1] if run else images[:, :, central]
    k = max(1, round(ENVELOPE_M / geometry.bin_size))
    env = np.array(cols, dtype=np.uint8)
    spare = np.empty_like(env)
    span = 1
    while span < k:  # running maximum over the k rows ending at each row, by doubling (log2 k passes)
        step = min(span, k - span)
        spare[:, :step] = env[:, :step]
        np.maximum(env[:, step:], env[:, :-step], out=spare[:, step:])
        env, spare = spare, env
        span += step
    return az[central], env


def plane_terms(geometry: SonarGeometry, rot: Rotation, pos: F64, point: F64, normal: F64, az: F64
                 ) -> tuple[F64, F64, F64]:
    """The sonar's height (F,) above the seabed plane (``point``, unit ``normal`` into the water, (F, 3) each) and,
    per beam at azimuth ``az``, the terms ``a``, ``b`` (F, C) of the normal in S: a ray at elevation ``phi`` meets
    the plane at range ``height / (a cos phi + b sin phi)``, as in :meth:`SonarGeometry.onset_ranges`."""
    m_wb = rot.as_matrix().reshape(-1, 3, 3)
    m_ws = m_wb @ geometry.mounting.rotation.as_matrix()
    origin = pos + m_wb @ geometry.mounting.lever
    height = np.einsum("fi,fi->f", normal, origin - point)
    n_s = np.einsum("fi,fij->fj", normal, m_ws)
    a = -(n_s[:, :1] * np.cos(az) + n_s[:, 1:2] * np.sin(az))
    return height, a, np.broadcast_to(-n_s[:, 2:3], a.shape)


def plane_elevation(a: F64, b: F64, k: F64) -> F64:
    """The steeper elevation (rad, above the fan's axis) at which a ray meets the plane of :func:`plane_terms`'s
    ``a``, ``b`` where ``a cos phi + b sin phi = k`` (``k``: the sonar's height over the plane / the range). Where no
    ray meets the plane at that range (``k > hypot(a, b)``) ``k`` is clipped (the grazing ray): callers mask those."""
    with np.errstate(all="ignore"):
        return np.asarray(np.arctan2(b, a) - np.arccos(np.clip(k / np.hypot(a, b), -1.0, 1.0)), np.float64)


def _levels(prof: F64, no_seabed: NDArray[np.bool_]) -> tuple[F64, F64, NDArray[np.bool_]]:
    """Per frame and row the water level ``N`` (F, bins), per frame the seabed level ``P`` (F,), both of the
    central beams' median envelope ``prof`` (F, bins) in grey levels, and whether that step is a seabed onset
    (module docstring); ``no_seabed`` (F, bins) the rows no seabed can return from (a prefix of each frame's rows)."""
    rows = np.arange(prof.shape[1], dtype=np.float64)
    h = no_seabed.sum(axis=1).astype(np.float64)  # (F,): rows before the seabed can show
    has_water = h >= 8
    near, far = rows[None, :] < 0.5 * h[:, None], no_seabed & (rows[None, :] >= 0.5 * h[:, None])
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows (no water, no seabed): NaN levels, no step
        n_near = masked_percentile(prof, near, 50)
        n_far = masked_percentile(prof, far, 50)
        mad = masked_percentile(np.abs(prof - n_far[:, None]), far, 50)
        p_lvl = masked_percentile(prof, ~no_seabed, 90)
        # the water's level along range: a line through the medians of the water's near and far halves (the
        # time-varied gain lifts the noise with range), never falling
        slope = np.where(has_water, np.maximum(0.0, (n_far - n_near) / (0.5 * h)), 0.0)
        flat = np.percentile(prof, 5, axis=1)
    n_lvl = np.where(has_water, n_far, flat)[:, None] + slope[:, None] * (rows[None, :] - 0.75 * h[:, None])
    step_ok = np.nan_to_num(p_lvl - np.where(has_water, n_far, flat)) > (
        MIN_STEP_MAD * 1.4826 * np.maximum(np.where(has_water, np.nan_to_num(mad), 0.0), 1.0))
    return n_lvl, p_lvl, step_ok


def _noise_climb(prof: F64, no_seabed: NDArray[np.bool_], n_lvl: F64, p_lvl: F64, span: int
                 ) -> tuple[NDArray[np.bool_], NDArray[np.int64], F64, F64]:
    """Per frame, whether the water's noise climbing under the time-varied gain crossed the half step before the
    seabed shows (F,), and the seabed's steepest rise: its foot's row (F,), the level there (F,; never under the
    water's) and the level it reaches (F,: the highest within ``2 span`` rows of the foot). ``prof`` (F, bins) is
    the central beams' median envelope; a rise is taken over ``span`` rows. The noise is taken to have crossed
    where the envelope reaches the half step before the foot of its steepest rise, and that rise is at least
    :data:`CLIMB_RATIO` times the steepest one up to the crossing: the noise climbs, the seabed steps (a vertical
    sidelobe's band that lights the seabed first steps as steeply as the main lobe after it)."""
    f, n = prof.shape
    h = no_seabed.sum(axis=1)
    if n <= 2 * span:
        return np.zeros(f, bool), np.zeros(f, np.int64), np.full(f, np.nan), np.full(f, np.nan)
    rows = np.arange(n)[None, :]
    rise = np.full((f, n), -np.inf)  # the rise over the span rows that end at each row
    rise[:, span:] = np.nan_to_num(prof[:, span:] - prof[:, :-span], nan=-np.inf)
    rise[rows < h[:, None]] = -np.inf
    foot = (np.argmax(rise, axis=1) - span).astype(np.int64)
    steepest = np.max(rise, axis=1)
    crossed = (prof >= n_lvl + ONSET_STEP * (p_lvl[:, None] - n_lvl)) & (rows >= h[:, None])
    cross = np.where(crossed.any(axis=1), np.argmax(crossed, axis=1), n)
    before = np.max(np.where(rows <= cross[:, None], rise, -np.inf), axis=1)
    climbed = (foot > cross) & (steepest >= CLIMB_RATIO * np.maximum(before, 1.0))
    at = np.clip(foot, 0, n - 1)[:, None]
    level = np.maximum(np.take_along_axis(prof, at, axis=1)[:, 0], np.take_along_axis(n_lvl, at, axis=1)[:, 0])
    top = np.max(np.where((rows >= at) & (rows <= at + 2 * span), prof, -np.inf), axis=1)
    return climbed, foot, level, np.maximum(top, level)


def frame_edges(images: NDArray[np.uint8], geometry: SonarGeometry, pos: F64, rot: Rotation, point: F64,
                normal: F64) -> tuple[F64, F64]:
    """Per frame, the effective steepest elevation (rad, above the fan's axis, in S) measured from its seabed
    onset against the seabed plane (``point``, unit ``normal`` into the water, (F, 3) each), and the grey level
    ``(N + P) / 2`` that defines that onset (module docstring); both (F,), NaN where the frame shows no onset or
    the plane is unknown."""
    edges, level, _ = frame_edge_profile(images, geometry, pos, rot, point, normal, (ONSET_STEP,))
    return edges[:, 0], level


def frame_edge_profile(images: NDArray[np.uint8], geometry: SonarGeometry, pos: F64, rot: Rotation, point: F64,
                       normal: F64, fractions: tuple[float, ...]) -> tuple[F64, F64, F64]:
    """:func:`frame_edges` at each of ``fractions`` of the water-to-seabed step (the first one defines the level):
    the elevations (F, K) at which the seabed onset reaches ``N + fraction (P - N)`` (a lower fraction is reached
    at a steeper elevation: the beam pattern's fall beyond the edge, :mod:`recon.pattern_fall`), the grey level
    of the first fraction at the onset (F,) and the step ``P - N`` there (F,); NaN where a frame shows no onset."""
    az, env = _envelope(images, geometry)
    r = geometry.ranges
    height, a, b = plane_terms(geometry, rot, pos, point, normal, az)
    with np.errstate(invalid="ignore"):
        no_seabed = r[None, :] < height[:, None]
    prof = median_u8(env)  # (F, bins): the central beams' median (an object in a few beams is outvoted)
    n_lvl, p_lvl, step_ok = _levels(prof, no_seabed)
    span = max(1, round(STEP_M / geometry.bin_size))
    climbed, foot, foot_lvl, top = _noise_climb(prof, no_seabed, n_lvl, p_lvl, span)
    # where the noise climbed over the half step: the seabed's step from its foot to its top, none before it
    base = np.where(climbed[:, None], foot_lvl[:, None], n_lvl)  # (F, bins)
    top = np.where(climbed, top, p_lvl)
    before = climbed[:, None] & (np.arange(env.shape[1])[None, :] < foot[:, None])
    amp = np.hypot(a, b)
    edges = np.full((env.shape[0], len(fractions)), np.nan)
    level = step = np.full(env.shape[0], np.nan)
    for k, fraction in enumerate(fractions):
        lvl = base + fraction * (top[:, None] - base)  # (F, bins)
        above = (env >= lvl[:, :, None]) & ~(no_seabed | before)[:, :, None]  # (F, bins, C)
        row = np.argmax(above, axis=1)  # (F, C): each central beam's onset row
        hit = np.take_along_axis(above, row[:, None, :], axis=1)[:, 0, :]
        g = height[:, None] / r[row]
        phi = np.where(hit & (g <= amp), plane_elevation(a, b, g), np.nan)  # (F, C): each beam's edge at its onset
        enough = np.isfinite(phi).sum(axis=1) >= 0.5 * phi.shape[1]  # most central beams show the onset
        ok = step_ok & enough & np.isfinite(height) & (height > 0)
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # frames without an onset: NaN
            edges[:, k] = np.where(ok, np.nanmedian(np.where(ok[:, None], phi, 0.0), axis=1), np.nan)
        if k == 0:
            at = np.median(row, axis=1).astype(np.int64)[:, None]
            found = np.isfinite(edges[:, 0])
            level = np.where(found, np.take_along_axis(lvl, at, axis=1)[:, 0], np.nan)
            step = np.where(found, p_lvl - np.take_along_axis(base, at, axis=1)[:, 0], np.nan)
    return edges, level, step


class BeamEdge:
    """Running estimates of the effective half-spread (rad) and of the grey level that defines it (the seabed
    onset's half step); see the module docstring."""

    def __init__(self, nominal_half: float, window: int = WINDOW_FRAMES, min_frames: int = MIN_FRAMES) -> None:
        self.nominal_half = float(nominal_half)
        self.min_frames = int(min_frames)
        self._edges: deque[float] = deque(maxlen=int(window))
        self._levels: deque[float] = deque(maxlen=int(window))
        self.frames_used = 0

    def update(self, edges: F64, tilt: float, levels: F64 | None = None) -> float:
        """Take the frame edges (rad above the axis, NaN: none) of a batch and their onset levels (grey levels,
        :func:`frame_edges`); returns the effective half-spread."""
        e = np.asarray(edges, np.float64)
        lv = np.full(e.shape, np.nan) if levels is None else np.asarray(levels, np.float64)
        keep = np.isfinite(e) & (e > 0.0) & (e < min(0.5 * np.pi - tilt, 0.25 * np.pi))  # SonarGeometry's range
        self._edges.extend(float(x) for x in e[keep])
        self._levels.extend(float(x) for x in lv[keep & np.isfinite(lv)])
        self.frames_used += int(keep.sum())
        return self.half

    @property
    def half(self) -> float:
        """The effective half-spread (rad): the running median, at least the nominal one (module docstring); the
        nominal one until ``min_frames`` edges."""
        if len(self._edges) < self.min_frames:
            return self.nominal_half
        return max(self.nominal_half, float(np.median(np.fromiter(self._edges, np.float64))))

    @property
    def level(self) -> float:
        """The grey level at which the seabed shows (the running median of the frames' onset levels); NaN until
        ``min_frames`` levels. A return fainter than this is one the effective edge does not account for: a
        reflector as bright as the seabed reaches it where the edge says, a fainter one only farther inside the
        beam, where its placement on the edge ray would be wrong."""
        if len(self._levels) < self.min_frames:
            return float("nan")
        return float(np.median(np.fromiter(self._levels, np.float64)))
