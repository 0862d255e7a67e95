"""Scene files for the simulator: seabed, objects, survey and sonar, loaded from TOML.

The schema is the one in ``shared/design/ARCHITECTURE.md`` ("Scene files"), validated by pydantic
models (the JSON Schema is ``docs/schemas/scene.schema.json``). An unknown key anywhere is an error
(a typo would run a different mission), as is a missing required key, a wrong type or a value out
of range: :class:`auvlink.errors.ConfigError` names the dotted key (``survey.altitude``,
``objects[2].class``), the problem and the allowed keys or range. Every size is bounded so a scene
cannot ask for more than an AUV survey needs (``survey.lines`` <= 1000, ``line_length`` <= 20 km,
a mission of at most 12 h, ``rays_per_beam`` <= 256).

Optional keys beyond the architecture's table (all with defaults):

- ``[site] latitude``, ``longitude``: WGS84 degrees of the NED origin (see :class:`auvlink.validation.Site`).
- ``[sonar] lever_arm = [x, y, z]`` sonar position in the body frame (FRD, m), default ``[0, 0, 0]``;
  ``rays_per_beam`` (K, default 32).
- ``[vehicle] current = [north, east]`` water current (m/s, default none), ``roll_amplitude_deg``
  (1.0), ``pitch_amplitude_deg`` (0.5), ``yaw_amplitude_deg`` (0.5), ``roll_period_s`` (7.0),
  ``pitch_period_s`` (11.0), ``yaw_period_s`` (17.0): the small seeded attitude oscillations.
- ``[sensors]`` and ``[noise]``: the simulator settings (:mod:`auvlink.sim.settings` validates them).
- ``[gnss]``: the GNSS receiver and the surface phases of the mission (:mod:`auvlink.sim.gnss_config`).
- ``[acoustics]``: the acoustic model of the sonar image, ``profile`` and overrides
  (:mod:`auvlink.sim.acoustics`); absent, or without ``profile``: the realistic profile of the sonar model
  (:func:`auvlink.sim.acoustics.rendered_table`); ``profile = "ideal"``: the idealized model.

Without ``[site]`` (or with only one of its keys) the scene's datum (:attr:`Scene.datum`) is Jangil Bay,
Pohang (36.0412 N, 129.3915 E), where the paper's field trial ran.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field
from pydantic.dataclasses import dataclass as model

from auvlink.errors import ConfigError
from auvlink.geodesy import JANGIL_BAY, Datum
from auvlink.sim.acoustics import AcousticsTable, profile_named, rendered_table, resolve
from auvlink.sim.gnss_config import Gnss, check_gnss
from auvlink.sonar import MAX_LEVER_M, Sonar, SonarModelName, describe
from auvlink.validation import CONFIG, Integer, Number, Site, Vec2, Vec3, loads_toml, read_toml, validate

#: Object catalog class names, in a fixed order (class index = position in this tuple).
CLASSES: tuple[str, ...] = (
    "reef_a", "reef_b", "reef_c", "sphere", "hemisphere", "pipe", "half_pipe", "box",
)

DEFAULT_SCENE_RESOURCE = "default_scene.toml"


#: limits of a scene's sizes (what one AUV survey could need; beyond them a typo would allocate GiB)
MAX_LINES = 1000
MAX_LINE_LENGTH_M = 20_000.0
MAX_LINE_SPACING_M = 1000.0
MAX_MISSION_S = 12 * 3600.0
MAX_RAYS_PER_BEAM = 256
MAX_OFFSET_M = 100_000.0
#: largest seed: 63 bits, what every consumer of the seed (numpy's SeedSequence, JSON readers, the log) keeps exactly
MAX_SEED = 2**63 - 1

Angle = Annotated[Number, Field(ge=-360.0, le=360.0)]
Offset = Annotated[Vec2, Field(description="north, east (m) in the world frame")]


@model(frozen=True, config=CONFIG)
class Seabed:
    depth: Annotated[Number, Field(gt=0.0, le=11_000.0, description="m below the surface at the NED origin")]
    slope_deg: Annotated[Number, Field(ge=0.0, le=30.0)] = 0.0
    slope_azimuth_deg: Annotated[Angle, Field(description="direction in which depth increases (0 = north)")] = 0.0
    roughness: Annotated[Number, Field(ge=0.0, le=0.5, description="m rms")] = 0.0


@dataclass(frozen=True)
class SceneObject:
    class_name: str
    north: float  # m
    east: float  # m
    heading_deg: float = 0.0

    @property
    def class_index(self) -> int:
        return CLASSES.index(self.class_name)


@model(frozen=True, config=CONFIG)
class ObjectTable:
    """One ``[[objects]]`` table as written."""

    class_name: Annotated[Literal[CLASSES], Field(alias="class")]  # type: ignore[valid-type]
    position: Annotated[Vec2, Field(description="north, east (m); the object rests on the seabed")]
    heading_deg: Angle = 0.0

    def scene_object(self) -> SceneObject:
        return SceneObject(self.class_name, self.position[0], self.position[1], self.heading_deg)


@model(frozen=True, config=CONFIG)
class Survey:
    line_length: Annotated[Number, Field(gt=0.0, le=MAX_LINE_LENGTH_M, description="m")]
    line_spacing: Annotated[Number, Field(gt=0.0, le=MAX_LINE_SPACING_M,
                                          description="m; later lines step to the starboard side of the first")]
    lines: Annotated[Integer, Field(ge=1, le=MAX_LINES)]
    altitude: Annotated[Number, Field(gt=0.0, le=1000.0, description="m above the seabed")]
    speed: Annotated[Number, Field(gt=0.0, le=10.0, description="m/s over ground")]
    origin: Offset = (0.0, 0.0)
    heading_deg: Annotated[Angle, Field(description="direction of the first line")] = 0.0
    pattern: Literal["lawnmower"] = "lawnmower"

    @property
    def path_length(self) -> float:
        """m flown: the lines and the semicircle turns between them."""
        return self.lines * self.line_length + (self.lines - 1) * math.pi * self.line_spacing / 2.0


@model(frozen=True, kw_only=True, config=CONFIG)
class SonarConfig(Sonar):
    """The scene's ``[sonar]``: the shared :class:`~auvlink.sonar.Sonar` plus what the simulator renders."""

    tilt_deg: Annotated[Number, Field(gt=0.0, lt=90.0, description="pitch down of the boresight, deg")]
    spread_deg: Annotated[Number, Field(gt=0.0, le=60.0, description="vertical beam spread, deg")] = 14.0
    fps: Annotated[Number, Field(gt=0.0, le=1000.0, description="frames per second")]
    lever_arm: Annotated[Vec3, Field(description="sonar origin in the body frame (FRD), m")] = (0.0, 0.0, 0.0)
    rays_per_beam: Annotated[Integer, Field(ge=2, le=MAX_RAYS_PER_BEAM, description="K rays per beam")] = 32


