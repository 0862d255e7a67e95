"""Recon with calibration close to the seabed: when fewer than ``MIN_STAT_ROWS`` rows of water lie before the
widest seabed search, the frame's own statistics would come from the whole image (the seabed band included, a
threshold above the seabed's own level); the highlight search then keeps to the background before the onsets and
the seabed's onset level (recon.onset_stage), so an object's echo before the onset still gives returns."""

from __future__ import annotations

import numpy as np

from recon.highlight import MIN_STAT_ROWS, HighlightConfig, frame_thresholds, onset_rows
from recon.reconstructor import Reconstructor
from recon.seabed_band import SEABED_BAND
from recon.sonar_geometry import SonarGeometry
from recon.trajectory import Trajectory

ALTITUDE_M = 2.1  # the fan's nominal edge (37 deg) meets a level seabed at ~3.5 m, the window starts at 1 m


def _close_survey(n: int, seed: int, early_m: float = 0.0
                  ) -> tuple[SonarGeometry, Trajectory, np.ndarray, np.ndarray, tuple[int, int]]:
    """A vehicle :data:`ALTITUDE_M` above a level seabed moving north at 1.5 m/s, 10 frames/s: speckle at the
    display floor, a bright continuous seabed band (150-200 grey levels) from the onset on, and an object's echo
    (230) 0.6 m before the onset in the central beams; the images, and the echo's first row and beam. The band
    starts ``early_m`` m of range before the nominal edge's onset (a beam with energy beyond its nominal edge)."""
    t = np.arange(n) * 0.1
    pos = np.column_stack([1.5 * t, np.zeros(n), np.full(n, 5.0)])
    zeros = np.zeros(n)
    traj = Trajectory.from_euler(t, pos, zeros, zeros, zeros, altitude=np.full(n, ALTITUDE_M))
    geometry = SonarGeometry.from_degrees(30.0, 14.0)
    onset = geometry.flat_onset_ranges(*traj.pose_at(t), np.full(n, ALTITUDE_M))
    rng = np.random.default_rng(seed)
    img = np.zeros((n, geometry.n_bins, geometry.n_beams), np.uint8)
    lit = rng.random(img.shape) < 0.03
    img[lit] = rng.integers(5, 26, int(lit.sum()))
    seabed = geometry.ranges[None, :, None] >= onset[:, None, :] - early_m
    img[seabed] = rng.integers(150, 201, int(seabed.sum()))
    row = int(np.round(geometry.range_to_row(float(onset[0, 48]) - 0.6)))
    img[:, row:row + 4, 45:52] = 230
    return geometry, traj, t, img, (row, 48)


def test_the_frame_statistics_would_read_the_seabed() -> None:
    """The premise: too few water rows before the widest search, and the whole image's threshold above the echo."""
    geometry, traj, t, img, _ = _close_survey(16, 5)
    onset = geometry.flat_onset_ranges(*traj.pose_at(t), np.full(t.size, ALTITUDE_M))
    lead = HighlightConfig().margin_m + max(SEABED_BAND.lead_m, SEABED_BAND.lead_flat_m)
    water = int(onset_rows(geometry, onset, lead).min())
    assert water < MIN_STAT_ROWS
    assert np.all(frame_thresholds(img, water, HighlightConfig()) >= 230)


def test_an_echo_before_the_onset_gives_returns_close_to_the_seabed() -> None:
    geometry, traj, t, img, (row, beam) = _close_survey(64, 6)
    rec = Reconstructor(geometry, traj)
    assert rec.add_frames(t[:32], img[:32]) >= 0  # the seabed's level is measured in these frames
    assert np.isfinite(rec.beam_edge.level)
    assert rec.add_frames(t[32:], img[32:]) > 0
    _, bi, ri = rec.last_returns
    on_echo = (np.abs(bi - beam) <= 3) & (np.abs(ri - row) <= 2)
    assert on_echo.sum() >= 32 * 5  # the echo's beams in every frame


def test_the_front_slope_arcs_span_the_effective_fan() -> None:
    """Points placed on the effective edge (wider than the nominal one) are moved along arcs spanning that same
    fan (recon.front_slope), not clipped to the nominal spread, which would lift them above the object's top."""
    geometry, traj, t, img, _ = _close_survey(48, 7, early_m=0.5)
    rec = Reconstructor(geometry, traj)
    rec.add_frames(t, img)
    assert rec.geometry.spread > geometry.spread
    assert rec._objects.spread == rec.geometry.spread
