"""recon.image_pooling: frames finer than recon's sampling pooled to it; DIDSON and ARIS frames untouched."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.sonar import Sonar, describe
from recon.image_pooling import BEAM_SPACING, MAX_RANGE_ROWS, ImagePooling
from recon.sonar_geometry import SonarGeometry


def _geometry(model: str, mode: str = "high") -> SonarGeometry:
    d = describe(model, mode)
    sonar = Sonar(tilt_deg=30.0, spread_deg=d.vertical_aperture_deg, window_start=1.0, window_length=10.0,
                  model=model, frequency_mode=mode)
    return SonarGeometry.of(sonar)


@pytest.mark.parametrize("model", ["didson", "aris1800", "aris3000"])
@pytest.mark.parametrize("mode", ["high", "low"])
def test_fixed_sample_sonars_are_not_pooled(model: str, mode: str) -> None:
    g = _geometry(model, mode)
    pool = ImagePooling.for_geometry(g)
    frames = np.random.default_rng(0).integers(0, 256, (2, g.n_bins, g.n_beams), dtype=np.uint8)
    assert pool.identity and pool.geometry(g) is g and pool.apply(frames) is frames


@pytest.mark.parametrize("model", ["oculus-m750d", "oculus-m1200d"])
@pytest.mark.parametrize("mode", ["high", "low"])
def test_oculus_frames_pooled_to_recons_sampling(model: str, mode: str) -> None:
    g = _geometry(model, mode)
    pool = ImagePooling.for_geometry(g)
    pg = pool.geometry(g)
    assert pg.n_bins <= MAX_RANGE_ROWS < g.n_bins and pg.n_beams == math.ceil(g.n_beams / pool.beams)
    spacing = np.diff(g.azimuths)
    assert pool.beams * np.median(spacing) <= BEAM_SPACING < (pool.beams + 1) * np.median(spacing)  # the DIDSON's
    assert pg.bin_size == pytest.approx(g.bin_size * pool.rows)  # the same range scale, coarser
    assert pg.window_start == g.window_start and pg.window_length >= g.window_length
    assert pg.azimuths[0] < 0 < pg.azimuths[-1] and np.all(np.diff(pg.azimuths) > 0)
    assert abs(pg.azimuths[0] - g.azimuths[0]) < pool.beams * spacing.max()


def test_a_pooled_pixel_is_the_maximum_of_its_group_and_the_first_return_keeps_its_range() -> None:
    g = SonarGeometry.from_degrees(30.0, 12.0, n_bins=1000, n_beams=10)
    pool = ImagePooling(rows=8, beams=3)  # 1000 rows -> 125, 10 beams -> 4 (the last group of one beam)
    frames = np.zeros((1, 1000, 10), np.uint8)
    frames[0, 803, 4] = 200  # a return at range row 803 in beam 4
    frames[0, 999, 9] = 7  # the last row and beam: short groups count too
    out = pool.apply(frames)
    assert out.shape == (1, 125, 4) and out.dtype == np.uint8
    assert out[0, 803 // 8, 4 // 3] == 200 and out[0, 124, 3] == 7 and int(out.sum()) == 207
    pg = pool.geometry(g)
    r = g.ranges[803]
    assert abs(pg.ranges[803 // 8] - r) <= 4 * g.bin_size  # within half a pooled row of the original range
    np.testing.assert_allclose(pg.azimuths[:3], [g.azimuths[0:3].mean(), g.azimuths[3:6].mean(),
                                                 g.azimuths[6:9].mean()])
    assert pg.azimuths[3] == pytest.approx(g.azimuths[9])


@settings(max_examples=60, deadline=None)
@given(f=st.integers(1, 3), n_bins=st.integers(1, 40), n_beams=st.integers(1, 12), rows=st.integers(1, 9),
       beams=st.integers(1, 4), seed=st.integers(0, 2**32 - 1))
def test_pooling_equals_the_maximum_over_each_group(f: int, n_bins: int, n_beams: int, rows: int, beams: int,
                                                    seed: int) -> None:
    frames = np.random.default_rng(seed).integers(0, 256, (f, n_bins, n_beams), dtype=np.uint8)
    out = ImagePooling(rows=rows, beams=beams).apply(frames)
    nr, nb = -(-n_bins // rows), -(-n_beams // beams)
    want = np.zeros((f, nr, nb), np.uint8)
    for i in range(nr):
        for j in range(nb):
            want[:, i, j] = frames[:, i * rows:(i + 1) * rows, j * beams:(j + 1) * beams].max(axis=(1, 2))
    assert out.dtype == np.uint8 and out.shape == want.shape
    np.testing.assert_array_equal(out, want)