@model(frozen=True, config=CONFIG)
class Vehicle:
    current: Annotated[Vec2, Field(description="water current north, east (m/s)")] = (0.0, 0.0)
    roll_amplitude_deg: Annotated[Number, Field(ge=0.0, le=20.0)] = 1.0
    pitch_amplitude_deg: Annotated[Number, Field(ge=0.0, le=20.0)] = 0.5
    yaw_amplitude_deg: Annotated[Number, Field(ge=0.0, le=20.0)] = 0.5
    roll_period_s: Annotated[Number, Field(gt=0.0, le=3600.0)] = 7.0
    pitch_period_s: Annotated[Number, Field(gt=0.0, le=3600.0)] = 11.0
    yaw_period_s: Annotated[Number, Field(gt=0.0, le=3600.0)] = 17.0


@model(frozen=True, kw_only=True, config=CONFIG)
class SceneFile:
    """A scene file as written. ``sensors`` and ``noise`` are validated by :mod:`auvlink.sim.settings`."""

    seed: Annotated[Integer, Field(ge=0, le=MAX_SEED)] = 0
    site: Site | None = None
    seabed: Seabed
    objects: Annotated[list[ObjectTable], Field(max_length=10_000)] = field(default_factory=list)
    survey: Survey
    sonar: SonarConfig
    vehicle: Vehicle = field(default_factory=Vehicle)
    sensors: dict[str, Any] | None = None
    noise: dict[str, Any] | bool | None = None
    gnss: Gnss | None = None
    acoustics: Annotated[AcousticsTable | None, Field(
        description="the sonar image's acoustic model; absent: the realistic profile of the sonar model "
                    "(sonar.model, DIDSON if unset); profile = \"ideal\": the idealized model")] = None


@dataclass(frozen=True)
class Scene:
    seed: int
    seabed: Seabed
    objects: tuple[SceneObject, ...]
    survey: Survey
    sonar: SonarConfig
    vehicle: Vehicle = field(default_factory=Vehicle)
    source: str = ""  # file the scene came from ("" when built in code)
    site: Site | None = None
    gnss: Gnss | None = None  # None: no GNSS receiver, the mission is the survey alone
    acoustics: AcousticsTable | None = None  # None: the sonar model's own profile (acoustics.rendered_table)

    @property
    def datum(self) -> Datum:
        """The WGS84 datum of the scene's NED frame: ``[site]``, else Jangil Bay (Pohang)."""
        s = self.site
        if s is None or s.latitude is None or s.longitude is None:
            return Datum(*JANGIL_BAY)
        return Datum(float(s.latitude), float(s.longitude))


