"""Simulator settings: the optional ``[sensors]`` and ``[noise]`` tables of a scene file.

The scene loader (:mod:`auvlink.sim.scene`) leaves both to this module; :func:`settings_for` reads
them from the same TOML text, validated by the pydantic models :class:`SensorSettings` and
:class:`NoiseTable` (``docs/schemas/settings.schema.json``). Every key has a default; an unknown key or
a bad value raises :class:`~auvlink.errors.ConfigError` naming the dotted key and the allowed keys or
range; :func:`check_budget` bounds the samples a mission's streams may hold. The ``[noise]`` table is
documented in :mod:`auvlink.sim.noise`.

.. code-block:: toml

    [sensors]
    pressure = "paro"            # or "keller" (F73 request + response pairs as a serial tap sees them)
    dvl_hz = 5.0                 # PD0 ensembles (and the DVL_* CAN messages)
    gyro_hz = 100.0              # DSP-1760 messages
    pressure_hz = 10.0           # pressure readings (and the PRESSURE / DEPTH CAN messages)
    can_hz = 10.0                # GYRO_RATE and ATTITUDE CAN messages
    truth_hz = 50.0              # true trajectory stored in the log (attachment truth/trajectory.npy)
    truth_topic_hz = 10.0        # the same as a JSON channel truth/pose for viewers (0: none)
    dvl_lever_arm = [0.40, 0.0, 0.25]       # body FRD, m
    dvl_rpy_deg = [0.0, 0.0, 0.0]           # DVL mounting (moves its beams; velocities are 'ship')
    pressure_lever_arm = [-0.60, 0.0, 0.0]  # body FRD, m
    water_temperature_c = 10.0
    sound_speed = 1500.0         # m/s (PD0 leader, DIDSON header)
    start = "2026-01-01T00:00:00Z"          # UTC time of mission t = 0 (host and sensor clocks)
    keller_address = 1
    keller_latency_s = 0.015     # a Keller answer follows its request by this much
    gyro_temperature_c = 30.0
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import Field, field_validator
from pydantic.dataclasses import dataclass as model

from auvlink.errors import ConfigError
from auvlink.sim.noise import AhrsNoise, DvlNoise, GyroNoise, NoiseConfig, PressureNoise
from auvlink.sim.scene import Scene, SceneFile, default_scene_text
from auvlink.sonar import Lever
from auvlink.validation import CONFIG, Boolean, Integer, Number, Vec3, loads_toml, validate

PRESSURE_KINDS = ("paro", "keller")
DEFAULT_START = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
#: most samples one sensor stream may hold for a mission (the simulator computes them up front)
MAX_SAMPLES = 20_000_000


Hz = Field(description="Hz")
Rate100 = Annotated[Number, Field(gt=0.0, le=100.0), Hz]
Rate1k = Annotated[Number, Field(gt=0.0, le=1000.0), Hz]
Rate5k = Annotated[Number, Field(gt=0.0, le=5000.0), Hz]
Rate10k = Annotated[Number, Field(gt=0.0, le=10_000.0), Hz]
TopicRate = Annotated[Number, Field(ge=0.0, le=1000.0), Field(description="Hz (0: none)")]
Temperature = Annotated[Number, Field(ge=-5.0, le=100.0, description="degC")]


@model(frozen=True, config=CONFIG)
class SensorSettings:
    pressure: Literal["paro", "keller"] = "paro"
    dvl_hz: Rate100 = 5.0
    gyro_hz: Rate5k = 100.0
    pressure_hz: Rate1k = 10.0
    can_hz: Rate1k = 10.0
    truth_hz: Rate10k = 50.0
    truth_topic_hz: TopicRate = 10.0
    dvl_lever_arm: Lever = (0.40, 0.0, 0.25)
    dvl_rpy_deg: Annotated[Vec3, Field(description="DVL mounting roll, pitch, yaw in B, deg")] = (0.0, 0.0, 0.0)
    pressure_lever_arm: Lever = (-0.60, 0.0, 0.0)
    water_temperature_c: Temperature = 10.0
    sound_speed: Annotated[Number, Field(ge=1300.0, le=1700.0, description="m/s")] = 1500.0
    start: dt.datetime = DEFAULT_START
    keller_address: Annotated[Integer, Field(ge=0, le=255)] = 1
    keller_latency_s: Annotated[Number, Field(ge=0.0, le=10.0)] = 0.015  # response after the request
    gyro_temperature_c: Temperature = 30.0

    @field_validator("start", mode="after")
    @classmethod
    def _utc(cls, value: dt.datetime) -> dt.datetime:
        return value.replace(tzinfo=dt.UTC) if value.tzinfo is None else value.astimezone(dt.UTC)

    @property
    def start_ns(self) -> int:
        """UTC nanoseconds since the epoch of mission time 0."""
        delta = self.start - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
        return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


@model(frozen=True, config=CONFIG)
class NoiseTable:
    """``[noise]`` as written: ``enabled`` and one table per sensor (every key has a default)."""

    enabled: Boolean = True
    dvl: DvlNoise = field(default_factory=DvlNoise)
    gyro: GyroNoise = field(default_factory=GyroNoise)
    pressure: PressureNoise = field(default_factory=PressureNoise)
    ahrs: AhrsNoise = field(default_factory=AhrsNoise)


@model(frozen=True, config=CONFIG)
class SettingsTables:
    """The simulator settings of a scene file: ``[sensors]`` and ``[noise]`` (or ``noise = false``)."""

    sensors: SensorSettings = field(default_factory=SensorSettings)
    noise: NoiseTable | Boolean = True


@model(frozen=True, kw_only=True, config=CONFIG)
class SceneDocument(SceneFile):
    """A whole scene file: the scene's tables and the simulator settings (``docs/schemas/scene.schema.json``)."""

    sensors: SensorSettings | None = None  # type: ignore[assignment]
    noise: NoiseTable | Boolean | None = None  # type: ignore[assignment]


