"""Frames while the vehicle turns at a line end are skipped and counted (``EngineConfig.max_turn_rate_deg_s``):
on a rough, sloped seabed the fan sweeps sideways over seabed the fit ahead does not know, and turns made
trails of false objects (a random survey of 6 objects, seed 1234 survey 37, gave 15 detections, 8 of them
in two turns; with the turns skipped 6). Here: only the turn is skipped, and nothing false comes from it.

An empty rough slope (0.07 m rough, 9.9 deg slope) reports nothing: the seabed samples of the first metres, taken
while the fitted seabed does not know the slope yet, are sought at the seabed's own level (recon.onset_stage), so
they lie on the seabed and no later return stands high above them. The texture grid is fitted to the seabed returns
alone (recon.seabed_texture.TextureConfig.highlights), so a crest's highlight points may stand over it as a low
cluster; the classifier calls it clutter."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scenes import scene_toml

from auvlink.pipeline.engine_config import EngineConfig
from auvlink.pipeline.process import FRAME_BLOCK, run_log
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene
from recon.target_envelope import LOWEST_OBJECT_M

SCENE_SPEED, SCENE_LINE, SCENE_SPACING = 0.75, 16.0, 2.1  # m/s, m, m (the survey below)

pytestmark = pytest.mark.slow

pytest.importorskip("open3d")

# two 16 m lines and a turn over an empty rough seabed sloping 9.9 deg
SCENE = scene_toml(seed=37, seabed={"depth": 30.0, "slope_deg": 9.9, "slope_azimuth_deg": 250.0, "roughness": 0.07},
                   objects=[], survey={"heading_deg": 137.6, "line_length": SCENE_LINE, "line_spacing": SCENE_SPACING,
                                       "lines": 2, "altitude": 5.9, "speed": SCENE_SPEED},
                   sonar={"tilt_deg": 26.0, "window_start": 2.0, "window_length": 14.0, "fps": 6.5})


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("turns") / "mission.mcap"
    simulate_to_log(loads_scene(SCENE), path, progress=False)
    return path


def test_turn_frames_are_skipped_and_counted(log: Path) -> None:
    base = EngineConfig(frame_block=FRAME_BLOCK)
    res = run_log(log, classify=False, progress=False, engine_config=base)
    turning = res.recon_stats["frames_turning"]
    frames = res.recon_stats["frames"]
    # a U-turn onto a line 2.1 m over at 0.75 m/s: several seconds at 6.5 frames/s, not the lines (2 x 21 s)
    assert 10 <= turning <= 0.5 * frames, (turning, frames)
    # the U-turn (a half circle between the lines, after line 1) in mission time
    turn = (SCENE_LINE / SCENE_SPEED, (SCENE_LINE + 0.5 * np.pi * SCENE_SPACING) / SCENE_SPEED)
    near_turn = [d for d in res.detections
                 if any(a - res.t0 <= turn[1] and b - res.t0 >= turn[0] for a, b in d.passes)]
    assert near_turn == [], [(d.class_name, d.position_ned, d.passes) for d in near_turn]
    off = run_log(log, classify=False, progress=False, engine_config=replace(base, max_turn_rate_deg_s=1e9))
    assert off.recon_stats["frames_turning"] == 0
    assert off.recon_stats["frames_processed"] == res.recon_stats["frames_processed"] + turning


def test_an_empty_rough_slope_reports_nothing(log: Path) -> None:
    res = run_log(log, classify=True, progress=False, engine_config=EngineConfig(frame_block=FRAME_BLOCK))
    assert res.detections == [], [(d.class_name, d.position_ned) for d in res.detections]
    clusters = run_log(log, classify=False, progress=False, engine_config=EngineConfig(frame_block=FRAME_BLOCK))
    # at most a crest, lower than the lowest object
    assert len(clusters.detections) <= 1, [(d.position_ned, d.size) for d in clusters.detections]
    assert all(d.size[2] < LOWEST_OBJECT_M for d in clusters.detections), [d.size for d in clusters.detections]
