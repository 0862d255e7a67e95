"""Recon with calibration finds no returns before it has measured the seabed's level (recon.beam_edge): frames of
the surface phase or the dive, with no seabed in the range window, give no points, however faint their speckle."""

from __future__ import annotations

import numpy as np

from recon.reconstructor import ReconConfig, Reconstructor
from recon.sonar_geometry import SonarGeometry
from recon.trajectory import Trajectory


def _survey(altitude: float, n: int) -> tuple[SonarGeometry, Trajectory, np.ndarray]:
    """A vehicle 0.5 m under the surface moving north at 1.5 m/s, ``altitude`` m above a level seabed, 10 frames/s."""
    t = np.arange(n) * 0.1
    pos = np.column_stack([1.5 * t, np.zeros(n), np.full(n, 0.5)])
    zeros = np.zeros(n)
    traj = Trajectory.from_euler(t, pos, zeros, zeros, zeros, altitude=np.full(n, altitude))
    return SonarGeometry.from_degrees(30.0, 14.0), traj, t


def _floor_speckle(geometry: SonarGeometry, n: int, rng: np.random.Generator) -> np.ndarray:
    """Water at a log display's floor: 97 % of the pixels at 0, the rest 5-25 grey levels (a realistic profile's
    water column far from the seabed)."""
    img = np.zeros((n, geometry.n_bins, geometry.n_beams), np.uint8)
    lit = rng.random(img.shape) < 0.03
    img[lit] = rng.integers(5, 26, int(lit.sum()))
    return img


def test_no_returns_while_no_seabed_is_in_the_window() -> None:
    n = 64
    geometry, traj, t = _survey(30.0, n)  # the fan reaches ~11 m: no seabed anywhere in it
    img = _floor_speckle(geometry, n, np.random.default_rng(3))
    uncalibrated = Reconstructor(geometry, traj, ReconConfig(calibrate=False))
    assert uncalibrated.add_frames(t, img) > 0  # the frame's water statistics alone: speckle at the floor passes
    rec = Reconstructor(geometry, traj)
    assert rec.add_frames(t, img) == 0
    assert np.isnan(rec.beam_edge.level)


def test_returns_once_the_seabed_has_shown() -> None:
    n = 64
    geometry, traj, t = _survey(5.0, n)
    pos, rot = traj.pose_at(t)
    onset = geometry.flat_onset_ranges(pos, rot, np.full(n, 5.0))
    rng = np.random.default_rng(4)
    img = _floor_speckle(geometry, n, rng)
    seabed = geometry.ranges[None, :, None] >= onset[:, None, :]
    img[seabed] = rng.integers(120, 160, int(seabed.sum()))
    row = int(np.round(geometry.range_to_row(float(onset[0, 48]) - 0.6)))
    img[:, row:row + 4, 45:52] = 200  # an object's echo 0.6 m before the onset in the central beams
    rec = Reconstructor(geometry, traj)
    assert rec.add_frames(t, img) > 0
    assert np.isfinite(rec.beam_edge.level)
