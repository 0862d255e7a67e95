"""Simulator settings: the optional ``[sensors]`` and ``[noise]`` tables of a scene file.

The scene loader (:mod:`auvlink.sim.scene`) ignores both; :func:`settings_for` reads them from the
same TOML text. Every key has a default; an unknown key or a bad value raises
:class:`~auvlink.errors.ConfigError` naming the dotted key. The ``[noise]`` table is documented in
:mod:`auvlink.sim.noise`.

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
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from auvlink.errors import ConfigError
from auvlink.sim.noise import SHAPE_FIELDS, AhrsNoise, DvlNoise, GyroNoise, NoiseConfig, PressureNoise
from auvlink.sim.scene import Scene, default_scene_text

PRESSURE_KINDS = ("paro", "keller")
DEFAULT_START = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)


@dataclass(frozen=True)
class SensorSettings:
    pressure: str = "paro"
    dvl_hz: float = 5.0
    gyro_hz: float = 100.0
    pressure_hz: float = 10.0
    can_hz: float = 10.0
    truth_hz: float = 50.0
    truth_topic_hz: float = 10.0
    dvl_lever_arm: tuple[float, float, float] = (0.40, 0.0, 0.25)
    dvl_rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    pressure_lever_arm: tuple[float, float, float] = (-0.60, 0.0, 0.0)
    water_temperature_c: float = 10.0
    sound_speed: float = 1500.0
    start: dt.datetime = DEFAULT_START
    keller_address: int = 1
    keller_latency_s: float = 0.015  # response after the request (9600 baud: 5 + 9 bytes on the line)
    gyro_temperature_c: float = 30.0

    @property
    def start_ns(self) -> int:
        """UTC nanoseconds since the epoch of mission time 0."""
        delta = self.start - dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
        return (delta.days * 86_400 + delta.seconds) * 1_000_000_000 + delta.microseconds * 1000


@dataclass(frozen=True)
class SimSettings:
    sensors: SensorSettings = field(default_factory=SensorSettings)
    noise: NoiseConfig = field(default_factory=NoiseConfig)
    scene_text: str = ""  # the scene file's TOML ("" when the scene was built in code)


def _number(value: Any, key: str, lo: float = 0.0, hi: float = math.inf, open_lo: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(key, f"expected a finite number, got {value!r}", "write a plain number, e.g. 1.0")
    v = float(value)
    if v < lo or v > hi or (open_lo and v == lo):
        raise ConfigError(key, f"{v} is out of range", f"use a value in {'(' if open_lo else '['}{lo}, {hi}]")
    return v


def _vec3(value: Any, key: str) -> tuple[float, float, float]:
    ok = isinstance(value, list) and len(value) == 3 and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not ok:
        raise ConfigError(key, f"expected a list of 3 numbers, got {value!r}", "write [x, y, z]")
    return (float(value[0]), float(value[1]), float(value[2]))


def _start(value: Any, key: str) -> dt.datetime:
    if isinstance(value, str):
        try:
            value = dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
        except ValueError as exc:
            raise ConfigError(key, f"not an ISO 8601 time: {value!r}", 'write "2026-01-01T00:00:00Z"') from exc
    if not isinstance(value, dt.datetime):
        raise ConfigError(key, f"expected a date-time, got {value!r}", 'write "2026-01-01T00:00:00Z"')
    return value.replace(tzinfo=dt.UTC) if value.tzinfo is None else value.astimezone(dt.UTC)


_RATE_HI = {"dvl_hz": 100.0, "gyro_hz": 5000.0, "pressure_hz": 1000.0, "can_hz": 1000.0, "truth_hz": 10000.0,
            "truth_topic_hz": 1000.0}


def _sensors(table: Mapping[str, Any]) -> SensorSettings:
    known = {f.name for f in fields(SensorSettings)}
    kw: dict[str, Any] = {}
    for key, value in table.items():
        name = f"sensors.{key}"
        if key not in known:
            raise ConfigError(name, "unknown key", f"allowed: {', '.join(sorted(known))}")
        if key == "pressure":
            if value not in PRESSURE_KINDS:
                raise ConfigError(name, f"unknown pressure sensor {value!r}", 'use "paro" or "keller"')
            kw[key] = value
        elif key.endswith(("lever_arm", "rpy_deg")):
            kw[key] = _vec3(value, name)
        elif key == "start":
            kw[key] = _start(value, name)
        elif key == "keller_address":
            kw[key] = int(_number(value, name, 0, 255))
        elif key in _RATE_HI:
            kw[key] = _number(value, name, 0.0, _RATE_HI[key], open_lo=key != "truth_topic_hz")
        elif key == "sound_speed":
            kw[key] = _number(value, name, 1300.0, 1700.0)
        else:
            kw[key] = _number(value, name, -5.0 if key.endswith("_c") else 0.0, 100.0 if key.endswith("_c")
                              else 10.0)
    return SensorSettings(**kw)


def _noise_part(cls: type, table: Any, prefix: str) -> Any:
    if not isinstance(table, Mapping):
        raise ConfigError(prefix, "expected a table", f"write [{prefix}]")
    known = {f.name for f in fields(cls)}
    kw: dict[str, float] = {}
    for key, value in table.items():
        if key not in known:
            raise ConfigError(f"{prefix}.{key}", "unknown key", f"allowed: {', '.join(sorted(known))}")
        hi = 1.0 if key in ("dropout_probability", "scale_error", "sigma_fs") else math.inf
        lo = -0.1 if key == "scale_error" else 0.0
        kw[key] = _number(value, f"{prefix}.{key}", lo, hi, open_lo=key in SHAPE_FIELDS)
    return cls(**kw)


_NOISE_PARTS: dict[str, type] = {"dvl": DvlNoise, "gyro": GyroNoise, "pressure": PressureNoise, "ahrs": AhrsNoise}


def _noise(value: Any) -> NoiseConfig:
    if isinstance(value, bool):
        return NoiseConfig() if value else NoiseConfig.off()
    if not isinstance(value, Mapping):
        raise ConfigError("noise", f"expected a table or true/false, got {value!r}", "write [noise] or noise = false")
    enabled = value.get("enabled", True)
    if not isinstance(enabled, bool):
        raise ConfigError("noise.enabled", f"expected true or false, got {enabled!r}", "write enabled = false")
    if not enabled:
        return NoiseConfig.off()
    parts: dict[str, Any] = {}
    for key, sub in value.items():
        if key == "enabled":
            continue
        if key not in _NOISE_PARTS:
            raise ConfigError(f"noise.{key}", "unknown key", f"allowed: enabled, {', '.join(_NOISE_PARTS)}")
        parts[key] = _noise_part(_NOISE_PARTS[key], sub, f"noise.{key}")
    return NoiseConfig(True, **parts)


def parse_settings(doc: Mapping[str, Any], text: str = "") -> SimSettings:
    """The ``[sensors]`` and ``[noise]`` tables of a parsed scene document (both optional)."""
    sensors = doc.get("sensors", {})
    if not isinstance(sensors, Mapping):
        raise ConfigError("sensors", "expected a table", "write [sensors]")
    return SimSettings(_sensors(sensors), _noise(doc.get("noise", True)), text)


def loads_settings(text: str) -> SimSettings:
    """The settings in scene TOML text."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("scene", f"not valid TOML: {exc}", "fix the TOML syntax") from exc
    return parse_settings(doc, text)


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
