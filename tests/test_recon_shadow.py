"""An object's top height from its acoustic shadow (recon.shadow): frames of a level seabed band, then one with an
object's echo and shadow in some beams; the height read against the geometry's h = H (1 - r_top / r_s)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from recon.shadow import MIN_REFERENCE, REFERENCE_M, SAMPLE_M, ShadowTops
from recon.sonar_geometry import SonarGeometry

WATER, SEABED, ECHO = 10.0, 100.0, 220.0
ONSET_M = 5.0


def _seabed_frame(g: SonarGeometry, rng: np.random.Generator) -> np.ndarray:
    level = np.where(g.ranges < ONSET_M, WATER, SEABED)
    return np.clip(level[:, None] + rng.normal(0.0, 3.0, (g.n_bins, g.n_beams)), 0, 255)


def _run(g: SonarGeometry, alt: float, r_top: float, r_s: float, beams: slice, seed: int = 0
         ) -> tuple[ShadowTops, np.ndarray]:
    """A ShadowTops fed frames along a straight line north (one per SAMPLE_M), the last with an object's echo
    (0.3 m before ``r_top``) and shadow (``r_top`` to ``r_s``) in ``beams``; and the last frame's position."""
    rng = np.random.default_rng(seed)
    n = math.ceil(REFERENCE_M[1] / SAMPLE_M) + 2
    frames = np.stack([_seabed_frame(g, rng) for _ in range(n)])
    r = g.ranges
    frames[-1, (r >= r_top - 0.3) & (r < r_top), beams] = ECHO
    frames[-1, (r >= r_top) & (r < r_s), beams] = WATER
    pos = np.column_stack([np.arange(n) * SAMPLE_M * 1.001, np.zeros(n), np.zeros(n)])
    rot = Rotation.identity(n)
    point, normal = pos + [0.0, 0.0, alt], np.tile([0.0, 0.0, -1.0], (n, 1))
    tops = ShadowTops()
    tops.add(frames.astype(np.uint8), g, np.full((n, g.n_beams), ONSET_M), pos, rot, point, normal)
    return tops, pos[-1]


def test_a_shadow_gives_the_top_of_the_ray_that_grazes_it() -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    alt, r_top, r_s = 2.2, 8.0, 11.0
    tops, last = _run(g, alt, r_top, r_s, slice(40, 56))
    assert tops.frames_read >= 1 and tops.shadows >= 14
    want = alt * (1.0 - r_top / r_s)  # 0.60 m
    t = tops.tops
    assert np.all(np.abs(t[:, 2] - want) < 0.04), t[:, 2]
    # the tops lie on the rays of those beams at r_top ahead of the sonar (north), r_top cos(elevation) away
    ahead = np.hypot(t[:, 0] - last[0], t[:, 1] - last[1])
    assert np.all((ahead > r_top * math.cos(math.asin(alt / r_s)) - 0.05) & (ahead < r_top))
    footprint = np.column_stack([t[:, 0], t[:, 1], np.zeros(len(t))])
    assert tops.height(footprint) == pytest.approx(want, abs=0.04)
    assert math.isnan(tops.height(footprint + [30.0, 0.0, 0.0]))  # no tops there


@settings(max_examples=12, deadline=None)
@given(alt=st.floats(1.5, 3.5), r_top=st.floats(6.0, 9.0), h=st.floats(0.15, 1.0), seed=st.integers(0, 100))
def test_the_height_follows_the_geometry(alt: float, r_top: float, h: float, seed: int) -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    r_s = r_top * alt / (alt - h)  # where the ray grazing a top h high meets the seabed
    if r_s > g.max_range - 0.5:
        return
    tops, _ = _run(g, alt, r_top, r_s, slice(30, 50), seed)
    assert tops.shadows > 0
    assert np.median(tops.tops[:, 2]) == pytest.approx(h, abs=0.04)


