"""A small simulated mission (one 40 m line over a pipe and a reef, about 27 s; ~2 s to simulate)."""

from __future__ import annotations

from pathlib import Path

from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene

SCENE = """
seed = 11
[seabed]
depth = 20.0
slope_deg = 0.0
slope_azimuth_deg = 0.0
roughness = 0.02
[[objects]]
class = "pipe"
position = [16.0, 0.3]
heading_deg = 60.0
[[objects]]
class = "reef_c"
position = [30.0, -0.3]
heading_deg = 0.0
[survey]
pattern = "lawnmower"
origin = [0.0, 0.0]
heading_deg = 0.0
line_length = 40.0
line_spacing = 3.5
lines = 1
altitude = 5.0
speed = 1.5
[sonar]
tilt_deg = 30.0
spread_deg = 14.0
window_start = 1.0
window_length = 10.0
fps = 10.0
"""
TRUTH = {"pipe": (16.0, 0.3), "reef_c": (30.0, -0.3)}


def simulate_small(path: Path) -> Path:
    """Simulate the mission into ``path`` (a mission log) and return it."""
    simulate_to_log(loads_scene(SCENE), path, progress=False)
    return path
