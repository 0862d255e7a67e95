"""Scene files: the shipped default, the schema's rules, and errors that name the key."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import pytest

from auvlink.errors import ConfigError
from auvlink.sim.scene import (
    CLASSES,
    Scene,
    default_scene_text,
    load_default_scene,
    load_scene,
    loads_scene,
    parse_scene,
)

MINIMAL = """
seed = 3
[seabed]
depth = 20.0
[[objects]]
class = "box"
position = [10.0, 1.0]
[survey]
line_length = 50.0
line_spacing = 3.0
lines = 2
altitude = 4.0
speed = 1.0
[sonar]
tilt_deg = 30.0
window_start = 1.0
window_length = 10.0
fps = 10.0
"""


def _doc() -> dict[str, Any]:
    return tomllib.loads(MINIMAL)


def test_default_scene_is_a_short_lawnmower_with_many_classes() -> None:
    scene = load_default_scene()
    assert isinstance(scene, Scene)
    assert len(scene.objects) >= 6
    assert len({o.class_name for o in scene.objects}) >= 4
    sv = scene.survey
    assert 60.0 <= sv.line_length <= 80.0 and sv.lines >= 2
    path_m = sv.lines * sv.line_length + (sv.lines - 1) * math.pi * sv.line_spacing / 2
    assert 60.0 < path_m / sv.speed < 600.0  # a few minutes
    assert scene.sonar.spread_deg == 14.0 and scene.sonar.rays_per_beam == 32
    # every object lies within reach of a survey line (sonar swath about +-2 m)
    for o in scene.objects:
        offsets = [abs(o.east - (sv.origin[1] + i * sv.line_spacing)) for i in range(sv.lines)]
        assert min(offsets) <= 1.5
        assert sv.origin[0] + 10 <= o.north <= sv.origin[0] + sv.line_length


def test_minimal_scene_defaults() -> None:
    scene = loads_scene(MINIMAL)
    assert scene.seed == 3
    assert scene.seabed.slope_deg == 0.0 and scene.seabed.roughness == 0.0
    assert scene.objects[0].class_name == "box" and scene.objects[0].heading_deg == 0.0
    assert scene.objects[0].class_index == CLASSES.index("box")
    assert scene.survey.origin == (0.0, 0.0) and scene.survey.pattern == "lawnmower"
    assert scene.sonar.spread_deg == 14.0 and scene.sonar.lever_arm == (0.0, 0.0, 0.0)
    assert scene.vehicle.current == (0.0, 0.0)
    assert scene.sonar.window_end == 11.0


@pytest.mark.parametrize("path,key,allowed", [
    (("seabed", "slope_degree"), "seabed.slope_degree", "depth, roughness, slope_azimuth_deg, slope_deg"),
    (("bogus",), "bogus", "seabed, seed"),
    (("sonar", "rays_per_bean"), "sonar.rays_per_bean", "rays_per_beam"),
    (("objects", 0, "colour"), "objects[0].colour", "class, heading_deg, position"),
    (("site", "lat"), "site.lat", "latitude, longitude"),
])
def test_unknown_keys_are_rejected(path: tuple[Any, ...], key: str, allowed: str) -> None:
    """A typo (``slope_degree``, ``[bogus]``, ``rays_per_bean``) would silently run another mission."""
    doc = _doc()
    doc.setdefault("site", {})
    table: Any = doc
    for part in path[:-1]:
        table = table[part]
    table[path[-1]] = {} if path == ("bogus",) else 1.0
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == key and err.value.problem == "unknown key"
    assert "allowed here:" in err.value.fix and allowed in err.value.fix


@pytest.mark.parametrize("path,value,limit", [
    (("survey", "lines"), 10**9, "1000"), (("survey", "line_length"), 1e9, "20000.0"),
    (("survey", "line_spacing"), 1e9, "1000.0"), (("sonar", "rays_per_beam"), 10**6, "256"),
])
def test_sizes_are_bounded(path: tuple[str, str], value: Any, limit: str) -> None:
    """Sizes that would allocate tens of GiB are refused with the limit named."""
    doc = _doc()
    doc[path[0]][path[1]] = value
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == ".".join(path) and "out of range" in err.value.problem and limit in err.value.fix


def test_mission_duration_is_bounded() -> None:
    doc = _doc()
    doc["survey"].update(lines=1000, line_length=20_000.0, speed=0.5)
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == "survey" and "12 h" in err.value.problem


def test_site_is_read_and_checked() -> None:
    doc = _doc()
    doc["site"] = {"latitude": 36.0412, "longitude": 129.3915}
    site = parse_scene(doc).site
    assert site is not None and (site.latitude, site.longitude) == (36.0412, 129.3915)
    doc["site"]["longitude"] = 190.0
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == "site.longitude" and "[-180.0, 180.0]" in err.value.fix


def test_load_from_file(tmp_path: Path) -> None:
    path = tmp_path / "scene.toml"
    path.write_text(default_scene_text())
    scene = load_scene(path)
    assert scene.source == str(path)
    assert scene.objects == load_default_scene().objects


@pytest.mark.parametrize("table,key", [
    ("seabed", "depth"), ("survey", "line_length"), ("survey", "line_spacing"), ("survey", "lines"),
    ("survey", "altitude"), ("survey", "speed"), ("sonar", "tilt_deg"), ("sonar", "window_start"),
    ("sonar", "window_length"), ("sonar", "fps"),
])
def test_missing_key_is_named(table: str, key: str) -> None:
    doc = _doc()
    del doc[table][key]
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == f"{table}.{key}"
    assert "missing" in err.value.problem and err.value.fix


@pytest.mark.parametrize("table", ["seabed", "survey", "sonar"])
def test_missing_table_is_named(table: str) -> None:
    doc = _doc()
    del doc[table]
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == table


@pytest.mark.parametrize("path,value,key", [
    (("seabed", "depth"), "deep", "seabed.depth"),
    (("seabed", "depth"), -3.0, "seabed.depth"),
    (("seabed", "roughness"), -0.1, "seabed.roughness"),
    (("survey", "lines"), 2.5, "survey.lines"),
    (("survey", "lines"), 0, "survey.lines"),
    (("survey", "altitude"), 25.0, "survey.altitude"),  # below the seabed
    (("survey", "origin"), [1.0], "survey.origin"),
    (("survey", "pattern"), "spiral", "survey.pattern"),
    (("survey", "speed"), True, "survey.speed"),
    (("sonar", "tilt_deg"), 95.0, "sonar.tilt_deg"),
    (("sonar", "window_length"), 0.0, "sonar.window_length"),
    (("sonar", "lever_arm"), [0.0, 0.0], "sonar.lever_arm"),
    (("sonar", "rays_per_beam"), 1, "sonar.rays_per_beam"),
])
def test_wrong_value_is_named(path: tuple[str, str], value: Any, key: str) -> None:
    doc = _doc()
    doc[path[0]][path[1]] = value
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == key
    assert key in str(err.value)


def test_object_errors_name_the_index() -> None:
    doc = _doc()
    doc["objects"].append({"class": "submarine", "position": [1.0, 2.0]})
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == "objects[1].class" and "reef_a" in err.value.fix
    doc["objects"][1] = {"class": "sphere", "position": [1.0, 2.0, 3.0]}
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == "objects[1].position"
    doc["objects"][1] = {"position": [1.0, 2.0]}
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == "objects[1].class"


def test_current_must_be_slower_than_the_vehicle() -> None:
    doc = _doc()
    doc["vehicle"] = {"current": [1.0, 0.5]}
    with pytest.raises(ConfigError) as err:
        parse_scene(doc)
    assert err.value.key == "vehicle.current"


def test_bad_toml_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as err:
        loads_scene("seed = = 1")
    assert err.value.key == "scene" and isinstance(err.value.__cause__, tomllib.TOMLDecodeError)
    with pytest.raises(ConfigError) as err:
        load_scene(tmp_path / "nope.toml")
    assert err.value.key == "scene" and isinstance(err.value.__cause__, OSError)
