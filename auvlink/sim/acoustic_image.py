"""Realistic image formation of the simulated sonar: the profiles of :mod:`auvlink.sim.acoustics`.

Input: the nearest hit of every elevation sample of every beam (``K`` samples spread evenly over
``vertical_extent`` times the vertical -3 dB width, :class:`~auvlink.sim.sonar_render.RayHits`).
Output: the uint8 image ``[range bin, beam]``. Steps, all vectorized over the frame:

1. Energy of each sample, after an exact time-varied gain (spherical spreading, absorption and the
   area of a range bin compensated)::

       e = sigma(alpha) * B(phi) dphi * r / (cos(alpha) * dr) * 10^(tvg_error (r - r_mid) / 10)

   ``sigma`` the backscatter per unit area at incidence ``alpha`` (seabed: Lambert
   ``mu cos^2 alpha``; objects: the material's diffuse ``cos^2 alpha`` plus a specular lobe),
   ``B`` the two-way vertical pattern, ``dr`` the bin width. A level Lambert seabed fully in the
   beam reads ``mu sin^2(g) / cos(g)`` at grazing angle ``g``.
2. Continuous in elevation: two neighbouring samples of a beam on the same surface (the seabed, or
   one object with less than :data:`OBJECT_GAP_M` between them) spread their mean energy
   uniformly over the ranges between them (the integral of the vertical aperture, piecewise linear
   in range), so a level seabed is one continuous band at any ``K``; a sample without such a
   neighbour keeps its share in its own bin (an edge).
   Surface multipath (shallow water): every sample's echo also returns over the sea surface (``z = 0``, world
   NED): out direct and back over the surface, or the reverse, both ``r + r_s`` long (``r_s`` the path from the
   sonar's image above the surface), so its ghost shows at ``(r + r_s) / 2`` in the same beam, at
   ``multipath_db`` under the echo, times the extra spreading ``(r / r_s)^2`` and the gain the TVG gives the
   longer range ``((r + r_s) / 2r)^3`` (the extra absorption and the TVG's compensation of it cancel). The
   ghosts integrate in elevation as the echoes do; a frame whose ghosts all fall past the window skips them.
3. Pulse: each bin's energy spreads over ``[r, r + pulse_m]`` (a rectangular pulse; the echo's
   leading edge stays at the true range). Azimuth pattern: each beam receives the others through
   its two-way response, a gaussian main lobe and sidelobes from ``sidelobe_db`` two beams off,
   falling as ``1/k^2`` with the offset (:mod:`auvlink.sim.azimuth_response`, by FFT): the arcs across the fan of a
   strong return.
4. Speckle (multiplicative, unit mean: gamma intensity of ``speckle_looks`` looks, times a gamma
   texture of shape ``texture_shape`` when > 0: K-distributed amplitude), additive noise
   (exponential power of mean ``noise_floor_db`` at the window's middle, scaled by the TVG's
   spreading and absorption gain along range), interference (a band of 1-7 bins across the fan at
   ``interference_db`` in ``interference_fraction`` of the frames), the survey's gain, then the 8-bit
   log display. Without a generator (``speckle=False``) the image is the expected level alone.

Random draws come from the frame's generator (:func:`auvlink.sim.sonar_render.frame_rng`): speckle
and noise by inverse-CDF lookup of one 16-bit integer each (tables built once), then the
interference's decision, position, width and per-beam levels. The survey's gain offset is drawn from
the scene's seed (stream :data:`ACOUSTIC_STREAM`).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray
from scipy import special

from auvlink.sim.acoustics import Acoustics
from auvlink.sim.azimuth_response import AzimuthMixer
from auvlink.sim.sonar_geometry import RayFan

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]
FArray = TypeVar("FArray", NDArray[np.float32], NDArray[np.float64])

#: SeedSequence stream tag of the per-survey acoustic draws (the gain offset)
ACOUSTIC_STREAM = 0xAC0057
#: two samples on one object further apart in range than this are two surfaces (an edge between)
OBJECT_GAP_M = 0.15
#: neighbouring samples nearer in range than this (bins) are one point, not a segment
MIN_SPAN_BINS = 1e-3
#: incidence cosine floor: a facet seen edge-on holds at most 20x its projected area in one sample
MIN_COS = 0.05
#: widest interference band, bins (a DVL ping of ~1 ms blanks a few centimetres of range)
MAX_BAND_BINS = 7
#: dB: a multipath level at or under this is no multipath (the schema's floor is -100 dB)
MULTIPATH_OFF_DB = -80.0
SINC2_HALF_POWER = 0.442946470689452  # x where (sin(pi x) / (pi x))^2 = 1/2


def vertical_pattern(shape: str, width: float, phi: F64) -> F64:
    """Two-way power pattern at elevations ``phi`` (rad) off the boresight, -3 dB at ``+-width/2``."""
    u = np.asarray(phi, float) / (width / 2.0)
    if shape == "uniform":
        return (np.abs(u) <= 1.0).astype(float)
    if shape == "gaussian":
        return np.asarray(np.exp(-math.log(2.0) * u * u))
    if shape == "sinc2":
        return np.asarray(np.sinc(u * SINC2_HALF_POWER) ** 2)
    raise ValueError(f"unknown vertical pattern {shape!r}")


@lru_cache(maxsize=16)
def speckle_table(looks: float, texture: float) -> F32:
    """65536 quantiles of the unit-mean speckle intensity factor (gamma looks x gamma texture)."""
    q = (np.arange(65536) + 0.5) / 65536.0
    if texture <= 0.0:
        return np.asarray(special.gammaincinv(looks, q) / looks, np.float32)
    t = special.gammaincinv(texture, (np.arange(512) + 0.5) / 512.0) / texture  # texture quantiles
    x = np.geomspace(1e-7, 1e3, 8192)
    cdf = special.gammainc(looks, looks * x[:, None] / t[None, :]).mean(axis=1)
    return np.asarray(np.interp(q, cdf, x), np.float32)


#: 65536 quantiles of a unit-mean exponential (noise power)
EXP_TABLE = np.asarray(-np.log1p(-(np.arange(65536) + 0.5) / 65536.0), np.float32)


def spread_in_range(energy: FArray, pulse_bins: float) -> FArray:
    """Range-major (bins, beams): each bin's energy spread uniformly over the next ``pulse_bins`` bins
    (``floor`` whole bins, then the fraction in one more): a rectangular pulse, energy kept."""
    if pulse_bins <= 1.0:
        return energy
    whole = int(pulse_bins)
    frac = pulse_bins - whole
    out = energy.copy()
    for j in range(1, whole):  # one pass per whole tap of the pulse
        out[j:] += energy[:-j]
    if frac > 0.0:
        out[whole:] += energy.dtype.type(frac) * energy[:-whole]
    out *= energy.dtype.type(1.0 / pulse_bins)
    return out


def running_sum(rows: F64) -> F64:
    """Cumulative sum down the rows of a C-contiguous ``(lines, beams)`` array, in place: one vector add per
    line (numpy's ``cumsum(axis=0)`` walks it column by column, three times slower at 4096 x 512)."""
    for i in range(1, rows.shape[0]):
        np.add(rows[i - 1], rows[i], out=rows[i])
    return rows


def tapered_pattern(shape: str, width: float, phi: F64, extent: float) -> F64:
    """:func:`vertical_pattern` tapered to 0 over the outer 30 % of the sampled half extent (no step
    where the integration stops)."""
    v = np.abs(np.asarray(phi, float)) / (extent / 2.0)
    taper = np.cos(np.clip((v - 0.7) / 0.3, 0.0, 1.0) * (math.pi / 2.0)) ** 2
    return vertical_pattern(shape, width, phi) * taper


class AcousticImager:
    """Builds a frame's image from its sample hits under one realistic :class:`Acoustics`."""

    def __init__(self, params: Acoustics, geometry: RayFan, seed: int) -> None:
        self.p, self.g = params, geometry
        g = geometry
        width = math.radians(params.vertical_width_deg)
        dphi = g.spread / (g.k - 1)
        pattern = tapered_pattern(params.vertical_pattern, width, g.elevation, g.spread)
        self.weight = np.repeat(pattern * dphi, g.n_beams)
        self.mu = 10.0 ** (params.seabed_backscatter_db / 10.0)
        self.object_scale = 10.0 ** (params.object_backscatter_db / 10.0)
        self.specular = 10.0 ** (params.object_specular_db / 10.0)
        self.spec_w = math.radians(params.specular_width_deg)
        self.r_mid = g.window_start + g.n_bins * g.bin_width / 2.0
        r = g.range_of_bin
        tvg_gain_db = 30.0 * np.log10(r / self.r_mid) + 2.0 * params.absorption_db_per_m * (r - self.r_mid)
        self.noise = np.asarray(10.0 ** ((params.noise_floor_db + tvg_gain_db) / 10.0), np.float32)
        draw = np.random.default_rng(np.random.SeedSequence([seed, ACOUSTIC_STREAM]))
        self.gain_db = params.gain_db + params.gain_jitter_db * (2.0 * draw.random() - 1.0)
        self.table = speckle_table(params.speckle_looks, params.texture_shape)
        self.mixer = AzimuthMixer(g.n_beams, params.azimuth_width_beams, params.sidelobe_db)
        self.multipath = 0.0 if params.multipath_db <= MULTIPATH_OFF_DB else 10.0 ** (params.multipath_db / 10.0)

    def sample_energy(self, rng_: F64, cos2: F64, diffuse: F64, is_object: NDArray[np.bool_]) -> F64:
        """Energy of every sample (step 1): ranges (m), cos^2 of incidence, diffuse strength (linear)."""
        cos_a = np.sqrt(np.clip(cos2, 0.0, 1.0))
        sigma = diffuse * cos2
        if is_object.any():
            alpha = np.arccos(cos_a[is_object])
            sigma[is_object] += self.specular * diffuse[is_object] * np.exp(-math.log(2.0) * (alpha / self.spec_w) ** 2)
        with np.errstate(invalid="ignore"):
            e = sigma * self.weight * rng_ / (np.maximum(cos_a, MIN_COS) * self.g.bin_width)
            if self.p.tvg_error_db_per_m:
                # ranges clipped to the window: a sample beyond it lands in no bin, and its far range
                # (a ray grazing a distant seabed) would overflow the exponent
                window_end = self.g.window_start + self.g.n_bins * self.g.bin_width
                r_in = np.clip(rng_, self.g.window_start, window_end)
                e *= 10.0 ** (self.p.tvg_error_db_per_m * (r_in - self.r_mid) / 10.0)
        return np.where(np.isfinite(rng_), e, 0.0)

    def integrate(self, rng_: F64, energy: F64, surface: NDArray[np.int32]) -> F64:
        """Bin energies (n_bins, n_beams), range-major like the image, from the samples (step 2); ``surface``
        -1 the seabed, else the object's index."""
        first, band = self.lit_band(rng_, energy, surface)
        out = np.zeros((self.g.n_bins, self.g.n_beams))
        out[first:first + band.shape[0]] = band
        return out

    def lit_band(self, rng_: F64, energy: F64, surface: NDArray[np.int32]) -> tuple[int, F64]:
        """:meth:`integrate` on the range lines that can hold energy alone: the first such line and the band
        ``(lines, n_beams)`` from it to the last (every other line is 0)."""
        g = self.g
        nb, nk, n = g.n_beams, g.k, g.n_bins
        x = ((rng_ - g.window_start) / g.bin_width).reshape(nk, nb)
        e = energy.reshape(nk, nb)
        s = surface.reshape(nk, nb)
        with np.errstate(invalid="ignore"):
            span = np.abs(x[1:] - x[:-1])  # inf or nan where a sample misses
            joined = (s[:-1] == s[1:]) & np.isfinite(span) & (span > MIN_SPAN_BINS) & (
                (s[:-1] < 0) | (span * g.bin_width < OBJECT_GAP_M))
        single = np.full((nk, nb), 2.0)  # a sample's halves not in a segment stay in its own bin
        single[1:] -= joined
        single[:-1] -= joined
        own = 0.5 * e * single
        slope = np.where(joined, 0.5 * (e[:-1] + e[1:]) / np.where(joined, span, 1.0), 0.0)
        # a segment of level ``slope`` over [a, b) bins: bin m holds slope * (overlap of [m, m + 1) and [a, b));
        # bin m = S1(m) - sum over breakpoints c in bin m of w frac(c), S1 the running sum of the slope changes
        # w (+slope at a, -slope at b) up to bin m: a running sum over the band and sparse corrections
        seg = np.concatenate([joined, joined]).ravel()
        c = np.concatenate([np.fmin(x[:-1], x[1:]), np.fmax(x[:-1], x[1:])]).ravel()[seg]
        c = np.clip(c, 0.0, n)
        w = np.concatenate([slope, -slope]).ravel()[seg]
        row = np.floor(c).astype(np.int64)
        beam = np.broadcast_to(np.arange(nb), (2 * (nk - 1), nb)).ravel()[seg]
        inside = (np.isfinite(x) & (x >= 0.0) & (x < n) & (own != 0.0)).ravel()
        pts_row = np.floor(x.ravel()[inside]).astype(np.int64)
        rows = np.concatenate([row, pts_row])
        if rows.size == 0:
            return 0, np.zeros((0, nb))
        lo, hi = int(rows.min()), int(rows.max()) + 1  # hi may be n + 1: a segment's end clipped to the window's
        cell = (row - lo) * nb + beam
        size = (hi - lo) * nb
        v = running_sum(np.bincount(cell, weights=w, minlength=size).astype(float, copy=False).reshape(hi - lo, nb))
        pts = (pts_row - lo) * nb + np.broadcast_to(np.arange(nb), (nk, nb)).ravel()[inside]
        fix = np.concatenate([-w * (c - row), own.ravel()[inside]])
        v += np.bincount(np.concatenate([cell, pts]), weights=fix, minlength=size).reshape(hi - lo, nb)
        v = v[: min(hi, n) - lo]
        return lo, np.maximum(v, 0.0, out=v)

    def ghosts(self, rng_: F64, energy: F64, surface_range: F64) -> tuple[F64, F64] | None:
        """The samples' surface ghosts (step 2): their ranges (inf past the window) and energies, from the
        samples' ranges and energies and their paths ``surface_range`` (m) from the sonar's image above the
        surface; None without multipath or when no ghost falls inside the window."""
        if self.multipath == 0.0:
            return None
        with np.errstate(invalid="ignore", divide="ignore"):
            r_g = 0.5 * (rng_ + surface_range)
            inside = np.isfinite(r_g) & (r_g < self.g.window_end) & (energy > 0.0)
            if not inside.any():
                return None
            gain = self.multipath * (rng_ / surface_range) ** 2 * (r_g / rng_) ** 3
            e_g = np.where(inside, energy * gain, 0.0)
        return np.where(inside, r_g, np.inf), e_g

    def expected(self, rng_: F64, cos2: F64, diffuse: F64, surface: NDArray[np.int32],
                 surface_range: F64 | None = None) -> F32:
        """Expected bin energy (steps 1-3) before speckle, noise and gain; range-major (n_bins, n_beams),
        float32 after the integral (ample for an 8-bit log image). ``surface_range``: each sample's path (m) from
        the sonar's image above the sea surface (its multipath ghosts; None: none). The pulse and the beam
        mixing run on the lit band of range lines alone (:meth:`lit_band`; the others stay 0)."""
        e = self.sample_energy(rng_, cos2, diffuse, surface >= 0)
        bands = [self.lit_band(rng_, e, surface)]
        ghost = None if surface_range is None else self.ghosts(rng_, e, surface_range)
        if ghost is not None:
            bands.append(self.lit_band(ghost[0], ghost[1], surface))
        bands = [(lo, band) for lo, band in bands if band.shape[0]]
        img = np.zeros((self.g.n_bins, self.g.n_beams), np.float32)
        if not bands:
            return img
        for lo, band in bands:
            img[lo:lo + band.shape[0]] += band
        lo = min(b[0] for b in bands)
        end = max(b[0] + b[1].shape[0] for b in bands)
        pulse_bins = self.p.pulse_m / self.g.bin_width
        hi = min(self.g.n_bins, end + 1 + int(pulse_bins))
        img[lo:hi] = self.mixer(spread_in_range(img[lo:hi], pulse_bins))
        return img

    def display(self, energy: F32 | F64, rng: np.random.Generator | None) -> U8:
        """Speckle, noise, interference and gain (step 4) of range-major energies: the 8-bit log display,
        the image ``[range bin, beam]``."""
        p = self.p
        energy32 = energy.astype(np.float32, copy=False)
        if rng is None:
            power = energy32 + self.noise[:, None]
        else:
            size = energy.size
            raw = rng.bit_generator.random_raw((size + 1) // 2).astype("<u8", copy=False).view("<u2")
            power = self.noise[:, None] * np.take(EXP_TABLE, raw[size:2 * size]).reshape(energy.shape)
            lit = np.flatnonzero(energy32.any(axis=1))  # speckle multiplies 0 elsewhere: look up lit lines only
            if lit.size:
                a, b = int(lit[0]), int(lit[-1]) + 1
                speckle = np.take(self.table, raw[a * energy.shape[1]:b * energy.shape[1]]).reshape(b - a, -1)
                power[a:b] += energy32[a:b] * speckle
            hit, row, width = rng.random(), rng.integers(self.g.n_bins), rng.integers(1, MAX_BAND_BINS + 1)
            level = 10.0 ** (p.interference_db / 10.0) * (0.5 + rng.random(self.g.n_beams, np.float32))
            if hit < p.interference_fraction:
                power[row:row + width] += level
        scale = np.float32(10.0 * 256.0 / p.display_range_db)
        with np.errstate(divide="ignore"):
            q = np.log10(power, out=power)
        q += np.float32((self.gain_db - p.display_floor_db) / 10.0)
        q *= scale
        return np.clip(q, 0.0, 255.0, out=q).astype(np.uint8)
