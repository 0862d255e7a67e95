"""Simulated sonar images: exact seabed geometry, shadows, the sphere/hemisphere ambiguity,
culling that changes nothing, speckle statistics and reproducible bytes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import gaussian_filter
from scipy.spatial.transform import Rotation

from auvlink.sim.acoustics import AcousticsTable
from auvlink.sim.scene import Scene, SceneObject, Seabed, SonarConfig, Survey, load_default_scene
from auvlink.sim.sonar_geometry import RayFan
from auvlink.sim.sonar_render import MISS, OBJECT, SEABED, SonarRenderer, frame_rng
from auvlink.sim.speckle import AcousticModel
from auvlink.sim.trajectory import LawnmowerTrajectory

POS = np.array([0.0, 0.0, 15.0])  # 5 m above a 20 m deep flat seabed
#: the idealized model (equation 9): the flat-scene tests check its exact geometry (K rays per beam, a hard
#: edge at +-s/2, each ray's return in one cell, nothing where no ray hits), which a realistic profile blurs
IDEAL = AcousticsTable(profile="ideal")


def flat_scene(objects: tuple[SceneObject, ...] = (), tilt: float = 30.0,
               window: tuple[float, float] = (1.0, 10.0), rough: float = 0.0, k: int = 32) -> Scene:
    return Scene(seed=11, seabed=Seabed(depth=20.0, roughness=rough), objects=objects,
                 survey=Survey(line_length=60.0, line_spacing=3.5, lines=2, altitude=5.0, speed=1.0),
                 sonar=SonarConfig(tilt_deg=tilt, window_start=window[0], window_length=window[1], fps=10.0,
                                   rays_per_beam=k), acoustics=IDEAL)


def first_rows(img: np.ndarray) -> np.ndarray:
    """First range bin with a return in every beam (-1 for none)."""
    nz = img > 0
    return np.where(nz.any(axis=0), nz.argmax(axis=0), -1)


@pytest.mark.parametrize("tilt,altitude,window", [(30.0, 5.0, (1.0, 10.0)), (20.0, 5.0, (2.0, 12.0)),
                                                  (45.0, 3.0, (0.5, 5.0)), (30.0, 2.0, (0.5, 5.0))])
def test_flat_seabed_first_return_per_beam_matches_geometry(tilt: float, altitude: float,
                                                            window: tuple[float, float]) -> None:
    rd = SonarRenderer(flat_scene(tilt=tilt, window=window), speckle=False)
    img = rd.render(np.array([3.0, -2.0, 20.0 - altitude]), 0.7, 0.0, 0.0)
    g = rd.geometry
    t, s = math.radians(tilt), math.radians(14.0)
    r = altitude / (math.sin(t) * math.cos(s / 2) * np.cos(g.azimuth) + math.cos(t) * math.sin(s / 2))
    expected = g.bin_of_range(r)
    assert (expected >= 0).all()
    assert np.abs(first_rows(img) - expected).max() <= 1


@pytest.mark.parametrize("tilt,altitude", [(30.0, 5.0), (25.0, 4.0), (40.0, 3.0)])
def test_seabed_onset_at_azimuth_zero(tilt: float, altitude: float) -> None:
    rd = SonarRenderer(flat_scene(tilt=tilt, window=(0.5, 12.0)), speckle=False)
    pos = np.array([0.0, 0.0, 20.0 - altitude])
    hits = rd.trace(pos, 0.0, 0.0, 0.0)
    onset = altitude / math.sin(math.radians(tilt + 7.0))
    k = rd.geometry.k
    for beam in (47, 48):  # the two beams next to azimuth 0 (+-0.15 deg)
        ranges = hits.range.reshape(k, 96)[:, beam]  # ray index = k * 96 + beam
        assert ranges.min() == pytest.approx(onset, abs=1e-4)
        assert ranges.argmin() == k - 1  # the steepest ray, phi = +s/2
    img = rd.image(hits)
    assert set(first_rows(img)[47:49]) <= {int(rd.geometry.bin_of_range(np.array([onset]))[0])}


def test_seabed_return_strength_formula() -> None:
    rd = SonarRenderer(flat_scene(), speckle=False)
    hits = rd.trace(POS, 0.3, 0.0, 0.0)
    assert (hits.kind == SEABED).all()
    d = hits.directions
    expected = rd.seabed_gain * d[:, 2] ** 2 / hits.range**2  # cos(alpha) = down component
    np.testing.assert_allclose(hits.intensity, expected, rtol=1e-12)
    np.testing.assert_allclose(hits.points[:, 2], 20.0, atol=1e-9)


def _highlight(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Speckle-free image of the object's own returns (blurred to the sonar's resolution), hits."""
    rd = SonarRenderer(scene, speckle=False)
    hits = rd.trace(POS, 0.0, 0.0, 0.0)
    only = replace(hits, intensity=np.where(hits.kind == OBJECT, hits.intensity, 0.0))
    return gaussian_filter(rd.image(only).astype(float), (2.0, 0.7)), hits.points[hits.kind == OBJECT]


