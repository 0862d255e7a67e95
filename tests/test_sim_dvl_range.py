"""The simulated DVL finds no bottom beyond its range (issue 34's random scenes): a steep dive (4.8 m/s down at
0.8 m/s ahead) turns a beam near the horizontal, whose seabed hit hundreds of metres away no DVL reports; it stopped
``auvlink sim`` at the PD0 encoder (bottom-track range 380 km). Every ping encodes, and a beam beyond the
Workhorse's 90 m is a ping without bottom track."""

from __future__ import annotations

import numpy as np

from auvlink.codecs import pd0
from auvlink.sim.dvl import MAX_BOTTOM_RANGE_M, pd0_ensemble
from auvlink.sim.mission import prepare
from auvlink.sim.scene import loads_scene

SCENE = """seed = 1
[seabed]
depth = 35.61
slope_deg = 6.71
slope_azimuth_deg = 188.9
[survey]
origin = [0.0, 0.0]
heading_deg = 315.1
line_length = 39.0
line_spacing = 1.706
lines = 2
altitude = 4.31
speed = 0.816
[sonar]
tilt_deg = 34.35
window_start = 0.82
window_length = 8.74
fps = 5.0
[gnss]
wait_before_s = 4.0
wait_after_s = 4.0
vertical_rate = 4.76
start_offset = [-18.94, 23.72]
"""


def test_a_steep_dive_gives_pings_without_bottom_not_a_380_km_range() -> None:
    run = prepare(loads_scene(SCENE), None, 40.0)
    dvl = run.measurements.dvl
    assert np.nanmax(dvl.range_m) <= MAX_BOTTOM_RANGE_M
    assert (~dvl.valid).any() and dvl.valid.mean() > 0.5  # the dive loses the bottom, the survey has it
    for k in range(len(dvl)):
        raw = pd0.encode(pd0_ensemble(dvl, k, run.settings.sensors.start_ns * 1e-9))
        assert pd0.decode(raw) is not None
