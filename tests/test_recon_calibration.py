"""Recon calibrating itself from the frames: the fan's effective lower edge (recon.beam_edge) and the background
thresholds (recon.water_threshold, recon.highlight.row_thresholds)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from recon.beam_edge import MIN_FRAMES, BeamEdge, frame_edges
from recon.highlight import row_thresholds
from recon.sonar_geometry import SonarGeometry
from recon.water_threshold import PFA, WaterThreshold, histogram_thresholds, speckle_upper, water_histogram


def _seabed_frames(geometry: SonarGeometry, alt: float, pitch_deg: float, n: int, rng: np.random.Generator,
                   gain: float = 0.0) -> tuple[np.ndarray, np.ndarray, Rotation, np.ndarray]:
    """Frames of a level seabed ``alt`` m under the vehicle that shows from the edge of ``geometry``'s fan on
    (water ~ 10 grey levels, seabed ~ 110, both + ``gain``), with their poses and altitudes."""
    pos = np.zeros((n, 3))
    rot = Rotation.from_euler("ZYX", np.tile([0.0, np.radians(pitch_deg), 0.0], (n, 1)))
    alts = np.full(n, alt)
    onset = geometry.flat_onset_ranges(pos, rot, alts)  # (n, beams)
    seabed = geometry.ranges[None, :, None] >= onset[:, None, :]
    img = np.where(seabed, 110.0, 10.0) + gain + rng.normal(0.0, 6.0, (n, geometry.n_bins, geometry.n_beams))
    return np.clip(img, 0, 255).astype(np.uint8), pos, rot, alts


def _flat(pos: np.ndarray, alts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The flat seabed ``alts`` m under each position: points and normals into the water (NED: up)."""
    q = pos + np.outer(alts, [0.0, 0.0, 1.0])
    return q, np.tile([0.0, 0.0, -1.0], (len(pos), 1))


@pytest.mark.parametrize(("half_deg", "alt", "pitch_deg", "gain"), [(7.0, 5.0, 0.0, 0.0), (12.0, 4.0, 3.0, 40.0),
                                                                     (16.0, 6.0, -2.0, -5.0)])
def test_frame_edges_recover_the_edge_the_seabed_shows(half_deg: float, alt: float, pitch_deg: float,
                                                       gain: float) -> None:
    nominal = SonarGeometry.from_degrees(30.0, 14.0)
    truth = replace(nominal, spread=np.radians(2.0 * half_deg))
    imgs, pos, rot, alts = _seabed_frames(truth, alt, pitch_deg, 5, np.random.default_rng(3), gain)
    edges = np.degrees(frame_edges(imgs, nominal, pos, rot, *_flat(pos, alts))[0])
    # one range bin (0.02 m) at ~7 m moves the elevation by ~0.2 deg; the quarter-metre average is trailing
    assert np.all(np.abs(edges - half_deg) < 0.5), edges


@pytest.mark.parametrize(("half_deg", "alt", "noise_db", "absorption_db_per_m"),
                         [(7.0, 5.5, -3.0, 0.9), (7.0, 6.5, -6.0, 0.9), (10.0, 4.0, -14.0, 2.6)])
def test_frame_edges_not_fooled_by_the_water_noise_climbing_under_the_gain(half_deg: float, alt: float,
                                                                          noise_db: float,
                                                                          absorption_db_per_m: float) -> None:
    """The water's noise, under the display's floor where no seabed can return and lifted along range by the
    time-varied gain (spherical spreading and the absorption of 1.8 and 3 MHz: DIDSON, ARIS 3000), climbs through
    half the water-to-seabed step before a hard-edged seabed shows: the edge is the seabed's steep onset, not where
    the noise crosses that level."""
    nominal = SonarGeometry.from_degrees(22.0, 14.0, window_start=0.75 * alt, window_length=2.0 * alt)
    truth = replace(nominal, spread=np.radians(2.0 * half_deg))
    rng = np.random.default_rng(7)
    n = 6
    pos = np.zeros((n, 3))
    rot = Rotation.identity(n)
    alts = np.full(n, alt)
    onset = truth.flat_onset_ranges(pos, rot, alts)
    r = nominal.ranges[None, :, None]
    lpd = 255.0 / 60.0  # grey levels per dB of a 60 dB display
    # exponential speckle of the noise's power, its mean noise_db under the floor at the sonar's height
    noise = lpd * (noise_db + 30.0 * np.log10(r / alt) + 2.0 * absorption_db_per_m * (r - alt)
                   + 10.0 * np.log10(rng.exponential(1.0, (n, nominal.n_bins, nominal.n_beams))))
    seabed = 100.0 + lpd * 10.0 * np.log10(rng.exponential(1.0, noise.shape))
    img = np.where(r >= onset[:, None, :], np.maximum(seabed, noise), noise)
    imgs = np.clip(img, 0, 255).astype(np.uint8)
    profile = np.median(imgs[:, :, 40:56], axis=(0, 2))
    half = 0.5 * np.median(imgs[:, nominal.ranges > onset.max() + 0.5, 40:56])
    assert (profile[nominal.ranges < onset.min() - 0.3] >= 0.5 * half).any()  # the noise reaches a quarter step
    edges = np.degrees(frame_edges(imgs, nominal, pos, rot, *_flat(pos, alts))[0])
    assert np.all((edges > half_deg - 1.5) & (edges < half_deg + 0.6)), edges  # inside it: the nominal edge holds


