"""Recon's self-calibration on images unlike the ideal simulator's: the sidelobe rule (recon.sidelobe), the
effective edge on a ray comb and under a time-varied gain's noise ramp (recon.beam_edge), no fixed grey level."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from recon.beam_edge import MIN_FRAMES, BeamEdge, frame_edges
from recon.highlight import HighlightConfig, first_returns
from recon.sidelobe import margin_levels, sidelobe_thresholds
from recon.sonar_geometry import SonarGeometry


def test_a_sidelobe_arc_is_no_return_but_a_faint_echo_of_its_own_is() -> None:
    img = np.zeros((1, 512, 96), np.uint8)
    margin = margin_levels(-25.0, 60.0)  # 106 grey levels
    img[0, 200:204, 40] = 220  # a strong return ...
    img[0, 200:205, :] = np.maximum(img[0, 200:205, :], int(220 - margin - 5))  # ... its sidelobe arc across the fan
    img[0, 150:153, 10] = 90  # a faint echo at a range with nothing stronger
    limits = np.full((1, 96), 400)
    cfg = HighlightConfig()
    low = np.full((1, 512), 20.0)  # a water threshold below the arc
    _, bi, _ = first_returns(img, limits, low, cfg)
    assert len(bi) == 96  # without the rule every beam returns (the arc, or the echo in beam 10)
    _, bi, ri = first_returns(img, limits, sidelobe_thresholds(low, img, 400, margin), cfg)
    assert sorted(zip(bi.tolist(), ri.tolist(), strict=True)) == [(10, 150), (40, 200)]


def test_margin_follows_the_sidelobe_level_and_the_display() -> None:
    assert margin_levels(-30.0, 60.0) == pytest.approx(127.5)
    assert margin_levels(-30.0, 80.0) == pytest.approx(255.0 * 30.0 / 80.0)


def _frames(geometry: SonarGeometry, alt: float, n: int, rng: np.random.Generator, comb: int = 0,
            tvg_ramp: float = 0.0) -> tuple[np.ndarray, np.ndarray, Rotation, np.ndarray, np.ndarray]:
    """Frames of a level seabed ``alt`` m under the vehicle that shows from ``geometry``'s edge on: speckle water
    (~50 +- 10 grey levels, rising ``tvg_ramp`` levels per row), seabed bright (every ``comb``-th row only: the
    ray comb of a renderer sampling the fan with few rays); poses, the flat plane's points and normals."""
    pos = np.zeros((n, 3))
    rot = Rotation.identity(n)
    onset = geometry.flat_onset_ranges(pos, rot, np.full(n, alt))
    rows = np.arange(geometry.n_bins)[None, :, None]
    seabed = geometry.ranges[None, :, None] >= onset[:, None, :]
    if comb:
        first = np.argmax(seabed, axis=1)[:, None, :]  # each column's first seabed row
        seabed &= (rows - first) % comb == 0
    water = 50.0 + tvg_ramp * rows + rng.normal(0.0, 10.0, (n, geometry.n_bins, geometry.n_beams))
    img = np.clip(np.where(seabed, 150.0 + tvg_ramp * rows, water), 0, 255).astype(np.uint8)
    return img, pos, rot, pos + np.outer(np.full(n, alt), [0.0, 0.0, 1.0]), np.tile([0.0, 0.0, -1.0], (n, 1))


@pytest.mark.parametrize(("comb", "tvg_ramp"), [(9, 0.0), (0, 0.15), (5, 0.1)])
def test_edge_of_a_ray_comb_and_under_a_noise_ramp(comb: int, tvg_ramp: float) -> None:
    nominal = SonarGeometry.from_degrees(30.0, 14.0)
    truth = replace(nominal, spread=np.radians(2.0 * 9.0))
    imgs, pos, rot, q, nrm = _frames(truth, 5.0, 6, np.random.default_rng(7), comb, tvg_ramp)
    edges, levels = frame_edges(imgs, nominal, pos, rot, q, nrm)
    # one range bin (0.02 m) at ~7 m moves the elevation by ~0.2 deg
    assert np.all(np.abs(np.degrees(edges) - 9.0) < 0.5), np.degrees(edges)
    assert np.all((levels > 50.0) & (levels < 150.0 + tvg_ramp * 512))  # between the water and the seabed


def test_edge_never_inside_the_nominal_spread() -> None:
    edge = BeamEdge(np.radians(7.0))
    edge.update(np.full(MIN_FRAMES, np.radians(6.6)), np.radians(30.0), np.full(MIN_FRAMES, 80.0))
    assert edge.half == pytest.approx(np.radians(7.0))  # a hard edge's range quantization
    assert edge.level == pytest.approx(80.0)
    edge.update(np.full(MIN_FRAMES, np.radians(12.0)), np.radians(30.0))
    assert edge.half == pytest.approx(np.radians(9.3))  # the running median of 20 edges


@pytest.mark.parametrize("gain", [-30, 40])
def test_edge_and_level_follow_a_gain_offset(gain: int) -> None:
    """A gain offset (dB on a log display: grey levels added to every pixel) moves the onset's level by as much
    and leaves the edge where it was."""
    nominal = SonarGeometry.from_degrees(30.0, 14.0)
    truth = replace(nominal, spread=np.radians(2.0 * 10.0))
    imgs, pos, rot, q, nrm = _frames(truth, 5.0, 4, np.random.default_rng(8), 0, 0.05)
    e0, l0 = frame_edges(imgs, nominal, pos, rot, q, nrm)
    shifted = np.clip(imgs.astype(int) + gain, 0, 255).astype(np.uint8)
    e1, l1 = frame_edges(shifted, nominal, pos, rot, q, nrm)
    assert np.allclose(np.degrees(e1), np.degrees(e0), atol=0.3)
    assert np.allclose(l1 - l0, gain, atol=3.0)
