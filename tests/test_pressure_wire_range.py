"""A pressure sensor reports what it reads, below zero included (issue 34): the CAN navigation bus's PRESSURE
signal, the Keller F73 response and the Paroscientific line carry a negative reading, and the scene of the issue
(seed 9204, whose simulated pressure goes below 0 Pa and stopped ``auvlink sim`` at the CAN encoder)
simulates into a log whose PRESSURE frames decode to the simulated values."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from auvlink.codecs import can_nav, keller, paro
from auvlink.sim.mission import prepare, simulate_to_log
from auvlink.sim.scene import loads_scene
from logs_format import MissionLogReader

SCENE_9204 = """seed = 9204
[site]
latitude = 27.64687
longitude = 123.93789
[seabed]
depth = 12.31
slope_deg = 6.05
slope_azimuth_deg = 197.3
roughness = 0.025
[[objects]]
class = "pipe"
position = [257.52, -137.73]
heading_deg = 29.1
[[objects]]
class = "reef_b"
position = [244.14, -143.08]
heading_deg = 52.2
[[objects]]
class = "box"
position = [246.8, -122.31]
heading_deg = 313.2
[[objects]]
class = "reef_c"
position = [231.17, -120.61]
heading_deg = 225.5
[[objects]]
class = "pipe"
position = [212.0, -142.3]
heading_deg = 210.7
[[objects]]
class = "pipe"
position = [246.69, -130.59]
heading_deg = 27.8
[[objects]]
class = "reef_b"
position = [255.92, -123.23]
heading_deg = 34.2
[[objects]]
class = "reef_a"
position = [237.49, -117.08]
heading_deg = 39.1
[survey]
pattern = "lawnmower"
origin = [196.04, -158.93]
heading_deg = 14.7
line_length = 71.1
line_spacing = 2.57
lines = 15
altitude = 4.49
speed = 1.28
[sonar]
tilt_deg = 37.4
spread_deg = 14.0
window_start = 1.09
window_length = 8.0
fps = 15.0

[gnss]
"""
#: the first minute of the mission holds readings below 0 Pa (the first at 58.7 s: PRESSURE counter 75)
DURATION_S = 62.0


@given(st.floats(-2.0e5, 0.0))
def test_can_pressure_carries_a_negative_reading(pa: float) -> None:
    rec = can_nav.CanNavRecord(320, "PRESSURE", {"pressure": pa, "temperature_c": 10.0, "counter": 75})
    back = can_nav.decode(can_nav.encode(rec))
    assert isinstance(back, can_nav.CanNavRecord)
    assert back.signals["pressure"] == round(pa)  # the DBC's 1 Pa resolution


@pytest.mark.parametrize("pa", [-108.09, -2500.0, -101325.0])
def test_keller_and_paro_carry_a_negative_reading(pa: float) -> None:
    req = keller.KellerReadRequest(1, keller.CH_P1)
    resp = keller.decode(keller.encode(keller.build_pressure_response(1, pa)))
    assert isinstance(resp, keller.KellerReadResponse)
    assert keller.pair(req, resp).pressure_pa == pytest.approx(pa, rel=1e-6)  # IEEE float32 bar
    line = paro.decode(paro.encode(paro.build_reading(pa)))
    assert line.pressure_pa == pytest.approx(pa, abs=0.04)  # 5 decimals of psi


@pytest.mark.slow
def test_the_scene_of_issue_34_simulates_its_negative_pressure_into_the_log(tmp_path: Path) -> None:
    scene = loads_scene(SCENE_9204)
    expected = prepare(scene, None, DURATION_S).measurements.pressure.pressure_pa
    assert expected.min() < 0.0  # the case: readings below 0 Pa
    log = simulate_to_log(scene, tmp_path / "m.mcap", progress=False, duration=DURATION_S, workers=1).path
    with MissionLogReader(log) as r:
        got = [can_nav.decode(m.data) for m in r.messages(channels=["can"])]
    pressure = np.array([g.signals["pressure"] for g in got if g.name == "PRESSURE"])
    assert pressure.size == expected.size
    assert np.abs(pressure - expected).max() <= 0.5  # 1 Pa resolution, negative readings included
