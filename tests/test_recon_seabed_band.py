"""Each column's seabed return and the tracked onset (recon.seabed_band), and the seabed they give on a
rendered rough seabed: samples within centimetres of the truth, where the former search (from the expected
onset, two bins) put them 0.1-0.5 m under it; under a soft, wide beam as well."""

from __future__ import annotations

import numpy as np
import pytest
from scenes import scene_toml

from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_band import BandConfig, OnsetTracker, seabed_returns
from recon.sonar_geometry import SonarGeometry

GEOM = SonarGeometry.from_degrees(30.0, 14.0, window_start=1.0, window_length=10.0)
NB = GEOM.n_beams


def _returns(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Onset (F, beams) of 8 m and returns at ``onset + d`` (NaN: none) as (onset, frame, beam, row)."""
    onset = np.full(d.shape, 8.0)
    fi, bi = np.nonzero(np.isfinite(d))
    rows = np.rint(GEOM.range_to_row(onset[fi, bi] + d[fi, bi])).astype(np.int64)
    return onset, fi, bi, rows


def test_tracker_corrects_a_fit_that_is_too_deep() -> None:
    trk = OnsetTracker(NB, BandConfig())
    rng = np.random.default_rng(1)
    d = -0.4 + rng.normal(0, 0.01, (80, NB))  # the seabed 0.4 m of range nearer than the fit says
    onset, fi, bi, ri = _returns(d)
    out = trk.correct(GEOM, onset, fi, bi, ri)
    assert np.allclose(out[-1] - onset[-1], -0.4, atol=0.03)


def test_an_object_filling_the_fan_does_not_move_the_onset() -> None:
    trk = OnsetTracker(NB, BandConfig())
    rng = np.random.default_rng(2)
    d = rng.normal(0, 0.01, (40, NB))
    d[20:26, 10:80] = -0.5  # a pipe across 3/4 of the fan for 6 frames, its shadow late in the rest
    d[20:26, 80:] = np.nan
    onset, fi, bi, ri = _returns(d)
    out = trk.correct(GEOM, onset, fi, bi, ri)
    assert np.abs(out - onset).max() < 0.05


def test_the_onset_is_never_put_much_beyond_the_fit() -> None:
    trk = OnsetTracker(NB, BandConfig())
    d = np.full((60, NB), 0.6)  # returns later than the fit: shadows, or a fit too shallow
    onset, fi, bi, ri = _returns(d)
    out = trk.correct(GEOM, onset, fi, bi, ri)
    assert (out - onset).max() <= BandConfig().max_deeper_m + 1e-9


def test_a_fit_too_shallow_is_corrected_while_the_seabed_is_not_known() -> None:
    # the first metres of a survey down a slope: the fit (level) puts the onset 0.6 m of range too near, and
    # every object lower than that error would be taken for the seabed; the returns move it while the fitted
    # seabed spans little, by at most band_m (the end of the seabed search)
    cfg = BandConfig()
    trk = OnsetTracker(NB, cfg)
    trk.set_known(False)
    d = np.full((80, NB), 0.6)
    onset, fi, bi, ri = _returns(d)
    out = trk.correct(GEOM, onset, fi, bi, ri)
    assert np.allclose(out[-1] - onset[-1], 0.6, atol=0.03)
    trk.set_known(True)  # a fit spanning the survey: the limit is max_deeper_m again, from the next frame on
    out = trk.correct(GEOM, onset, fi, bi, ri)
    assert (out - onset).max() <= cfg.max_deeper_m + 1e-9
    trk.set_known(False)
    far = trk.correct(GEOM, *_returns(np.full((80, NB), 1.8)))  # never past the end of the search
    assert (far - 8.0).max() <= cfg.band_m + 1e-9


def test_rebase_keeps_the_corrected_onset_where_it_was() -> None:
    trk = OnsetTracker(NB, BandConfig())
    d = np.full((60, NB), -0.3)
    onset, fi, bi, ri = _returns(d)
    before = trk.correct(GEOM, onset, fi, bi, ri)[-1]
    trk.rebase(np.full(NB, 0.2))  # the new fit predicts 0.2 m nearer: the correction grows by 0.2
    assert np.allclose(onset[-1] + trk.est - 0.2, before, atol=1e-9)


def test_a_one_bin_return_is_the_seabed_return() -> None:
    img = np.full((1, GEOM.n_bins, NB), 40, np.uint8)
    row = int(np.rint(GEOM.range_to_row(7.7)))
    img[0, row, :] = 180  # the steepest ray's return: one bin per beam
    img[0, row + 6 : row + 8, :] = 200  # shallower rays' returns, two bins together, later
    sf, _sb, sr = seabed_returns(GEOM, img, np.full((1, NB), 8.0), np.full(1, 100.0), 0.1, BandConfig())
    assert sf.size == NB and np.all(sr == row)
    two = seabed_returns(GEOM, img, np.full((1, NB), 8.0), np.full(1, 100.0), 0.1, BandConfig(min_run=2))
    assert np.all(two[2] == row + 6)  # what asking for two bins found: 6 bins late


# two lines at 3.5 m over a rough seabed sloping 7 deg, nothing on it
ROUGH_SCENE = scene_toml(seed=5, seabed={"depth": 25.0, "slope_deg": 7.0, "slope_azimuth_deg": 60.0, "roughness": 0.08},
                         objects=[], survey={"heading_deg": 20.0, "line_length": 30.0, "line_spacing": 3.0, "lines": 2,
                                             "altitude": 3.5},
                         sonar={"tilt_deg": 37.0, "window_start": 0.5, "window_length": 7.2, "fps": 15.0})


@pytest.fixture(scope="module")
def rough_run() -> tuple[object, object]:
    pytest.importorskip("open3d")
    from auvlink.evaluation.simeval import reconstruct, simulate
    from auvlink.sim.scene import loads_scene
    from auvlink.sim.seabed import SeabedSurface

    frames = simulate(loads_scene(ROUGH_SCENE))
    rec, objects = reconstruct(frames)
    return rec, (objects, SeabedSurface(frames.scene.seabed, frames.scene.seed))


@pytest.mark.slow
def test_seabed_samples_on_a_rough_seabed_lie_on_it(rough_run: tuple) -> None:
    rec, (_, truth) = rough_run
    p = rec.seabed_points  # the DVL's and the sonar's seabed returns
    err = p[:, 2] - truth.depth(p[:, 0], p[:, 1])  # + under the seabed
    assert abs(float(np.median(err))) < 0.03, np.percentile(err, [5, 50, 95])
    assert float(np.percentile(err, 95)) < 0.15, np.percentile(err, [5, 50, 95])
    # the tiled planes fitted from them are level with the seabed's plane (the texture averages out)
    model = SeabedModel.fit(p, SeabedConfig())
    q = p[:: max(1, p.shape[0] // 2000), :2]
    off = model.depth_at(q) - truth.plane_depth(q[:, 0], q[:, 1])
    assert abs(float(np.median(off))) < 0.05, np.percentile(off, [5, 50, 95])
    # and the seabed at the scale of its texture follows it within centimetres (it was 0.13 m under it)
    tex = rec.fit_seabed(q.min(axis=0), q.max(axis=0))
    err = tex.depth_at(q) - truth.depth(q[:, 0], q[:, 1])
    assert abs(float(np.median(err))) < 0.03 and float(np.percentile(np.abs(err), 90)) < 0.12, \
        np.percentile(err, [5, 50, 95])


@pytest.mark.slow
def test_no_clutter_on_a_rough_seabed_without_objects(rough_run: tuple) -> None:
    _, (objects, _) = rough_run
    assert objects == [], [(o.centroid.round(1).tolist(), o.n_points) for o in objects]


# two lines over a rough seabed under a soft, wide vertical beam (Gaussian, energy out to 2.9 widths) with a TVG
# error: the seabed glows well before its onset, and the background pooled from earlier frames near the onset
# holds that glow
SOFT_SCENE = scene_toml(seed=7, seabed={"depth": 30.0, "slope_deg": 2.0, "slope_azimuth_deg": 300.0, "roughness": 0.06},
                        objects=[], survey={"heading_deg": 313.0, "line_length": 30.0, "line_spacing": 2.7, "lines": 2,
                                            "altitude": 4.2, "speed": 1.0},
                        sonar={"tilt_deg": 28.0, "window_start": 1.26, "window_length": 10.0, "fps": 10.0},
                        acoustics={"profile": "didson", "vertical_pattern": "gaussian", "vertical_extent": 2.9,
                                   "tvg_error_db_per_m": -1.7, "noise_floor_db": -51.0, "gain_db": 3.0})


@pytest.mark.slow
def test_seabed_samples_under_a_soft_wide_beam_lie_on_the_seabed() -> None:
    # the seabed return is where the column reaches the seabed's own level (the half step the effective edge is
    # measured at); a threshold over the background pooled from earlier frames finds it past the onset, and placed
    # on the steepest ray it lies under the seabed (here the texture 0.25 m deep at the median, its cells' spread
    # about their neighbourhood 0.12 m)
    pytest.importorskip("open3d")
    from auvlink.evaluation.simeval import reconstruct, simulate
    from auvlink.sim.scene import loads_scene
    from auvlink.sim.seabed import SeabedSurface

    frames = simulate(loads_scene(SOFT_SCENE))
    rec, objects = reconstruct(frames)
    truth = SeabedSurface(frames.scene.seabed, frames.scene.seed)
    p = rec.seabed_points
    err = p[:, 2] - truth.depth(p[:, 0], p[:, 1])
    assert float(np.percentile(err, 95)) < 0.15, np.percentile(err, [5, 50, 95])
    q = p[:: max(1, p.shape[0] // 2000), :2]
    tex = rec.fit_seabed(q.min(axis=0), q.max(axis=0))
    err = tex.depth_at(q) - truth.depth(q[:, 0], q[:, 1])
    assert abs(float(np.median(err))) < 0.03 and float(np.percentile(np.abs(err), 90)) < 0.12, \
        np.percentile(err, [5, 50, 95])
    assert tex.level_sigma < 0.09  # the cells' spread about their neighbourhood: the texture's, not a bias's
    assert objects == []
