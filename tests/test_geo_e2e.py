"""Where on Earth, end to end: a survey 250 m south-west of the datum, simulated with GNSS fixes before the
dive and after surfacing, replayed; every detection in detections.geojson within 1 m of its true latitude /
longitude, computed here from the datum with pymap3d (independent of the pipeline's PROJ path). Without
[gnss] the outputs say that positions are relative to the first navigation sample."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pymap3d
import pytest
from scenes import obj, scene_toml

from auvlink.pipeline.outputs import write_outputs
from auvlink.pipeline.process import run_log
from auvlink.pipeline.results import MissionResult
from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import loads_scene

SITE = (36.0412, 129.3915)
HEADING = 225.0  # south-west
F = np.array([math.cos(math.radians(HEADING)), math.sin(math.radians(HEADING))])
S = np.array([-F[1], F[0]])  # starboard
ORIGIN = 250.0 * F  # the first line starts 250 m from the datum
OBJECTS = (("sphere", 15.0, 0.3), ("box", 24.0, -0.4), ("reef_b", 34.0, 0.2))


def truth_ne() -> np.ndarray:
    return np.array([ORIGIN + along * F + across * S for _, along, across in OBJECTS])


def scene_text(gnss: bool) -> str:
    """One 45 m line south-west across a current at the site, over :data:`OBJECTS`; with or without GNSS."""
    objects = [obj(c, round(p[0], 4), round(p[1], 4), 20.0) for (c, _, _), p in zip(OBJECTS, truth_ne(), strict=True)]
    gnss_table = {"rate_hz": 2.0, "sigma_m": 0.3, "wait_before_s": 8.0, "wait_after_s": 6.0,
                  "start_offset": [14.0, 10.0], "vertical_rate": 0.8}
    return scene_toml(site={"latitude": SITE[0], "longitude": SITE[1]},
                      seabed={"depth": 12.0, "slope_deg": None, "slope_azimuth_deg": None}, objects=objects,
                      survey={"origin": [round(ORIGIN[0], 4), round(ORIGIN[1], 4)], "heading_deg": HEADING,
                              "line_length": 45.0},
                      vehicle={"current": [0.12, -0.08]}, gnss=gnss_table if gnss else None)


def run(tmp: Path, gnss: bool) -> tuple[Path, MissionResult, dict]:
    scene_path = tmp / "scene.toml"
    scene_path.write_text(scene_text(gnss))
    scene = loads_scene(scene_path.read_text(), source=str(scene_path))
    simulate_to_log(scene, tmp / "m.mcap", progress=False, workers=1)
    result = run_log(tmp / "m.mcap", progress=False)
    out = tmp / "out"
    summary = write_outputs(result, out)
    return out, result, summary


@pytest.fixture(scope="module")
def with_gnss(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, MissionResult, dict]:
    return run(tmp_path_factory.mktemp("geo"), gnss=True)


@pytest.mark.slow
def test_every_detection_within_1_m_of_its_true_lat_lon(with_gnss: tuple[Path, MissionResult, dict]) -> None:
    out, _, summary = with_gnss
    geo = json.loads((out / "detections.geojson").read_text())
    assert geo["type"] == "FeatureCollection" and "crs" not in geo
    ne = truth_ne()
    lat_t, lon_t, _ = pymap3d.ned2geodetic(ne[:, 0], ne[:, 1], np.zeros(len(ne)), SITE[0], SITE[1], 0.0)
    found = {}
    for f in geo["features"]:
        assert f["geometry"]["type"] == "Point"
        lon, lat = f["geometry"]["coordinates"]  # RFC 7946: [lon, lat]
        # each detection against every true object, metres on the local plane at the object (pymap3d)
        n, e, _ = pymap3d.geodetic2ned(lat, lon, 0.0, lat_t, lon_t, 0.0)
        d = np.hypot(n, e)
        k = int(np.argmin(d))
        assert d[k] < 1.0, (f["properties"], d)
        found[k] = f["properties"]["class"]
        assert set(f["properties"]) >= {"id", "class", "score", "depth", "size", "n_points", "t_first", "t_last"}
    assert sorted(found) == [0, 1, 2], found  # every object found
    g = summary["georef"]
    assert g["frame"] == "site" and g["georeferenced"] and g["fixes"]["used_before_dive"] >= 10
    assert g["closure_m"] is not None and g["fixes"]["used_after_surfacing"] >= 8
    assert g["fixes"]["no_fix"] > 0  # the receiver's quality-0 sentences under water, counted, not used


@pytest.mark.slow
def test_outputs_a_gis_opens(with_gnss: tuple[Path, MissionResult, dict]) -> None:
    out, result, _ = with_gnss
    lines = [json.loads(x) for x in (out / "detections.jsonl").read_text().splitlines()]
    assert len(lines) == len(OBJECTS) and all(d["frame"] == "site" for d in lines)
    # near the datum, not anywhere on Earth: the objects lie 250-290 m from it (0.0026 deg of latitude)
    assert all(abs(d["lat"] - SITE[0]) < 0.004 and abs(d["lon"] - SITE[1]) < 0.004 for d in lines), lines
    rows = (out / "track.csv").read_text().splitlines()
    assert rows[0] == "time,lat,lon,north,east,depth,altitude,heading,correction_north,correction_east"
    last = rows[-1].split(",")
    assert last[0].endswith("Z") and float(last[1]) == pytest.approx(SITE[0], abs=0.01)
    track = json.loads((out / "track.geojson").read_text())
    line = track["features"][0]["geometry"]
    assert line["type"] == "LineString" and len(line["coordinates"]) > 100
    assert (out / "detections.kml").read_text().count("<Placemark") == len(lines) + 1
    # the corrected track ends on the fixes after surfacing (within their noise)
    fixes = result.track_info["fixes"]
    end = np.array([float(last[3]), float(last[4])])
    assert np.linalg.norm(fixes[-5:, 1:].mean(axis=0) - end) < 1.0


@pytest.mark.slow
def test_without_gnss_the_outputs_say_positions_are_relative(tmp_path: Path) -> None:
    out, _, summary = run(tmp_path, gnss=False)
    g = summary["georef"]
    assert g["frame"] == "first_navigation_sample" and not g["georeferenced"]
    assert "relative to the first navigation sample" in g["positions"]
    assert not (out / "detections.geojson").exists()
    lines = [json.loads(x) for x in (out / "detections.jsonl").read_text().splitlines()]
    assert lines and all(d["frame"] == "first_navigation_sample" and "lat" not in d for d in lines)


def test_scoring_goes_through_lat_lon_when_the_datums_differ() -> None:
    from auvlink.geodesy import Datum
    from auvlink.pipeline.results import Detection
    from auvlink.pipeline.setup import MissionSetup, TruthObject
    from auvlink.pipeline.truth_scores import score_detections

    site, other = Datum(*SITE), Datum(36.0400, 129.3900)  # the simulator's datum, the run's (e.g. a first fix)
    ne = np.array([[10.0, 5.0], [-20.0, 3.0]])
    lat, lon, _ = site.to_geodetic(np.column_stack([ne, np.zeros(2)]))
    truth = tuple(TruthObject("box", (n, e, 10.0), 0.0, float(a), float(b))
                  for (n, e), a, b in zip(ne, lat, lon, strict=True))
    dets = [Detection(i, "box", 1.0, (float(p[0]), float(p[1]), 10.0), (1.0, 1.0, 1.0), 10, 0.0, 1.0,
                      np.zeros((0, 3))) for i, p in enumerate(other.to_ned(lat, lon))]
    res = MissionResult(None, MissionSetup(truth=truth), dets, np.zeros((0, 3)),
                        georef={"georeferenced": True, "datum": other.to_dict()})
    s = score_detections(res)
    assert s is not None and s["matched"] == 2 and s["centroid_error_mean_m"] < 1e-3
    res.georef = {}  # no georeference: the stored NED, another frame: nothing matches
    s = score_detections(res)
    assert s is not None and s["matched"] == 0
