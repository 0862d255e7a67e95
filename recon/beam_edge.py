"""The effective lower edge of the fan, estimated online from the seabed onset against the DVL's altitude.

A real beam has no hard vertical edge: its two-way pattern falls smoothly beyond the nominal -3 dB spread, and
the seabed comes back as a ramp of rising intensity well before the range at which the nominal edge
(``tilt + spread / 2``) meets it. The highlight-extension method needs the *effective* steepest elevation: the
one at which the seabed first shows in the image, under this sonar's pattern, gain and TVG.

Per frame (:func:`frame_edges`): the mean over the central beams, averaged over a quarter metre of range centred
on each row: a profile along range (objects in a few frames are outvoted by the running median below), its water
level
``N`` (the median of the profile at ranges shorter than the sonar's height above the seabed: no seabed can
return there; the profile's 5th percentile when the window starts beyond it)
and its seabed level ``P`` (the 90th percentile of the profile), both in the image's own grey levels. The
onset is the first range at which the profile reaches the midpoint ``(N + P) / 2`` of that log-intensity step (the
edge of a step at half its height, the usual edge convention; gain and TVG shift both levels alike). The
seabed plane is the one the onset stage predicts the onset with (:meth:`recon.onset_stage.OnsetStage.seabed_planes`:
the seabed fitted so far where the fan looks, else the flat seabed at the DVL altitude under the vehicle), seen
with the vehicle's attitude: the elevation
(in the sonar frame, above the fan's axis) whose ray meets that plane at the onset range, the median over the
central beams (the onset varies a little with the azimuth), is the frame's edge.
Frames with a step smaller than :data:`MIN_STEP_MAD` MADs of the water (no seabed in the window) give none.

:class:`BeamEdge` keeps the running median of the last ``window`` frame edges (re-estimated as the survey goes
on: gain, TVG and seabed type change) and gives the effective half-spread: the nominal ``spread / 2`` until
``min_frames`` frames gave an edge.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]

#: beams within this fraction of the fan's half-width of its centre give the profile (the central third)
CENTRAL_FRACTION = 1.0 / 3.0
#: m of range the profile is averaged over (a sampled surface's comb of bright bins and the speckle average out;
#: well under the 1-2 m of range over which the onset moves with the altitude)
SMOOTH_M = 0.25
#: water-to-seabed steps smaller than this many MADs of the water profile are not a seabed onset (Gaussian
#: 6 sigma: a false step once in ~5e8 rows)
MIN_STEP_MAD = 6.0
#: frames behind the running median: 10 s at 10 frames/s (the DVL altitude's own noise averages out, a change
#: of gain or seabed shows within the window)
WINDOW_FRAMES = 100
#: frames with an edge before the estimate replaces the nominal edge (1 s at 10 frames/s)
MIN_FRAMES = 10


def _smoothed(images: NDArray[np.uint8], geometry: SonarGeometry) -> tuple[F64, F64]:
    """The central beams' azimuths (C,) and their columns (F, bins, C) averaged over :data:`SMOOTH_M` of range
    centred on each row."""
    az = geometry.azimuths
    central = np.abs(az) <= CENTRAL_FRACTION * np.abs(az).max()
    cols = images[:, :, central].astype(np.float64)
    k = max(1, round(SMOOTH_M / geometry.bin_size))
    c = np.cumsum(np.pad(cols, ((0, 0), (k // 2 + 1, k - k // 2 - 1), (0, 0)), mode="edge"), axis=1)
    return az[central], np.asarray((c[:, k:] - c[:, :-k]) / k, dtype=np.float64)


def _plane_terms(geometry: SonarGeometry, rot: Rotation, pos: F64, point: F64, normal: F64, az: F64
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


def frame_edges(images: NDArray[np.uint8], geometry: SonarGeometry, pos: F64, rot: Rotation, point: F64,
                normal: F64) -> F64:
    """Per frame, the effective steepest elevation (rad, above the fan's axis, in S) measured from its seabed
    onset against the seabed plane (``point``, unit ``normal`` into the water, (F, 3) each) (module docstring);
    NaN where the frame shows no onset or the plane is unknown."""
    az, cols = _smoothed(images, geometry)
    prof = cols.mean(axis=2)
    r = geometry.ranges
    height, a, b = _plane_terms(geometry, rot, pos, point, normal, az)
    no_seabed = r[None, :] < height[:, None]
    has_water = no_seabed.sum(axis=1) >= 8
    water_rows = np.where(no_seabed | ~has_water[:, None], prof, np.nan)  # all rows where there is no water: unused
    with np.errstate(all="ignore"):
        n_lvl = np.where(has_water, np.nanmedian(water_rows, axis=1), np.percentile(prof, 5, axis=1))
        mad = np.where(has_water, np.nanmedian(np.abs(water_rows - n_lvl[:, None]), axis=1), 0.0)
    p_lvl = np.percentile(prof, 90, axis=1)
    step_ok = (p_lvl - n_lvl) > MIN_STEP_MAD * 1.4826 * np.maximum(mad, 1.0)
    mid = 0.5 * (n_lvl + p_lvl)
    above = (prof >= mid[:, None]) & ~no_seabed
    row = np.argmax(above, axis=1)
    found = above[np.arange(prof.shape[0]), row] & step_ok & np.isfinite(height) & (height > 0)
    g = (height / r[row])[:, None]
    amp = np.hypot(a, b)
    with np.errstate(all="ignore"):
        phi = np.arctan2(b, a) - np.arccos(np.clip(g / amp, -1.0, 1.0))  # (F, C): each beam's edge at that range
    return np.where(found & np.all(g <= amp, axis=1), np.median(phi, axis=1), np.nan)


class BeamEdge:
    """Running estimate of the effective half-spread (rad); see the module docstring."""

    def __init__(self, nominal_half: float, window: int = WINDOW_FRAMES, min_frames: int = MIN_FRAMES) -> None:
        self.nominal_half = float(nominal_half)
        self.min_frames = int(min_frames)
        self._edges: deque[float] = deque(maxlen=int(window))
        self.frames_used = 0

    def update(self, edges: F64, tilt: float) -> float:
        """Take the frame edges (rad above the axis, NaN: none) of a batch; returns the effective half-spread."""
        ok = np.asarray(edges, np.float64)
        ok = ok[np.isfinite(ok) & (ok > 0.0) & (ok < min(0.5 * np.pi - tilt, 0.25 * np.pi))]  # SonarGeometry's range
        self._edges.extend(float(e) for e in ok)
        self.frames_used += int(ok.size)
        return self.half

    @property
    def half(self) -> float:
        """The effective half-spread (rad): the running median, the nominal one until ``min_frames`` edges."""
        if len(self._edges) < self.min_frames:
            return self.nominal_half
        return float(np.median(np.fromiter(self._edges, np.float64)))