def _ncc_any_range_shift(a: np.ndarray, b: np.ndarray, max_shift: int = 60) -> float:
    """Best normalized correlation over range shifts (a single image does not give the range of an
    unknown object's base, so the shape is compared up to a shift in range)."""
    x, y = a - a.mean(), b - b.mean()
    # circular cross-correlation along range for every shift at once
    spec = np.fft.rfft(x, axis=0) * np.conj(np.fft.rfft(y, axis=0))
    xc = np.fft.irfft(spec, n=x.shape[0], axis=0).sum(axis=1)
    shifts = np.r_[xc[: max_shift + 1], xc[-max_shift:]]
    return float(shifts.max() / math.sqrt((x * x).sum() * (y * y).sum()))


def test_sphere_and_hemisphere_look_alike_in_one_image_but_differ_in_3d() -> None:
    images, points = {}, {}
    for name in ("sphere", "hemisphere", "box", "reef_a"):
        images[name], points[name] = _highlight(flat_scene((SceneObject(name, 9.0, 0.0),)))
    same = _ncc_any_range_shift(images["sphere"], images["hemisphere"])
    assert same > 0.9
    # more alike than the sphere is to other classes
    assert same > _ncc_any_range_shift(images["sphere"], images["box"])
    assert same > _ncc_any_range_shift(images["sphere"], images["reef_a"]) + 0.3
    # while the 3D truth differs: the sphere's hits reach 1.0 m above the seabed, the hemisphere's 0.5 m
    top_sphere = 20.0 - points["sphere"][:, 2].min()
    top_hemi = 20.0 - points["hemisphere"][:, 2].min()
    assert top_sphere > 0.9 and top_hemi < 0.51 and top_sphere - top_hemi > 0.4


def test_shadow_behind_a_box() -> None:
    box = flat_scene((SceneObject("box", 8.0, 0.0, 0.0),))
    empty = flat_scene()
    rd_box, rd_empty = SonarRenderer(box, speckle=False), SonarRenderer(empty, speckle=False)
    h_box, h_empty = rd_box.trace(POS, 0.0, 0.0, 0.0), rd_empty.trace(POS, 0.0, 0.0, 0.0)
    blocked = h_box.kind == OBJECT
    assert blocked.sum() > 50
    # cells the blocked rays would light on the seabed, minus anything the box itself lights
    g = rd_box.geometry
    _, cells_seabed = g.cells_of_rays(np.where(blocked, h_empty.range, np.inf))
    lit_box, _ = rd_box.returns(h_box)
    shadow = np.setdiff1d(cells_seabed, lit_box)
    assert shadow.size > 30
    i_box, i_empty = rd_box.intensity(h_box).ravel(), rd_empty.intensity(h_empty).ravel()
    assert (i_box[shadow] == 0).all() and (i_empty[shadow] > 0).all()
    # with speckle the shadow is as dark as the noise floor, the lit seabed much brighter
    sp_box = SonarRenderer(box).render(POS, 0.0, 0.0, 0.0, frame_rng(1, 0)).ravel().astype(float)
    sp_empty = SonarRenderer(empty).render(POS, 0.0, 0.0, 0.0, frame_rng(1, 0)).ravel().astype(float)
    noise_floor = sp_box[: 200 * g.n_beams].mean()  # near ranges: water only
    assert sp_box[shadow].mean() < noise_floor + 5
    assert sp_empty[shadow].mean() > noise_floor + 40
    # and the box itself is brighter than the seabed
    assert rd_box.intensity(h_box).max() > 3 * rd_empty.intensity(h_empty).max()