def test_frame_edges_a_vertical_sidelobe_band_that_lights_the_seabed_first_is_its_onset() -> None:
    """Under a sinc^2 vertical pattern the seabed shows first in a band of the first sidelobe, then a null, then the
    main lobe: the band steps as the main lobe does, the water is dark, and the edge is the band's."""
    nominal = SonarGeometry.from_degrees(30.0, 14.0)
    band = replace(nominal, spread=np.radians(2.0 * 20.0))
    null = replace(nominal, spread=np.radians(2.0 * 15.0))
    main = replace(nominal, spread=np.radians(2.0 * 10.0))
    rng = np.random.default_rng(11)
    n = 6
    pos, rot, alts = np.zeros((n, 3)), Rotation.identity(n), np.full(n, 4.0)
    r = nominal.ranges[None, :, None]
    level = np.where(r >= main.flat_onset_ranges(pos, rot, alts)[:, None, :], 120.0,
                     np.where(r >= null.flat_onset_ranges(pos, rot, alts)[:, None, :], 40.0,
                              np.where(r >= band.flat_onset_ranges(pos, rot, alts)[:, None, :], 80.0, 0.0)))
    img = level + np.where(level > 0, rng.normal(0.0, 8.0, level.shape), 0.0)
    imgs = np.clip(img, 0, 255).astype(np.uint8)
    edges = np.degrees(frame_edges(imgs, nominal, pos, rot, *_flat(pos, alts))[0])
    assert np.all(np.abs(edges - 20.0) < 1.0), edges


def test_frame_edges_none_without_seabed_or_altitude() -> None:
    g = SonarGeometry.from_degrees(30.0, 14.0)
    rng = np.random.default_rng(4)
    water = np.clip(rng.normal(10.0, 6.0, (2, g.n_bins, g.n_beams)), 0, 255).astype(np.uint8)
    pos, rot = np.zeros((2, 3)), Rotation.identity(2)
    assert np.isnan(frame_edges(water, g, pos, rot, *_flat(pos, np.array([5.0, 5.0])))).all()
    imgs, pos, rot, _ = _seabed_frames(g, 5.0, 0.0, 2, rng)
    assert np.isnan(frame_edges(imgs, g, pos, rot, *_flat(pos, np.array([np.nan, np.nan])))).all()


def test_beam_edge_nominal_until_enough_frames_then_follows_the_data() -> None:
    edge = BeamEdge(np.radians(7.0), window=20, min_frames=MIN_FRAMES)
    tilt = np.radians(30.0)
    assert edge.update(np.full(MIN_FRAMES - 1, np.radians(15.0)), tilt) == pytest.approx(np.radians(7.0))
    assert edge.update(np.array([np.radians(15.0), np.nan]), tilt) == pytest.approx(np.radians(15.0))
    # outliers (an object in the fan, a steep dive) are outvoted; a lasting change takes over within the window
    edge.update(np.array([np.radians(40.0)] * 3), tilt)
    assert edge.half == pytest.approx(np.radians(15.0))
    edge.update(np.full(20, np.radians(11.0)), tilt)
    assert edge.half == pytest.approx(np.radians(11.0))


