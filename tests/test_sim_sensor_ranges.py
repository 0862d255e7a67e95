"""Simulated sensors report what real ones do in a steep dive (issue 34's random scenes), where ``auvlink sim``
stopped at an encoder:

- the DVL finds no bottom beyond its range: a dive at 4.8 m/s down and 0.8 m/s ahead turns a beam near the
  horizontal, whose seabed hit hundreds of metres away no DVL reports (PD0 bottom-track range 380 km); every
  ping encodes, a beam beyond the Workhorse's 90 m is a ping without bottom track;
- the AHRS reports pitch in [-90, 90] deg: noise on a vertical dive (3 m/s down from 8 m away) went past
  -90 deg, out of the CAN ATTITUDE signal's range; the same attitude as canonical Euler angles encodes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from auvlink.codecs import can_nav, pd0
from auvlink.sim.dvl import MAX_BOTTOM_RANGE_M, pd0_ensemble
from auvlink.sim.emit import ahrs_euler
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


@pytest.mark.slow
def test_a_steep_dive_gives_pings_without_bottom_not_a_380_km_range() -> None:
    run = prepare(loads_scene(SCENE), None, 40.0)
    dvl = run.measurements.dvl
    assert np.nanmax(dvl.range_m) <= MAX_BOTTOM_RANGE_M
    assert (~dvl.valid).any() and dvl.valid.mean() > 0.5  # the dive loses the bottom, the survey has it
    for k in range(len(dvl)):
        raw = pd0.encode(pd0_ensemble(dvl, k, run.settings.sensors.start_ns * 1e-9))
        assert pd0.decode(raw) is not None


VERTICAL_DIVE = """seed = 783554404
[seabed]
depth = 18.79
slope_deg = 6.44
slope_azimuth_deg = 60.9
roughness = 0.0364
[[objects]]
class = "box"
position = [315.770, 387.170]
heading_deg = 285.9
[[objects]]
class = "half_pipe"
position = [306.670, 388.020]
heading_deg = 290.3
[survey]
pattern = "lawnmower"
origin = [328.257, 381.389]
heading_deg = 157.8
line_length = 38.3
line_spacing = 2.421
lines = 2
altitude = 4.59
speed = 1.495
[sonar]
tilt_deg = 37.42
spread_deg = 14.0
window_start = 0.5
window_length = 10.44
fps = 9.22
lever_arm = [0.6, 0.0, 0.2]
[vehicle]
current = [0.0194, -0.0367]
[site]
latitude = 2.684075
longitude = -107.296550
[gnss]
rate_hz = 5.03
sigma_m = 2.972
wait_before_s = 9.4
wait_after_s = 28.2
lever_arm = [-0.56, -0.51, -0.09]
vertical_rate = 3.01
quality = 1
satellites = 57
hdop = 0.68
start_offset = [7.84, -3.04]
"""


@pytest.mark.slow
def test_a_vertical_dive_gives_attitudes_within_plus_minus_90_deg_pitch() -> None:
    ahrs = prepare(loads_scene(VERTICAL_DIVE), None, 35.0).measurements.ahrs
    assert (np.abs(ahrs.pitch) > math.pi / 2).any()  # the case: the noise past the vertical
    for k in range(len(ahrs.t)):
        h, p, r = ahrs_euler(float(ahrs.heading[k]), float(ahrs.pitch[k]), float(ahrs.roll[k]))
        assert abs(p) <= math.pi / 2 and 0.0 <= h <= 2.0 * math.pi
        same = Rotation.from_euler("ZYX", [h, p, r]).inv() * \
            Rotation.from_euler("ZYX", [ahrs.heading[k], ahrs.pitch[k], ahrs.roll[k]])
        assert same.magnitude() < 1e-9  # the same attitude
        raw = can_nav.encode(can_nav.CanNavRecord(306, "ATTITUDE", {"heading": h, "pitch": p, "roll": r,
                                                                     "counter": k % 256, "valid": 1}))
        assert isinstance(can_nav.decode(raw), can_nav.CanNavRecord)
