"""The catalogue in geographic coordinates: missions georeferenced on different datums merge by
latitude/longitude, each mission's coverage moves to the catalogue's frame, and the files hold
``[lon, lat]`` (checked against an independent conversion by pymap3d)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely

from auvlink.geodesy import Datum
from auvlink.pipeline.catalogue import MissionData, build_catalogue
from auvlink.pipeline.catalogue_io import write_catalogue

pm = pytest.importorskip("pymap3d", reason="pymap3d (dev dependency) is the independent geodesy check")

D0 = (36.0412, 129.3915)  # Jangil Bay, Pohang
OBJECTS = {"sphere": (30.0, 5.0), "box": (60.0, -5.0), "pipe": (90.0, 5.0)}  # NED of D0, m


def _mission(name: str, day: int, datum: tuple[float, float], classes: list[str]) -> MissionData:
    d = Datum(*datum)
    offset = Datum(*D0).to_ned(*datum)[0]  # where this mission's datum lies in D0's frame
    dets = []
    for i, c in enumerate(classes):
        n, e = OBJECTS[c]
        lat, lon, _ = Datum(*D0).to_geodetic([n, e, 20.0])
        local = d.to_ned(lat, lon)[0]
        dets.append({"id": i, "class": c, "score": 0.9, "north": local[0], "east": local[1], "depth": 20.0,
                     "lat": float(lat[0]), "lon": float(lon[0])})
    # the survey box (0..120 north, -10..10 east of D0) in this mission's own frame
    cover = shapely.box(-10.0 - offset[1], 0.0 - offset[0], 10.0 - offset[1], 120.0 - offset[0])
    return MissionData(name, day * 86_400 * 10**9, dets, cover, datum, georeferenced=True)


def test_missions_on_different_datums_merge_by_latlon(tmp_path: Path) -> None:
    lat1, lon1, _ = Datum(*D0).to_geodetic([250.0, -250.0, 0.0])  # a datum 354 m north-west
    d1 = (float(lat1[0]), float(lon1[0]))
    missions = [_mission("a", 1, D0, ["sphere", "box", "pipe"]), _mission("b", 2, d1, ["sphere", "box", "pipe"]),
                _mission("c", 3, d1, ["sphere", "pipe"])]
    cat = build_catalogue(missions)
    assert cat.frame.geographic and cat.frame.datum == D0
    assert {o.class_name: o.status for o in cat.objects} == {"sphere": "stable", "box": "missing", "pipe": "stable"}
    for o in cat.objects:
        n, e = OBJECTS[o.class_name]
        assert (o.north, o.east) == pytest.approx((n, e), abs=1e-3)  # mm: lat/lon of points 20 m deep
        assert o.spread()[1] < 1e-3 and o.covering == ["a", "b", "c"]
    # coverage of b and c moved into D0's frame: the same box, to the 1 cm the test's construction neglects
    # (it shifts the box between two tangent planes 354 m apart, which are also tilted by 56 urad)
    assert cat.coverage["c"].hausdorff_distance(shapely.box(-10, 0, 10, 120)) < 0.01
    write_catalogue(cat, tmp_path)
    gj = json.loads((tmp_path / "catalogue.geojson").read_text())
    assert gj["frame"].startswith("WGS84")
    for f in gj["features"]:
        n, e = OBJECTS[f["properties"]["class"]]
        lat, lon, _ = pm.ned2geodetic(n, e, 0.0, D0[0], D0[1], 0.0)
        assert f["geometry"]["coordinates"] == pytest.approx([lon, lat], abs=1e-8)  # < 1 mm
    cov = json.loads((tmp_path / "coverage.geojson").read_text())
    ring = np.array(cov["features"][2]["geometry"]["coordinates"][0])
    assert ring[:, 0].min() == pytest.approx(pm.ned2geodetic(0, -10, 0, *D0, 0)[1], abs=1e-7)


def test_one_mission_without_georeference_makes_the_catalogue_datum_less() -> None:
    a = _mission("a", 1, D0, ["sphere"])
    b = _mission("b", 2, D0, ["sphere"])
    b.georeferenced = False
    cat = build_catalogue([a, b])
    assert not cat.frame.geographic and "datum-less" in cat.frame.note and cat.objects[0].lat is None
