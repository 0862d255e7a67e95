"""Scene files for the simulator: seabed, objects, survey and sonar, loaded from TOML.

The schema is the one in ``shared/design/ARCHITECTURE.md`` ("Scene files"). Keys named there are
read with these rules; extra keys anywhere are ignored, so a scene can carry notes or settings for
other tools. A missing required key, a wrong type or a value out of range raises
:class:`auvlink.errors.ConfigError` naming the dotted key (``survey.altitude``,
``objects[2].class``), the problem and the fix.

Optional keys beyond the architecture's table (all with defaults):

- ``[sonar] lever_arm = [x, y, z]`` sonar position in the body frame (FRD, m), default ``[0, 0, 0]``;
  ``rays_per_beam`` (K, default 32).
- ``[vehicle] current = [north, east]`` water current (m/s, default none), ``roll_amplitude_deg``
  (1.0), ``pitch_amplitude_deg`` (0.5), ``yaw_amplitude_deg`` (0.5), ``roll_period_s`` (7.0),
  ``pitch_period_s`` (11.0), ``yaw_period_s`` (17.0): the small seeded attitude oscillations.
- ``[site] latitude``, ``longitude`` (WGS84 degrees), ``height`` (m above the ellipsoid, 0): the datum,
  W's origin on the surface (:mod:`auvlink.geodesy`). Default: Jangil Bay, Pohang (36.0412 N, 129.3915 E).
- ``[gnss]``: the GNSS receiver and the surface phases of the mission (:mod:`auvlink.sim.gnss_config`).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from auvlink.errors import ConfigError
from auvlink.geodesy import JANGIL_BAY, Datum, parse_site

DEFAULT_SITE = Datum(*JANGIL_BAY)

if TYPE_CHECKING:
    from auvlink.sim.gnss_config import Gnss

#: Object catalog class names, in a fixed order (class index = position in this tuple).
CLASSES: tuple[str, ...] = (
    "reef_a", "reef_b", "reef_c", "sphere", "hemisphere", "pipe", "half_pipe", "box",
)

DEFAULT_SCENE_RESOURCE = "default_scene.toml"


@dataclass(frozen=True)
class Seabed:
    depth: float  # m below the surface at the NED origin
    slope_deg: float = 0.0
    slope_azimuth_deg: float = 0.0  # direction in which depth increases (0 = north, clockwise)
    roughness: float = 0.0  # m rms


@dataclass(frozen=True)
class SceneObject:
    class_name: str
    north: float  # m
    east: float  # m
    heading_deg: float = 0.0

    @property
    def class_index(self) -> int:
        return CLASSES.index(self.class_name)


@dataclass(frozen=True)
class Survey:
    line_length: float  # m
    line_spacing: float  # m, later lines step to the starboard side of the first line
    lines: int
    altitude: float  # m above the seabed
    speed: float  # m/s over ground
    origin: tuple[float, float] = (0.0, 0.0)  # north, east (m): start of the first line
    heading_deg: float = 0.0  # direction of the first line
    pattern: str = "lawnmower"


@dataclass(frozen=True)
class SonarConfig:
    tilt_deg: float  # pitch-down tilt of the boresight (positive looks down)
    window_start: float  # m, start of the range window
    window_length: float  # m
    fps: float  # frames per second
    spread_deg: float = 14.0  # vertical (elevation) spread of each beam
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)  # sonar origin in the body frame (m)
    rays_per_beam: int = 32  # K

    @property
    def window_end(self) -> float:
        return self.window_start + self.window_length


@dataclass(frozen=True)
class Vehicle:
    current: tuple[float, float] = (0.0, 0.0)  # water current north, east (m/s)
    roll_amplitude_deg: float = 1.0
    pitch_amplitude_deg: float = 0.5
    yaw_amplitude_deg: float = 0.5
    roll_period_s: float = 7.0
    pitch_period_s: float = 11.0
    yaw_period_s: float = 17.0


@dataclass(frozen=True)
class Scene:
    seed: int
    seabed: Seabed
    objects: tuple[SceneObject, ...]
    survey: Survey
    sonar: SonarConfig
    vehicle: Vehicle = Vehicle()
    source: str = ""  # file the scene came from ("" when built in code)
    site: Datum = DEFAULT_SITE  # WGS84 position of W's origin
    gnss: Gnss | None = None  # None: no GNSS, the mission is the survey alone


# --- field readers -------------------------------------------------------------------------
_MISSING = object()


def _get(table: Mapping[str, Any], key: str, prefix: str, default: Any = _MISSING) -> Any:
    if key in table:
        return table[key]
    if default is _MISSING:
        raise ConfigError(f"{prefix}{key}", "missing", f"add `{key} = ...` to the scene file")
    return default


def _num(
    table: Mapping[str, Any], key: str, prefix: str, default: Any = _MISSING, *,
    lo: float = -math.inf, hi: float = math.inf, lo_open: bool = False, hi_open: bool = False,
) -> float:
    value = _get(table, key, prefix, default)
    name = f"{prefix}{key}"
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(name, f"expected a number, got {value!r}", "write a plain number, e.g. 1.0")
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(name, f"expected a finite number, got {value!r}", "use a finite value")
    below = v <= lo if lo_open else v < lo
    above = v >= hi if hi_open else v > hi
    if below or above:
        lb = "(" if lo_open else "["
        rb = ")" if hi_open else "]"
        raise ConfigError(name, f"{v} is out of range", f"use a value in {lb}{lo}, {hi}{rb}")
    return v


def _int(table: Mapping[str, Any], key: str, prefix: str, default: Any = _MISSING, *, lo: int = 0) -> int:
    value = _get(table, key, prefix, default)
    name = f"{prefix}{key}"
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(name, f"expected an integer, got {value!r}", "write a whole number, e.g. 4")
    if value < lo:
        raise ConfigError(name, f"{value} is out of range", f"use an integer >= {lo}")
    return value


def _vec(
    table: Mapping[str, Any], key: str, prefix: str, n: int, default: Any = _MISSING
) -> tuple[float, ...]:
    value = _get(table, key, prefix, default)
    name = f"{prefix}{key}"
    ok = isinstance(value, list | tuple) and len(value) == n and all(
        isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for x in value
    )
    if not ok:
        example = ", ".join(["0.0"] * n)
        raise ConfigError(name, f"expected a list of {n} numbers, got {value!r}", f"write [{example}]")
    return tuple(float(x) for x in value)


def _table(doc: Mapping[str, Any], key: str, required: bool = True) -> Mapping[str, Any]:
    if key not in doc:
        if required:
            raise ConfigError(key, "missing table", f"add a [{key}] table to the scene file")
        return {}
    value = doc[key]
    if not isinstance(value, Mapping):
        got = type(value).__name__
        raise ConfigError(key, f"expected a table, got {got}", f"write [{key}] on its own line")
    return value


# --- sections ------------------------------------------------------------------------------
def _seabed(doc: Mapping[str, Any]) -> Seabed:
    t, p = _table(doc, "seabed"), "seabed."
    return Seabed(
        depth=_num(t, "depth", p, lo=0.0, lo_open=True),
        slope_deg=_num(t, "slope_deg", p, 0.0, lo=0.0, hi=30.0),
        slope_azimuth_deg=_num(t, "slope_azimuth_deg", p, 0.0),
        roughness=_num(t, "roughness", p, 0.0, lo=0.0, hi=0.5),
    )


def _objects(doc: Mapping[str, Any]) -> tuple[SceneObject, ...]:
    items = doc.get("objects", [])
    if not isinstance(items, list):
        raise ConfigError("objects", "expected an array of tables", "write each object as [[objects]]")
    out = []
    for i, item in enumerate(items):
        p = f"objects[{i}]."
        if not isinstance(item, Mapping):
            raise ConfigError(f"objects[{i}]", "expected a table", "write each object as [[objects]]")
        cls = _get(item, "class", p)
        if cls not in CLASSES:
            raise ConfigError(f"{p}class", f"unknown class {cls!r}", f"use one of {', '.join(CLASSES)}")
        north, east = _vec(item, "position", p, 2)
        out.append(SceneObject(cls, north, east, _num(item, "heading_deg", p, 0.0)))
    return tuple(out)


def _survey(doc: Mapping[str, Any], seabed: Seabed) -> Survey:
    t, p = _table(doc, "survey"), "survey."
    pattern = _get(t, "pattern", p, "lawnmower")
    if pattern != "lawnmower":
        raise ConfigError(f"{p}pattern", f"unknown pattern {pattern!r}", 'use "lawnmower"')
    altitude = _num(t, "altitude", p, lo=0.0, lo_open=True)
    if altitude >= seabed.depth:
        raise ConfigError(f"{p}altitude", f"{altitude} m is not above a seabed {seabed.depth} m deep",
                          "use an altitude smaller than seabed.depth")
    origin = _vec(t, "origin", p, 2, [0.0, 0.0])
    return Survey(
        line_length=_num(t, "line_length", p, lo=0.0, lo_open=True),
        line_spacing=_num(t, "line_spacing", p, lo=0.0, lo_open=True),
        lines=_int(t, "lines", p, lo=1),
        altitude=altitude,
        speed=_num(t, "speed", p, lo=0.0, lo_open=True, hi=10.0),
        origin=(origin[0], origin[1]),
        heading_deg=_num(t, "heading_deg", p, 0.0),
        pattern=pattern,
    )


def _sonar(doc: Mapping[str, Any]) -> SonarConfig:
    t, p = _table(doc, "sonar"), "sonar."
    spread = _num(t, "spread_deg", p, 14.0, lo=0.0, hi=60.0, lo_open=True)
    tilt = _num(t, "tilt_deg", p, lo=0.0, hi=90.0 - spread / 2.0, lo_open=True, hi_open=True)
    lever = _vec(t, "lever_arm", p, 3, [0.0, 0.0, 0.0])
    return SonarConfig(
        tilt_deg=tilt,
        window_start=_num(t, "window_start", p, lo=0.0),
        window_length=_num(t, "window_length", p, lo=0.0, lo_open=True),
        fps=_num(t, "fps", p, lo=0.0, lo_open=True, hi=1000.0),
        spread_deg=spread,
        lever_arm=(lever[0], lever[1], lever[2]),
        rays_per_beam=_int(t, "rays_per_beam", p, 32, lo=2),
    )


def _vehicle(doc: Mapping[str, Any]) -> Vehicle:
    t, p = _table(doc, "vehicle", required=False), "vehicle."
    cur = _vec(t, "current", p, 2, [0.0, 0.0])
    return Vehicle(
        current=(cur[0], cur[1]),
        roll_amplitude_deg=_num(t, "roll_amplitude_deg", p, 1.0, lo=0.0, hi=20.0),
        pitch_amplitude_deg=_num(t, "pitch_amplitude_deg", p, 0.5, lo=0.0, hi=20.0),
        yaw_amplitude_deg=_num(t, "yaw_amplitude_deg", p, 0.5, lo=0.0, hi=20.0),
        roll_period_s=_num(t, "roll_period_s", p, 7.0, lo=0.0, lo_open=True),
        pitch_period_s=_num(t, "pitch_period_s", p, 11.0, lo=0.0, lo_open=True),
        yaw_period_s=_num(t, "yaw_period_s", p, 17.0, lo=0.0, lo_open=True),
    )


def parse_scene(doc: Mapping[str, Any], source: str = "") -> Scene:
    """Validate a parsed TOML document and build a :class:`Scene`."""
    seed = _int(doc, "seed", "", 0, lo=0)
    seabed = _seabed(doc)
    survey = _survey(doc, seabed)
    vehicle = _vehicle(doc)
    cur = math.hypot(*vehicle.current)
    if cur >= survey.speed:
        raise ConfigError("vehicle.current", f"current {cur:.2f} m/s is not below survey.speed",
                          "use a current slower than the survey speed")
    from auvlink.sim.gnss_config import parse_gnss

    site = parse_site(dict(_table(doc, "site")), "site.") if "site" in doc else DEFAULT_SITE
    return Scene(seed=seed, seabed=seabed, objects=_objects(doc), survey=survey, sonar=_sonar(doc),
                 vehicle=vehicle, source=source, site=site, gnss=parse_gnss(doc))


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene TOML file."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError("scene", f"cannot read {path}: {exc.strerror}", "check the path") from exc
    return loads_scene(text, source=str(path))


def loads_scene(text: str, source: str = "") -> Scene:
    """Parse and validate scene TOML text."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("scene", f"not valid TOML: {exc}", "fix the TOML syntax") from exc
    return parse_scene(doc, source=source)


def default_scene_text() -> str:
    """The TOML text of the scene shipped in the package (used by ``make demo``)."""
    return resources.files("auvlink.sim").joinpath("data", DEFAULT_SCENE_RESOURCE).read_text("utf-8")


def load_default_scene() -> Scene:
    """The default scene shipped in the package."""
    return loads_scene(default_scene_text(), source=f"auvlink.sim:data/{DEFAULT_SCENE_RESOURCE}")
