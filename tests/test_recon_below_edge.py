"""Reflectors brighter than the seabed seen below the effective edge: the pattern's measured fall
(recon.pattern_fall, recon.beam_edge.frame_edge_profile), the seabed band's echo mosaic (recon.echo_mosaic) and
the objects re-placed on their arcs (recon.object_stage, recon.front_slope)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from recon.beam_edge import frame_edge_profile
from recon.echo_mosaic import EchoMosaic
from recon.front_slope import replace_on_arcs
from recon.pattern_fall import FALL_FRACTIONS, PatternFall
from recon.range_arcs import arc_record, points_at
from recon.sonar_geometry import SonarGeometry

N_FRAMES = 4


def _poses(n: int) -> tuple[np.ndarray, Rotation]:
    return np.zeros((n, 3)), Rotation.identity(n)


def _flat(pos: np.ndarray, alt: float) -> tuple[np.ndarray, np.ndarray]:
    return pos + np.array([0.0, 0.0, alt]), np.tile([0.0, 0.0, -1.0], (len(pos), 1))


def _seabed_elevations(g: SonarGeometry, alt: float) -> np.ndarray:
    """Per range bin, the elevation (rad below the fan's axis) at which the fan meets a level seabed ``alt`` m
    under a level vehicle (NaN before the seabed can show), lever arm and mounting included."""
    pos, rot = _poses(1)
    onset_at = {}
    for phi in np.radians(np.linspace(0.0, 40.0, 4001)):
        d = g.directions_body(np.array([phi]), np.array([0.0]))[0]
        o = g.mounting.lever
        if d[2] > 1e-9:
            onset_at[phi] = (alt - o[2]) / d[2]
    phis = np.array(list(onset_at))
    ranges = np.array(list(onset_at.values()))
    order = np.argsort(ranges)
    out = np.interp(g.ranges, ranges[order], phis[order], left=np.nan, right=np.nan)
    del pos, rot
    return np.asarray(out)


def _soft_seabed(g: SonarGeometry, alt: float, fall_db_per_deg: float | None, rng: np.random.Generator) -> np.ndarray:
    """Frames of a level seabed whose grey level falls ``fall_db_per_deg`` grey levels per degree below the
    nominal edge (None: a hard edge), water at 10, seabed plateau at 150, a little noise."""
    phi = _seabed_elevations(g, alt)
    beyond = np.degrees(phi - 0.5 * g.spread)
    if fall_db_per_deg is None:
        level = np.where(beyond <= 0, 150.0, 10.0)
    else:
        level = np.clip(150.0 - fall_db_per_deg * np.maximum(beyond, 0.0), 10.0, 150.0)
    level = np.where(np.isfinite(phi), level, 10.0)
    img = level[None, :, None] + rng.normal(0.0, 2.0, (N_FRAMES, g.n_bins, g.n_beams))
    return np.clip(img, 0, 255).astype(np.uint8)


def test_the_fall_of_a_soft_edge_is_measured_and_a_hard_edge_has_none() -> None:
    g = SonarGeometry.from_degrees(30.0, 14.0)
    pos, rot = _poses(N_FRAMES)
    rng = np.random.default_rng(11)
    soft, _, steps = frame_edge_profile(_soft_seabed(g, 5.0, 20.0, rng), g, pos, rot, *_flat(pos, 5.0),
                                        FALL_FRACTIONS)
    hard, _, _ = frame_edge_profile(_soft_seabed(g, 5.0, None, rng), g, pos, rot, *_flat(pos, 5.0), FALL_FRACTIONS)
    # 140 grey levels of step falling 20 per degree: the seabed reaches (0.5 - f) x 140 less 20 / deg further out
    extra = np.degrees(soft - soft[:, :1])
    expected = (0.5 - np.asarray(FALL_FRACTIONS)) * 140.0 / 20.0
    assert np.allclose(np.median(extra, axis=0), expected, atol=0.4), extra
    assert np.median(steps) == pytest.approx(140.0, abs=5.0)
    assert np.all(np.abs(np.degrees(hard - hard[:, :1])) < 0.4), np.degrees(hard)


def test_pattern_fall_places_brighter_reflectors_deeper_never_beyond_the_data() -> None:
    fall = PatternFall(window=100, min_frames=3)
    profile = np.radians([[7.0, 9.0, 11.0, 13.0]] * 2)
    fall.update(profile, np.array([160.0, 160.0]))
    assert not fall.ready and fall.extra(80.0) == 0.0  # too few frames: on the edge
    fall.update(profile[:1], np.array([160.0]))
    e = np.degrees(fall.extra(np.array([-20.0, 0.0, 20.0, 40.0, 50.0, 400.0, np.nan])))
    # f = 0.5 - E / 160: 0.5 (edge), 0.375 (+2 deg), 0.25 (+4), 0.1875 (+5), then the lowest fraction (+6) at most
    assert e == pytest.approx([0.0, 0.0, 2.0, 4.0, 5.0, 6.0, 0.0])


def test_the_mosaic_reads_an_object_brighter_than_the_seabed_where_it_lies() -> None:
    g = SonarGeometry.from_degrees(30.0, 14.0)
    alt = 5.0
    pos, rot = _poses(N_FRAMES)
    rng = np.random.default_rng(12)
    imgs = _soft_seabed(g, alt, None, rng).astype(np.float64)
    phi = _seabed_elevations(g, alt)
    row = int(np.nanargmin(np.abs(np.where(np.isfinite(phi), g.ranges, np.inf) - 9.0)))  # a patch at 9 m of range
    imgs[:, row - 15 : row + 15, 38:58] += 40.0  # 40 grey levels over the seabed, 0.6 m x 0.9 m
    onset = np.full((N_FRAMES, g.n_beams), float(g.ranges[np.flatnonzero(np.isfinite(phi))[0]]))
    mosaic = EchoMosaic()
    mosaic.add(np.clip(imgs, 0, 255).astype(np.uint8), g, onset, pos, rot, *_flat(pos, alt))
    d = g.directions_body(np.array([phi[row]]), np.array([0.0]))[0] * g.ranges[row] + g.mounting.lever
    here = np.array([[d[0], d[1], alt]])
    assert mosaic.excess(here) == pytest.approx(40.0, abs=6.0)
    away = here + np.array([0.0, 2.5, 0.0])  # seabed alone: its row's level
    assert abs(mosaic.excess(away)) < 6.0
    assert np.isnan(EchoMosaic().excess(here))


def test_points_below_the_edge_stay_below_it_through_the_front_slope_correction() -> None:
    """A cloud re-placed below the edge is raised to its own top, never back to the edge ray's."""
    half = np.radians(10.0)
    n = 40
    o = np.tile([0.0, 0.0, 0.0], (n, 1))
    u = np.tile([np.cos(np.radians(30.0)), 0.0, np.sin(np.radians(30.0))], (n, 1))
    w = np.tile([-np.sin(np.radians(30.0)), 0.0, np.cos(np.radians(30.0))], (n, 1))
    arcs = arc_record(o, u, w, np.linspace(6.0, 6.4, n))
    on_edge = points_at(arcs, half)
    below = points_at(arcs, half + np.radians(3.0))
    fixed = replace_on_arcs(below, arcs, 2.0 * half)
    assert fixed[:, 2].min() >= below[:, 2].min() - 1e-9  # no point above the lowered cloud's top
    assert fixed[:, 2].min() > on_edge[:, 2].min() + 0.1  # the top stays ~0.3 m below the edge ray's
