"""The DVL's seabed points: the altitude is measured along the DVL's beam-cone axis, which turns with the vehicle
(:func:`recon.frames.dvl_seabed_offsets`). A vehicle that pitches with a 10 deg slope measures the distance normal to
the seabed; taken as vertical it put the DVL's seabed points 0.08 m too shallow at 6 m of altitude (a random survey,
seed 9090 survey 15), and the seabed planes with them."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scenes import scene_toml

import recon.reconstructor as rp
from auvlink.evaluation.noncausal_reference import run_log_batch
from auvlink.pipeline.process import run_log
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene
from auvlink.sim.seabed import SeabedSurface
from recon.frames import Mounting, attitude, dvl_seabed_offsets, rdi_instrument_mounting


@settings(max_examples=60, deadline=None)
@given(slope=st.floats(0.0, 15.0), azimuth=st.floats(-180.0, 180.0), heading=st.floats(-180.0, 180.0),
       dist=st.floats(1.0, 30.0))
def test_a_vehicle_parallel_to_a_plane_finds_it(slope: float, azimuth: float, heading: float, dist: float) -> None:
    """The vehicle's down axis along the plane's normal, the altitude = the normal distance: the point is on it."""
    a, az, hd = math.radians(slope), math.radians(azimuth), math.radians(heading)
    grad = math.tan(a) * np.array([math.cos(az), math.sin(az)])  # d depth / d (north, east)
    normal_down = np.array([-grad[0], -grad[1], 1.0]) / math.sqrt(1.0 + grad @ grad)
    # the attitude whose body z is that normal, heading hd: pitch and roll from the normal in the heading frame
    c, s = math.cos(hd), math.sin(hd)
    fwd, right = c * normal_down[0] + s * normal_down[1], -s * normal_down[0] + c * normal_down[1]
    # R = Rz(yaw) Ry(pitch) Rx(roll): body z = (sin p cos r, -sin r, cos p cos r) in the heading frame
    roll = math.asin(-right)
    pitch = math.atan2(fwd, normal_down[2])
    rot = attitude(np.array([hd]), np.array([pitch]), np.array([roll]))
    assert np.allclose(rot.apply([0.0, 0.0, 1.0])[0], normal_down, atol=1e-9)
    off = dvl_seabed_offsets(rot, np.array([dist]), rdi_instrument_mounting())[0]
    # plane through (0, 0, d0) with depth = d0 + grad . xy; the vehicle at the origin is dist away along the normal
    d0 = dist * math.sqrt(1.0 + grad @ grad)
    assert off[2] == pytest.approx(d0 + grad @ off[:2], abs=1e-9)


def test_level_vehicle_lever_and_mountings() -> None:
    level = attitude(np.zeros(2), np.zeros(2), np.zeros(2))
    off = dvl_seabed_offsets(level, np.array([5.0, np.nan]), rdi_instrument_mounting((0.5, 0.0, 0.3)))
    assert np.allclose(off[0], [0.5, 0.0, 5.3])
    assert np.all(np.isnan(off[1, 2]))
    # an instrument frame whose Z points down (FRD-like) measures along the same axis as RDI's (Z up)
    assert np.allclose(dvl_seabed_offsets(level, np.array([5.0]), Mounting())[0], [0.0, 0.0, 5.0])


# two 20 m lines over an empty smooth seabed sloping 10 deg
SLOPED = scene_toml(seabed={"depth": 25.0, "slope_deg": 10.0, "slope_azimuth_deg": 30.0, "roughness": 0.0}, objects=[],
                    survey={"heading_deg": 30.0, "line_length": 20.0, "line_spacing": 4.0, "lines": 2,
                            "altitude": 6.0, "speed": 1.0},
                    sonar={"window_start": 2.0, "window_length": 14.0, "fps": 5.0})


@pytest.fixture(scope="module")
def sloped(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, SeabedSurface]:
    scene = loads_scene(SLOPED)
    path = tmp_path_factory.mktemp("dvl_slope") / "mission.mcap"
    simulate_to_log(scene, path, progress=False)
    return path, SeabedSurface(scene.seabed, scene.seed)


def _error(points: np.ndarray, seabed: SeabedSurface) -> np.ndarray:
    return np.asarray(points[:, 2] - seabed.depth(points[:, 0], points[:, 1]))


@pytest.mark.slow
def test_dvl_seabed_points_lie_on_a_sloped_seabed(sloped: tuple[Path, SeabedSurface],
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """Up and down a 10 deg slope at 6 m: the DVL's seabed points within a few cm of the seabed (batch and live
    paths); straight below the vehicle they would be ~0.09 m too shallow."""
    log, seabed = sloped
    _, traj = run_log_batch(log)
    batch = traj.seabed_points()
    err = _error(batch, seabed)
    assert batch.shape[0] > 100 and abs(float(np.median(err))) < 0.03, np.percentile(err, [5, 50, 95])
    below = replace(traj, seabed_offsets=None).seabed_points()  # straight below: the old placement, for contrast
    assert float(np.median(_error(below, seabed))) < -0.05
    seen: list[np.ndarray] = []
    orig = rp.Reconstructor.add_seabed_points

    def spy(self: rp.Reconstructor, points: np.ndarray) -> None:
        seen.append(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        orig(self, points)

    monkeypatch.setattr(rp.Reconstructor, "add_seabed_points", spy)
    run_log(log, classify=False, progress=False)
    live = np.concatenate(seen)
    err = _error(live, seabed)
    assert live.shape[0] > 100 and abs(float(np.median(err))) < 0.03, np.percentile(err, [5, 50, 95])