def test_no_shadow_without_a_reference_or_past_the_window() -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    tops, _ = _run(g, 2.2, 8.0, 20.0, slice(40, 56))  # the shadow runs past the window's end: its end unseen
    assert tops.shadows == 0
    few = ShadowTops()
    rng = np.random.default_rng(1)
    n = MIN_REFERENCE  # too few frames behind for a reference
    frames = np.stack([_seabed_frame(g, rng) for _ in range(n)]).astype(np.uint8)
    pos = np.column_stack([np.arange(n) * SAMPLE_M, np.zeros(n), np.zeros(n)])
    few.add(frames, g, np.full((n, g.n_beams), ONSET_M), pos, Rotation.identity(n), pos + [0, 0, 2.2],
            np.tile([0.0, 0.0, -1.0], (n, 1)))
    assert few.frames_read == 0


def test_a_plain_seabed_casts_no_shadow() -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    tops, _ = _run(g, 2.2, 8.0, 8.0, slice(0, 0))
    assert tops.frames_read >= 1 and tops.shadows == 0


def test_a_height_that_does_not_stand_out_of_the_seabeds_own_shadows_is_not_measured() -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    tops, _ = _run(g, 2.2, 8.0, 11.0, slice(40, 56))
    t = tops.tops
    footprint = np.column_stack([t[:, 0], t[:, 1], np.zeros(len(t))])
    h = tops.height(footprint)
    assert h == pytest.approx(0.6, abs=0.04)
    # a rough seabed around it casting shadows as high: its height no longer tells
    lo = t[:, :2].min(axis=0)
    north = lo[0] - 2.0 + 0.1 * np.arange(40)
    seen_from = np.column_stack([north, np.full(40, lo[1] - 8.0)])  # looking east along the row, not over the object
    rough = np.column_stack([north, np.full(40, lo[1]), np.full(40, h), np.zeros(40), seen_from])
    tops._tops.append(rough)
    assert math.isnan(tops.height(footprint))
    assert tops.outcomes == {"measured": 1, "too_few_shadows": 0, "not_above_seabed": 1}


def test_the_objects_own_shadow_beyond_its_footprint_is_not_the_seabeds() -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    tops, last = _run(g, 2.2, 8.0, 11.0, slice(40, 56))
    t = tops.tops
    footprint = np.column_stack([t[:, 0], t[:, 1], np.zeros(len(t))])
    hi = t[:, :2].max(axis=0)
    # tops as high 1-2 m beyond the object, read on rays from the sonar (south of it) that passed over it
    beyond = np.column_stack([np.linspace(hi[0] + 1.0, hi[0] + 2.0, 40), np.full(40, t[:, 1].mean()),
                              np.full(40, 0.6), np.zeros(40), np.tile(last[:2], (40, 1))])
    tops._tops.append(beyond)
    assert tops.height(footprint) == pytest.approx(0.6, abs=0.04)


def test_a_beam_without_an_onset_casts_no_shadow() -> None:
    g = SonarGeometry.from_degrees(tilt_deg=20.0, spread_deg=14.0, window_start=1.0, window_length=13.0)
    rng = np.random.default_rng(3)
    n = math.ceil(REFERENCE_M[1] / SAMPLE_M) + 2
    frames = np.stack([_seabed_frame(g, rng) for _ in range(n)])
    frames[-1, (g.ranges >= 7.7) & (g.ranges < 8.0), 40:56] = ECHO
    frames[-1, (g.ranges >= 8.0) & (g.ranges < 11.0), 40:56] = WATER
    onset = np.full((n, g.n_beams), ONSET_M)
    onset[:, 40:56] = np.nan  # no onset found in the object's beams
    pos = np.column_stack([np.arange(n) * SAMPLE_M * 1.001, np.zeros(n), np.zeros(n)])
    tops = ShadowTops()
    tops.add(frames.astype(np.uint8), g, onset, pos, Rotation.identity(n), pos + [0.0, 0.0, 2.2],
             np.tile([0.0, 0.0, -1.0], (n, 1)))
    assert tops.frames_read >= 1 and tops.shadows == 0
