"""The realistic image model's fast path (range-major lit band, FFT beam mixing) against the reference it replaced:
the beam-major dense elevation integral and the azimuth response as one matrix product, on small frames."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_sim_acoustics import _survey_poses

from auvlink.sim.acoustic_image import MIN_SPAN_BINS, OBJECT_GAP_M, AcousticImager, spread_in_range
from auvlink.sim.acoustics import AcousticsTable
from auvlink.sim.azimuth_response import AzimuthMixer, beam_mixing, spread_across_beams
from auvlink.sim.scene import load_default_scene, with_sonar_model
from auvlink.sim.sonar_geometry import RayFan
from auvlink.sim.sonar_render import MISS, OBJECT, SonarRenderer, sampled_aperture
from auvlink.sonar import SonarModelName


def _reference_integrate(im: AcousticImager, rng_: np.ndarray, energy: np.ndarray, surface: np.ndarray) -> np.ndarray:
    """The elevation integral as first written (beam-major, one dense running sum over the flattened beams)."""
    g = im.g
    nb, nk, n = g.n_beams, g.k, g.n_bins
    x = ((rng_ - g.window_start) / g.bin_width).reshape(nk, nb)
    e, s = energy.reshape(nk, nb), surface.reshape(nk, nb)
    with np.errstate(invalid="ignore"):
        span = np.abs(x[1:] - x[:-1])
        joined = (s[:-1] == s[1:]) & np.isfinite(span) & (span > MIN_SPAN_BINS) & (
            (s[:-1] < 0) | (span * g.bin_width < OBJECT_GAP_M))
    single = np.full((nk, nb), 2.0)
    single[1:] -= joined
    single[:-1] -= joined
    own = 0.5 * e * single
    slope = np.where(joined, 0.5 * (e[:-1] + e[1:]) / np.where(joined, span, 1.0), 0.0)
    stride = n + 1
    base = np.arange(nb) * stride
    c = np.clip(np.nan_to_num(np.concatenate([np.fmin(x[:-1], x[1:]), np.fmax(x[:-1], x[1:])]), nan=0.0, posinf=n),
                0.0, n)
    w = np.concatenate([slope, -slope])
    at = (np.floor(c).astype(np.int64) + 1 + base).ravel()
    inside = np.isfinite(x) & (x >= 0.0) & (x < n)
    pts = (np.floor(np.where(inside, x, 0.0)).astype(np.int64) + 1 + base).ravel()
    size = nb * stride + 1
    b1 = np.bincount(at, weights=w.ravel(), minlength=size)
    b0 = np.bincount(np.concatenate([at, pts]), minlength=size,
                     weights=np.concatenate([(w * c).ravel(), -np.where(inside, own, 0.0).ravel()]))
    v = (np.cumsum(b1) - b0)[: nb * stride].reshape(nb, stride)[:, 1:]
    v += np.arange(n) * b1[: nb * stride].reshape(nb, stride)[:, 1:]
    return np.maximum(v, 0.0)


def _reference_expected(im: AcousticImager, rng_: np.ndarray, cos2: np.ndarray, diffuse: np.ndarray,
                        surface: np.ndarray) -> np.ndarray:
    """Steps 1-3 as first written, range-major: the dense integral, the pulse, the azimuth response's matrix."""
    e = im.sample_energy(rng_, cos2, diffuse, surface >= 0)
    img = np.ascontiguousarray(_reference_integrate(im, rng_, e, surface).T.astype(np.float32))
    img = spread_in_range(img, im.p.pulse_m / im.g.bin_width)
    mixing = beam_mixing(im.g.n_beams, im.p.azimuth_width_beams, im.p.sidelobe_db).astype(np.float32)
    return np.asarray(spread_across_beams(img, mixing), np.float32)


@pytest.mark.parametrize("n_beams", [64, 96, 257, 512])
@pytest.mark.parametrize(("width", "sidelobe_db"), [(1.0, -25.0), (4.66, -20.0)])
def test_fft_mixing_matches_the_matrix_product(n_beams: int, width: float, sidelobe_db: float) -> None:
    draw = np.random.default_rng(n_beams)
    e = (draw.random((40, n_beams)) ** 8).astype(np.float32)  # mostly dark, a few bright cells
    ref = spread_across_beams(e, beam_mixing(n_beams, width, sidelobe_db).astype(np.float32))
    fast = AzimuthMixer(n_beams, width, sidelobe_db)(e)
    assert fast.dtype == np.float32 and fast.shape == e.shape
    assert np.allclose(fast, ref, rtol=1e-4, atol=1e-6 * float(ref.max()))


@pytest.mark.parametrize(("model", "n_bins"), [("didson", 512), ("oculus-m750d", 600), ("oculus-m1200d", 600)])
def test_the_fast_image_matches_the_reference_on_small_frames(model: SonarModelName, n_bins: int) -> None:
    """Expected energies within float32 rounding of the reference; 8-bit images (no speckle) equal but for a
    few cells one grey level apart, where a level sits on a step of the display."""
    scene = with_sonar_model(replace(load_default_scene(), acoustics=AcousticsTable(profile="didson")), model)
    rd = SonarRenderer(scene, speckle=False)
    assert rd.acoustics is not None
    rd.geometry = RayFan(sampled_aperture(scene.sonar, rd.acoustics), rd.geometry.k, n_bins=n_bins)
    im = rd.imager = AcousticImager(rd.acoustics, rd.geometry, scene.seed)
    pos, mats = _survey_poses(scene)
    seen = 0
    for p, m in zip(pos, mats, strict=True):
        h = rd.trace_matrix(p, m)
        seen += int((h.kind == OBJECT).any())
        strength = np.append(rd.gain, rd.seabed_gain)[h.object_index]
        with np.errstate(invalid="ignore"):
            cos2 = np.where(h.kind == MISS, 0.0, h.intensity * h.range * h.range / strength)
        diffuse = im.mu * np.where(h.kind == OBJECT, strength / rd.seabed_gain * im.object_scale, 1.0)
        ref = _reference_expected(im, h.range, cos2, diffuse, h.object_index)
        fast = im.expected(h.range, cos2, diffuse, h.object_index)
        assert ref.max() > 0.0 and fast.shape == ref.shape == (n_bins, rd.geometry.n_beams)
        assert np.allclose(fast, ref, rtol=1e-3, atol=1e-5 * float(ref.max()))
        a, b = im.display(fast, None).astype(int), im.display(ref, None).astype(int)
        assert np.abs(a - b).max() <= 1 and np.mean(a != b) < 1e-3
    assert seen >= 1  # an object in view: its highlight and sidelobe arcs compared too
