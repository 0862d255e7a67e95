"""The simulator at the surface: wait with GNSS fixes, dive on the way to the first line, survey, climb, fixes
again; the receiver's NMEA sentences (fix quality 0 under water); the datum in the log's truth."""

from __future__ import annotations

import math

import numpy as np
import pymap3d
import pytest
from scenes import scene_toml

from auvlink.codecs import nmea
from auvlink.errors import ConfigError
from auvlink.sim.emit import block_events
from auvlink.sim.mission import prepare
from auvlink.sim.scene import loads_scene
from auvlink.sim.trajectory import LawnmowerTrajectory

# two lines south-west, 250 m from the datum, with a GNSS receiver fixing at the surface before and after
SCENE = scene_toml(seed=4, site={"latitude": 36.0412, "longitude": 129.3915},
                   seabed={"depth": 14.0, "slope_deg": 1.0, "roughness": None}, objects=[],
                   survey={"origin": [-180.0, -160.0], "heading_deg": 225.0, "line_length": 30.0, "lines": 2},
                   sonar={"fps": 2.0}, vehicle={"current": [0.1, -0.05]},
                   gnss={"rate_hz": 2.0, "sigma_m": 0.0, "start_offset": [12.0, 9.0], "wait_before_s": 6.0,
                         "wait_after_s": 5.0})


def test_phases_are_continuous_and_start_at_the_offset() -> None:
    scene = loads_scene(SCENE)
    tr = LawnmowerTrajectory.from_scene(scene)
    sp = tr.surface
    assert sp is not None and tr.survey_start == sp.t_survey
    t = np.arange(0.0, tr.duration, 0.005)
    p = tr.true_pose(t)
    start = tr.line_start(0)
    wait = t < sp.t_wait0
    assert np.allclose(p.position[wait, :2], start + [12.0, 9.0]) and np.all(p.depth[wait] == 0.0)
    assert np.all(p.depth[t > sp.t_surfaced] == 0.0)
    assert np.abs(np.diff(p.position, axis=0)).max() <= 1.5 * 0.005 + 1e-9  # no jump anywhere
    dyaw = np.angle(np.exp(1j * np.diff(p.yaw)))
    assert np.abs(dyaw).max() < math.radians(1.0)  # no heading jump, not even when it moves off
    survey = (t >= sp.t_survey) & (t <= sp.t_climb0)
    assert np.allclose(p.altitude[survey], 5.0, atol=0.1)
    assert p.depth.max() == pytest.approx(p.depth[survey].max(), abs=1e-3)  # never deeper than the survey


def test_fixes_at_the_surface_only_and_exact_without_noise() -> None:
    run = prepare(loads_scene(SCENE))
    g = run.measurements.gnss
    assert g is not None and len(g) == math.ceil(run.duration * 2.0)
    pose = run.trajectory.true_pose(g.t)
    antenna = pose.position + pose.rotation().apply([0.0, 0.0, -0.5])
    assert np.array_equal(g.valid, antenna[:, 2] <= 0.0)
    assert g.valid[g.t < 6.0].all() and not g.valid[(g.t > 20) & (g.t < 60)].any() and g.valid[-3:].all()
    lat, lon, _ = pymap3d.ned2geodetic(antenna[:, 0], antenna[:, 1], antenna[:, 2], 36.0412, 129.3915, 0.0)
    ok = g.valid
    assert np.abs(lat[ok] - g.latitude[ok]).max() * 111e3 < 1e-3
    assert np.abs(lon[ok] - g.longitude[ok]).max() * 111e3 * math.cos(math.radians(36.04)) < 1e-3
    assert np.isnan(g.latitude[~ok]).all()


def test_receiver_sentences_and_quality_zero_under_water() -> None:
    run = prepare(loads_scene(SCENE))
    events = [e for e in block_events(run.measurements, 0.0, run.duration + 1, None) if e[3] == "gnss"]
    recs = [nmea.decode(e[4]) for e in events]
    gga = [r for r in recs if isinstance(r, nmea.GgaFix)]
    rmc = [r for r in recs if isinstance(r, nmea.RmcFix)]
    assert len(gga) == len(rmc) == len(run.measurements.gnss)  # type: ignore[arg-type]
    assert sum(isinstance(r, nmea.ZdaTime) for r in recs) == len(gga)
    has = np.array([r.has_fix for r in gga])
    assert np.array_equal(has, run.measurements.gnss.valid)  # type: ignore[union-attr]
    assert all(r.quality == 0 for r in gga if not r.has_fix) and all(r.quality == 2 for r in gga if r.has_fix)
    starts = run.settings.sensors.start_ns * 1e-9
    assert rmc[3].utc == pytest.approx(starts + 1.5, abs=0.006)


def test_gnss_table_errors() -> None:
    with pytest.raises(ConfigError, match=r"gnss\.rate_hz"):
        loads_scene(SCENE.replace("rate_hz = 2.0", "rate_hz = 50.0"))
    with pytest.raises(ConfigError, match=r"gnss\.start_offset"):
        loads_scene(SCENE.replace("start_offset = [12.0, 9.0]", "start_offset = [1.0, 1.0]"))
    assert loads_scene(SCENE.replace("[gnss]", "[gnss]\nenabled = false")).gnss is None