def parse_scene(doc: Any, source: str = "") -> Scene:
    """Validate a parsed TOML document and build a :class:`Scene`."""
    f = validate(SceneFile, doc)
    if f.survey.altitude >= f.seabed.depth:
        raise ConfigError("survey.altitude", f"{f.survey.altitude} m is not above a seabed {f.seabed.depth} m deep",
                          "use an altitude smaller than seabed.depth")
    tilt_hi = 90.0 - f.sonar.spread_deg / 2.0
    if f.sonar.tilt_deg >= tilt_hi:
        raise ConfigError("sonar.tilt_deg", f"{f.sonar.tilt_deg} is out of range",
                          f"use a value in (0.0, {tilt_hi}): the steepest ray must stay below vertical")
    if any(abs(v) > MAX_LEVER_M for v in f.sonar.lever_arm):
        raise ConfigError("sonar.lever_arm", f"{list(f.sonar.lever_arm)} is out of range",
                          f"use values in [-{MAX_LEVER_M}, {MAX_LEVER_M}] m")
    for key, vec in (("survey.origin", f.survey.origin), *((f"objects[{i}].position", o.position)
                                                           for i, o in enumerate(f.objects))):
        if any(abs(v) > MAX_OFFSET_M for v in vec):
            raise ConfigError(key, f"{list(vec)} is out of range", f"use values in [-{MAX_OFFSET_M}, {MAX_OFFSET_M}] m")
    cur = math.hypot(*f.vehicle.current)
    if cur >= f.survey.speed:
        raise ConfigError("vehicle.current", f"current {cur:.2f} m/s is not below survey.speed",
                          "use a current slower than the survey speed")
    duration = f.survey.path_length / f.survey.speed
    if duration > MAX_MISSION_S:
        raise ConfigError("survey", f"the mission would last {duration:.0f} s (lines x line_length / speed), "
                          f"beyond the {MAX_MISSION_S:.0f} s (12 h) limit",
                          "use fewer or shorter lines, or a higher speed")
    if f.sonar.model is not None and f.sonar.model not in SIMULATED_MODELS:
        raise ConfigError("sonar.model", f"the simulator does not send {f.sonar.model} frames",
                          f"use {', '.join(SIMULATED_MODELS)}")
    resolve(rendered_table(f.acoustics, f.sonar))  # the ideal profile with overrides is an error naming the key
    return Scene(seed=f.seed, seabed=f.seabed, objects=tuple(o.scene_object() for o in f.objects),
                 survey=f.survey, sonar=f.sonar, vehicle=f.vehicle, source=source, site=f.site,
                 gnss=check_gnss(f.gnss), acoustics=f.acoustics)


#: the sonar models the simulator sends (DIDSON and ARIS frames, Oculus pings; auvlink.sim.oculus_ping.sonar_format)
SIMULATED_MODELS: tuple[SonarModelName, ...] = ("didson", "aris1800", "aris3000", "oculus-m750d", "oculus-m1200d")


def with_sonar_model(scene: Scene, model: SonarModelName) -> Scene:
    """The scene flown with another sonar model (high-frequency mode): its vertical spread the model's data-sheet
    aperture, its images under the model's own realistic profile (the table's overrides kept), every other
    setting kept. A scene without ``[acoustics]``, or whose table names no profile, keeps its table: the renderer
    takes the flown model's profile itself; ``profile = "ideal"`` stays ideal."""
    if model not in SIMULATED_MODELS:
        raise ConfigError("sonar.model", f"the simulator does not send {model} frames", f"use one of "
                          f"{', '.join(SIMULATED_MODELS)}")
    d = describe(model)
    flown = replace(scene, sonar=replace(scene.sonar, model=model, spread_deg=d.vertical_aperture_deg))
    if scene.acoustics is None or scene.acoustics.profile in (None, "ideal"):
        return flown
    return with_acoustics(flown, d.acoustic_profile)  # the model's own profile, the table's overrides kept


def with_acoustics(scene: Scene, profile: str | None = None) -> Scene:
    """The scene with an ``[acoustics]`` table that names the profile it is rendered under: ``profile`` (a name of
    :data:`auvlink.sim.acoustics.PROFILES`; a realistic one keeps the scene's overrides, ``ideal`` takes none);
    with ``None``, the profile the scene renders under as it stands (:func:`auvlink.sim.acoustics.rendered_table`:
    its table's, else its sonar model's own), the same images."""
    table = rendered_table(scene.acoustics, scene.sonar)
    if profile is None:
        return scene if table == scene.acoustics else replace(scene, acoustics=table)
    name = profile_named(profile)
    if name == "ideal" or table.profile == "ideal":
        return replace(scene, acoustics=AcousticsTable(profile=name))
    return replace(scene, acoustics=replace(table, profile=name))


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene TOML file."""
    doc, _ = read_toml(path, "scene")
    return parse_scene(doc, source=str(path))


def loads_scene(text: str, source: str = "") -> Scene:
    """Parse and validate scene TOML text."""
    return parse_scene(loads_toml(text, "scene"), source=source)


def default_scene_text() -> str:
    """The TOML text of the scene shipped in the package (used by ``make demo``)."""
    return resources.files("auvlink.sim").joinpath("data", DEFAULT_SCENE_RESOURCE).read_text("utf-8")


def load_default_scene() -> Scene:
    """The default scene shipped in the package."""
    return loads_scene(default_scene_text(), source=f"auvlink.sim:data/{DEFAULT_SCENE_RESOURCE}")