def test_same_seed_same_bytes() -> None:
    scene = load_default_scene()
    tr = LawnmowerTrajectory.from_scene(scene)
    p = tr.true_pose(np.arange(0.0, 8.0, 0.5))
    a = list(SonarRenderer(scene).render_sequence(p.position, p.rotation(), seed=scene.seed))
    b = list(SonarRenderer(scene).render_sequence(p.position, p.rotation(), seed=scene.seed))
    c = list(SonarRenderer(scene).render_sequence(p.position, p.rotation(), seed=scene.seed + 1))
    assert b"".join(x.tobytes() for x in a) == b"".join(x.tobytes() for x in b)
    assert all(x.tobytes() != y.tobytes() for x, y in zip(a, c, strict=True))
    # a frame renders the same bytes on its own (per-frame generator)
    rd = SonarRenderer(scene)
    alone = rd.render(p.position[5], p.yaw[5], p.pitch[5], p.roll[5], frame_rng(scene.seed, 5))
    assert alone.tobytes() == a[5].tobytes()
    assert a[0].dtype == np.uint8 and a[0].shape == (512, 96) and a[0].flags.c_contiguous


@pytest.mark.parametrize("profile", ["ideal", "didson"])
def test_culling_modes_give_identical_images(profile: str) -> None:
    # didson, a realistic image: its samples' range footprints reach past a hit (the window's end)
    scene = replace(load_default_scene(), acoustics=AcousticsTable(profile=profile))  # type: ignore[arg-type]
    tr = LawnmowerTrajectory.from_scene(scene)
    p = tr.true_pose(tr.survey_start + np.arange(0.0, 60.0, 1.5))
    out = {}
    for cull in ("rays", "objects", "none"):
        rd = SonarRenderer(scene, cull=cull)
        out[cull] = np.stack(list(rd.render_sequence(p.position, p.rotation(), seed=3)))
        if cull == "none":
            kinds = [rd.trace(p.position[i], p.yaw[i], p.pitch[i], p.roll[i]).kind for i in range(len(p))]
    with_obj = sum(bool((k == OBJECT).any()) for k in kinds)
    assert 5 <= with_obj < len(p)  # the run has frames with and without objects in view
    np.testing.assert_array_equal(out["rays"], out["none"])
    np.testing.assert_array_equal(out["objects"], out["none"])


def test_frame_without_objects_in_view_casts_no_ray() -> None:
    rd = SonarRenderer(flat_scene((SceneObject("sphere", 9.0, 0.0),)))
    calls: list[int] = []
    cast = rd._cast

    def counting(*args: object, **kw: object) -> None:
        calls.append(1)
        cast(*args, **kw)  # type: ignore[arg-type]

    rd._cast = counting  # type: ignore[method-assign]
    rd.trace(POS, math.pi, 0.0, 0.0)  # looking away
    rd.trace(POS + np.array([-30.0, 0.0, 0.0]), 0.0, 0.0, 0.0)  # too far behind
    assert calls == []
    hits = rd.trace(POS, 0.0, 0.0, 0.0)
    assert calls == [1] and (hits.kind == OBJECT).any()


def test_rough_seabed_onset_close_to_flat() -> None:
    flat = SonarRenderer(flat_scene(), speckle=False).render(POS, 0.0, 0.0, 0.0)
    rough = SonarRenderer(flat_scene(rough=0.02), speckle=False).render(POS, 0.0, 0.0, 0.0)
    assert np.abs(first_rows(rough) - first_rows(flat)).max() <= 6  # 2 cm rms ~ 1-3 bins
    assert (first_rows(rough) != first_rows(flat)).any()