@dataclass(frozen=True)
class SimSettings:
    sensors: SensorSettings = field(default_factory=SensorSettings)
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    scene_text: str = ""  # the scene file's TOML ("" when the scene was built in code)


def _noise(value: NoiseTable | bool) -> NoiseConfig:
    if isinstance(value, bool):
        return NoiseConfig() if value else NoiseConfig.off()
    if not value.enabled:
        return NoiseConfig.off()
    return NoiseConfig(True, value.dvl, value.gyro, value.pressure, value.ahrs)


def parse_settings(doc: Mapping[str, Any], text: str = "") -> SimSettings:
    """The ``[sensors]`` and ``[noise]`` tables of a parsed scene document (both optional).

    The other tables belong to the scene (:func:`auvlink.sim.scene.parse_scene` checks them).
    """
    tables = {k: doc[k] for k in ("sensors", "noise") if k in doc}
    s = validate(SettingsTables, tables)
    return SimSettings(s.sensors, _noise(s.noise), text)


def loads_settings(text: str) -> SimSettings:
    """The settings in scene TOML text."""
    return parse_settings(loads_toml(text, "scene"), text)


def check_budget(scene: Scene, settings: SimSettings) -> None:
    """Refuse a mission whose sensor streams would hold more than :data:`MAX_SAMPLES` samples each."""
    duration = scene.survey.path_length / scene.survey.speed
    s = settings.sensors
    rates = (("sensors.gyro_hz", s.gyro_hz), ("sensors.truth_hz", s.truth_hz), ("sensors.can_hz", s.can_hz),
             ("sensors.pressure_hz", s.pressure_hz), ("sensors.dvl_hz", s.dvl_hz), ("sonar.fps", scene.sonar.fps))
    for key, hz in rates:
        if duration * hz > MAX_SAMPLES:
            raise ConfigError(key, f"{hz} Hz over a {duration:.0f} s mission is {duration * hz:.3g} samples, "
                              f"beyond the {MAX_SAMPLES} limit", f"use a rate <= {MAX_SAMPLES / duration:.4g} Hz "
                              "or a shorter survey")


def scene_text(scene: Scene) -> str:
    """The TOML text a scene was loaded from ("" when it was built in code)."""
    if scene.source.startswith("auvlink.sim:"):
        return default_scene_text()
    if scene.source:
        try:
            return Path(scene.source).read_text(encoding="utf-8")
        except OSError:
            return ""
    return ""


def settings_for(scene: Scene) -> SimSettings:
    """The simulator settings of a scene: its file's ``[sensors]`` / ``[noise]`` tables, else defaults."""
    text = scene_text(scene)
    return loads_settings(text) if text else SimSettings()
