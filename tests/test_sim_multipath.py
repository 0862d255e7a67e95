"""Surface multipath of the realistic acoustic model: each echo's ghost over the sea surface, in shallow water."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.sim.acoustic_image import AcousticImager
from auvlink.sim.acoustics import AcousticsTable, resolve
from auvlink.sim.scene import Scene, load_default_scene
from auvlink.sim.sonar_render import RayHits, SonarRenderer, surface_paths


def _scene(depth: float, multipath_db: float) -> Scene:
    """The default scene without objects over a level smooth seabed ``depth`` m deep (the sonar 5 m above it, at the
    body origin), under the didson profile with no pulse and the given multipath level."""
    s = load_default_scene()
    table = AcousticsTable(profile="didson", pulse_m=0.0, multipath_db=multipath_db)
    return replace(s, objects=(), acoustics=table, seabed=replace(s.seabed, depth=depth, slope_deg=0.0, roughness=0.0),
                   sonar=replace(s.sonar, lever_arm=(0.0, 0.0, 0.0)))


@dataclass(frozen=True)
class Frame:
    """The level frame at the start of the first line: its renderer, hits and the samples' inputs (seabed only)."""

    rd: SonarRenderer
    imager: AcousticImager
    hits: RayHits
    cos2: np.ndarray
    diffuse: np.ndarray

    @classmethod
    def of(cls, scene: Scene) -> Frame:
        rd = SonarRenderer(scene, speckle=False)
        hits = rd.trace(np.array([0.0, 0.0, scene.seabed.depth - scene.survey.altitude]), 0.0, 0.0, 0.0)
        assert rd.imager is not None
        cos2 = np.where(np.isfinite(hits.range), hits.intensity * hits.range**2 / rd.seabed_gain, 0.0)
        return cls(rd, rd.imager, hits, cos2, np.full(hits.range.size, rd.imager.mu))

    def expected(self, with_ghosts: bool = True) -> np.ndarray:
        """Expected energy (no speckle), with or without the surface ghosts."""
        paths = surface_paths(self.hits) if with_ghosts else None
        surface = np.full(self.hits.range.size, -1, np.int32)
        return self.imager.expected(self.hits.range, self.cos2, self.diffuse, surface, paths)


def test_surface_path_is_the_distance_from_the_sonars_image_above_the_surface() -> None:
    """The sonar 4 m deep, a hit 9 m deep 6 m ahead: direct 7.81 m, over the surface 14.32 m (the geometry)."""
    d = np.array([[6.0, 0.0, 5.0]]) / np.hypot(6.0, 5.0)
    hits = RayHits(np.array([0.0, 0.0, 4.0]), d.T, np.array([np.hypot(6.0, 5.0)]), np.ones(1),
                   np.ones(1, np.int8), np.full(1, -1, np.int32))
    assert surface_paths(hits)[0] == pytest.approx(np.hypot(6.0, 13.0))


def test_off_and_deep_water_leave_the_image_as_it_was() -> None:
    """-100 dB, or a seabed so deep that every ghost falls past the window: byte-identical energy."""
    for frame in (Frame.of(_scene(9.0, -100.0)), Frame.of(_scene(40.0, -20.0))):
        assert np.array_equal(frame.expected(), frame.expected(with_ghosts=False))


def test_shallow_water_ghost_lies_at_the_mixed_paths_range() -> None:
    """9 m of water, the sonar 4 m deep: the seabed band's ghost adds energy only, none nearer than the nearest
    sample's ``(r + r_s) / 2``, centred (energy-weighted) on the samples' ghost ranges within two bins."""
    frame = Frame.of(_scene(9.0, -20.0))
    on = frame.expected()
    ghost = on - frame.expected(with_ghosts=False)
    assert ghost.min() >= -1e-6 * on.max()
    g = frame.rd.geometry
    rows = g.range_of_bin
    w = ghost.sum(axis=1)
    assert w.sum() > 0.0
    # the prediction: each sample's ghost energy at its own ghost range
    hits = frame.hits
    e = frame.imager.sample_energy(hits.range, frame.cos2, frame.diffuse, np.zeros(hits.range.size, bool))
    got = frame.imager.ghosts(hits.range, e, surface_paths(hits))
    assert got is not None
    r_g, e_g = got
    inside = np.isfinite(r_g)
    assert rows[w > 1e-3 * w.max()].min() >= r_g[inside].min() - 2.0 * g.bin_width  # none nearer than predicted
    predicted = float(np.sum(r_g[inside] * e_g[inside]) / np.sum(e_g[inside]))
    assert float(np.sum(rows * w) / w.sum()) == pytest.approx(predicted, abs=2.0 * g.bin_width)


@settings(max_examples=25, deadline=None)
@given(r=st.floats(1.0, 11.0), extra=st.floats(0.0, 12.0), level_db=st.floats(-60.0, -10.0))
def test_ghost_level_follows_spreading_and_the_tvg(r: float, extra: float, level_db: float) -> None:
    """A sample's ghost: ``multipath_db`` x ``(r / r_s)^2`` x ``(r_g / r)^3`` of its energy, at ``r_g``."""
    table = AcousticsTable(profile="didson", multipath_db=level_db)
    scene = replace(load_default_scene(), acoustics=table)
    rd = SonarRenderer(scene, speckle=False)
    assert rd.imager is not None and resolve(table) is not None
    r_s = r + extra
    got = rd.imager.ghosts(np.array([r]), np.array([2.0]), np.array([r_s]))
    r_g = 0.5 * (r + r_s)
    window_end = rd.imager.g.window_start + rd.imager.g.n_bins * rd.imager.g.bin_width
    if r_g >= window_end:
        assert got is None
        return
    assert got is not None
    assert got[0][0] == pytest.approx(r_g)
    assert got[1][0] == pytest.approx(2.0 * 10.0 ** (level_db / 10.0) * (r / r_s) ** 2 * (r_g / r) ** 3)