def test_speckle_table_matches_explicit_draws() -> None:
    model = AcousticModel()
    zero = np.zeros((512, 96))
    fast = model.speckle(zero, np.random.default_rng(1))
    exact = model.speckle(zero, np.random.default_rng(2), exact=True)
    cdf_fast = np.cumsum(np.bincount(fast.ravel(), minlength=256)) / fast.size
    cdf_exact = np.cumsum(np.bincount(exact.ravel(), minlength=256)) / exact.size
    assert np.abs(cdf_fast - cdf_exact).max() < 0.012  # two-sample KS, n = 49152 each
    assert 20 < fast.mean() < 120  # a visible noise floor, far from saturation


def test_quantize_is_log_and_monotone() -> None:
    model = AcousticModel()
    th = model.thresholds
    assert model.quantize(np.array([0.0]))[0] == 0
    q = model.quantize(np.concatenate([th * 1.0001, th * 0.9999]))
    np.testing.assert_array_equal(q[:255], np.arange(1, 256))
    np.testing.assert_array_equal(q[255:], np.arange(0, 255))
    assert model.quantize(np.array([1e9]))[0] == 255
    # 50 dB over 256 levels: 10 dB more is 51.2 levels more
    assert int(model.quantize(np.array([1.0]))[0]) + 51 <= int(model.quantize(np.array([10.0]))[0]) <= \
        int(model.quantize(np.array([1.0]))[0]) + 52


def test_geometry_conventions() -> None:
    g = RayFan(SonarConfig(tilt_deg=30.0, window_start=1.0, window_length=10.0, fps=10.0,
                                  lever_arm=(0.5, 0.0, 0.2)), rays_per_beam=8)
    np.testing.assert_allclose(np.linalg.norm(g.dir_s, axis=1), 1.0)
    assert g.elevation[-1] == pytest.approx(math.radians(7.0))
    boresight = g.r_bs.apply([1.0, 0.0, 0.0])
    np.testing.assert_allclose(boresight, [math.cos(math.radians(30)), 0.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(g.range_of_bin[[0, 511]], [1.0 + 10 / 1024, 11.0 - 10 / 1024])
    bins = g.bin_of_range(np.array([0.99, 1.0, 10.999, 11.0, np.inf]))
    np.testing.assert_array_equal(bins, [-1, 0, 511, -1, -1])
    r_wb = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    origin, d = g.rays_world(np.array([1.0, 2.0, 3.0]), r_wb)
    np.testing.assert_allclose(origin, [1.0, 2.5, 3.2], atol=1e-12)
    assert g.beam_of_ray[1] == 1 and g.beam_of_ray[96] == 0 and d.shape == (3, 96 * 8)
    np.testing.assert_allclose(g.dir_s[96 * 7 + 3], [math.cos(math.radians(7.0)) * math.cos(g.azimuth[3]),
                                                     math.cos(math.radians(7.0)) * math.sin(g.azimuth[3]),
                                                     math.sin(math.radians(7.0))])


def test_misses_have_no_return() -> None:
    rd = SonarRenderer(flat_scene(), speckle=False)
    hits = rd.trace(POS, 0.0, math.radians(60.0), 0.0)  # nose up: rays point above the horizon
    assert (hits.kind == MISS).all() and (hits.intensity == 0).all()
    assert rd.image(hits).max() == 0


_CLUSTER = flat_scene(tuple(SceneObject(c, 8.0 + 1.5 * i, (-1) ** i * 0.8 * i, 25.0 * i)
                            for i, c in enumerate(("reef_a", "pipe", "sphere", "half_pipe", "box"))))
_RENDERERS = {cull: SonarRenderer(_CLUSTER, cull=cull, speckle=False) for cull in ("rays", "objects", "none")}


@settings(max_examples=25, deadline=None)
@given(st.floats(-6.0, 6.0), st.floats(-4.0, 4.0), st.floats(-0.6, 0.6), st.floats(-0.2, 0.2),
       st.floats(-0.2, 0.2), st.floats(2.0, 7.0))
def test_culling_never_changes_returns(north: float, east: float, yaw: float, pitch: float, roll: float,
                                       altitude: float) -> None:
    pos = np.array([north, east, 20.0 - altitude])
    out = {c: rd.returns(rd.trace(pos, yaw, pitch, roll)) for c, rd in _RENDERERS.items()}
    for cull in ("rays", "objects"):
        np.testing.assert_array_equal(out[cull][0], out["none"][0])
        np.testing.assert_array_equal(out[cull][1], out["none"][1])