def _log_speckle(rng: np.random.Generator, shape: tuple[int, ...], level: float) -> tuple[np.ndarray, float]:
    """Grey levels of fully developed speckle on a 60 dB log display (exponential intensity, the mean intensity at
    ``level``, floored at 0 like a display) and the display's grey levels per neper (255 / 60 dB: 18.5)."""
    c = 255.0 / 60.0 * 10.0 / np.log(10.0)
    return np.clip(level + c * np.log(rng.exponential(1.0, shape)), 0, 255), c


def test_water_threshold_holds_its_false_alarm_rate_with_objects_in_the_water() -> None:
    rng = np.random.default_rng(5)
    n, bins, beams = 50, 128, 96
    imgs, c = _log_speckle(rng, (n, bins, beams), 40.0)
    for k in range(n):  # an object passing through the water column: 20 beams of 3 rows, nearer each frame
        imgs[k, 120 - 2 * k : 123 - 2 * k, 40:60] = 180.0
    limits = np.full((n, beams), bins)
    thr = histogram_thresholds(water_histogram(imgs.astype(np.uint8), limits))
    exact = 40.0 + c * np.log(-np.log(PFA))  # the 1 - PFA quantile of the speckle's grey levels (81)
    assert np.all(np.abs(thr - exact) < 6.0), (thr.min(), thr.max(), exact)
    fresh, _ = _log_speckle(rng, (n, bins, beams), 40.0)  # background the threshold was not measured on
    rate = float((fresh.astype(np.uint8) > np.floor(thr)[None, :, None]).mean())
    assert PFA / 3 < rate < 3 * PFA, rate


def test_water_threshold_follows_the_gain_and_forgets_over_its_window() -> None:
    rng = np.random.default_rng(6)
    base = rng.normal(40.0, 8.0, (30, 64, 96))
    limits = np.full((30, 96), 64)
    lo = WaterThreshold(64, window=3).update(np.clip(base, 0, 255).astype(np.uint8), limits)
    wt = WaterThreshold(64, window=3)
    wt.update(np.clip(base, 0, 255).astype(np.uint8), limits)
    hi = wt.update(np.clip(base + 30.0, 0, 255).astype(np.uint8), limits)  # gain up by 30 grey levels
    assert np.median(hi - lo) == pytest.approx(30.0, abs=2.0)  # the first frames forgotten (e^-10)


def test_row_thresholds_rise_over_a_band_across_the_fan() -> None:
    rng = np.random.default_rng(7)
    img = np.clip(rng.normal(20.0, 5.0, (1, 64, 96)), 0, 255)
    img[0, 30:33] = 150.0  # interference: bright across the whole fan
    img[0, 50, 40:44] = 150.0  # an object in four beams
    thr = row_thresholds(img.astype(np.uint8), np.array([30.0]))[0]
    assert np.all(thr[30:33] > 150.0)
    assert thr[50] < 150.0 and thr[10] == pytest.approx(30.0, abs=25.0)


def test_row_rule_is_speckles_false_alarm_level() -> None:
    rng = np.random.default_rng(8)
    grey, _ = _log_speckle(rng, (2_000_000,), 120.0)  # a bright row: well clear of the display's floor
    med = float(np.median(grey))
    mad = float(np.median(np.abs(grey - med)))
    level = float(speckle_upper(np.array(med), np.array(mad)))
    fresh, _ = _log_speckle(rng, (2_000_000,), 120.0)
    assert PFA / 2 < float((fresh > level).mean()) < 2 * PFA
    assert level < med + 4.0 * 1.4826 * mad - 30.0  # a Gaussian's 4 robust sigmas: 36 levels higher


def test_water_histogram_counts_the_pixels_before_each_limit() -> None:
    """Every (row, grey level) pair of the pixels before their beam's limit, whatever the limits (negative, zero,
    past the image, alike or spread over the rows)."""
    rng = np.random.default_rng(11)
    for lo_lim, hi_lim in ((-3, 0), (0, 41), (12, 13), (-5, 60), (40, 41)):
        imgs = rng.integers(0, 256, (4, 40, 9)).astype(np.uint8)
        limits = rng.integers(lo_lim, hi_lim, (4, 9))
        rows = np.arange(40)[None, :, None]
        keys = (rows * 256 + imgs)[rows < limits[:, None, :]]
        ref = np.bincount(keys, minlength=40 * 256).reshape(40, 256)
        np.testing.assert_array_equal(water_histogram(imgs, limits), ref)
