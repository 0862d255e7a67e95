"""The vehicle / mission configuration file read by ``auvlink record``, ``live`` and ``sim --live``.

TOML, one file per vehicle set-up. Units are those a person types (m, deg, s); the loaded objects
also give radians. Every key is checked: a wrong or missing key raises
:class:`~auvlink.errors.ConfigError` naming the key and the fix.

.. code-block:: toml

    [vehicle]
    name = "auv1"

    [[devices]]                       # repeatable: one per port
    name = "dvl"                      # channel name in the log
    format = "pd0"                    # a wire-format name (auvlink.formats.names())
    url = "/dev/ttyUSB0?baudrate=115200"
    mounting = { xyz = [0.50, 0.00, 0.20], rpy_deg = [0.0, 0.0, 45.0] }  # lever arm in body FRD (m)
    options = { }                     # optional, free-form, handed to the device's driver

    [sonar]                           # optional: the forward-scan sonar's geometry
    device = "sonar"                  # optional: which device is the sonar
    tilt_deg = 30.0                   # pitch down of the boresight (positive = looking down)
    spread_deg = 14.0                 # vertical beam spread
    window_start = 1.0                # m
    window_length = 10.0              # m

    [can]                             # optional
    dbc = "auvlink_nav.dbc"           # DBC file name (relative to the config or the package data)

    [site]                            # optional: WGS84 position of the local NED origin (the datum)
    latitude = 36.0412                # deg, + north
    longitude = 129.3915              # deg, + east
    height = 0.0                      # optional, m above the WGS84 ellipsoid

A GNSS receiver is a device with ``format = "nmea"``; its ``mounting.xyz`` is the antenna's lever arm.
Without ``[site]`` the first accepted GNSS fix becomes the datum (see docs/GEO.md).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auvlink import formats
from auvlink.errors import ConfigError
from auvlink.geodesy import Datum, parse_site

_TOP_KEYS = {"vehicle", "devices", "sonar", "can", "site"}
_VEHICLE_KEYS = {"name"}
_DEVICE_KEYS = {"name", "format", "url", "mounting", "options"}
_MOUNTING_KEYS = {"xyz", "rpy_deg"}
_SONAR_KEYS = {"device", "tilt_deg", "spread_deg", "window_start", "window_length"}
_CAN_KEYS = {"dbc"}


@dataclass(frozen=True)
class Mounting:
    """Where a device sits on the vehicle: lever arm in the body frame (FRD, m) and its rotation."""

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)  # roll, pitch, yaw of the device in B

    @property
    def rpy(self) -> tuple[float, float, float]:
        """Roll, pitch, yaw in radians."""
        r, p, y = (math.radians(v) for v in self.rpy_deg)
        return (r, p, y)


@dataclass(frozen=True)
class DeviceConfig:
    """One port: a device name, its wire format, the transport URL and its mounting."""

    name: str
    format: str
    url: str
    mounting: Mounting = field(default_factory=Mounting)
    options: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class SonarConfig:
    """Geometry of the forward-scan sonar (degrees and metres as configured)."""

    tilt_deg: float
    spread_deg: float
    window_start: float
    window_length: float
    device: str | None = None

    @property
    def tilt(self) -> float:
        return math.radians(self.tilt_deg)

    @property
    def spread(self) -> float:
        return math.radians(self.spread_deg)


@dataclass(frozen=True)
class CanConfig:
    dbc: str | None = None


@dataclass(frozen=True)
class VehicleConfig:
    """A whole configuration file."""

    name: str
    devices: tuple[DeviceConfig, ...]
    sonar: SonarConfig | None = None
    can: CanConfig | None = None
    site: Datum | None = None
    source: str = "<string>"
    text: str = ""

    def device(self, name: str) -> DeviceConfig:
        for dev in self.devices:
            if dev.name == name:
                return dev
        raise ConfigError("devices", f"no device named {name!r}", f"one of {[d.name for d in self.devices]}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (what the mission log stores as ``vehicle_config``)."""
        out: dict[str, Any] = {
            "vehicle": {"name": self.name},
            "devices": [
                {"name": d.name, "format": d.format, "url": d.url,
                 "mounting": {"xyz": list(d.mounting.xyz), "rpy_deg": list(d.mounting.rpy_deg)},
                 "options": dict(d.options)}
                for d in self.devices
            ],
        }
        if self.sonar is not None:
            out["sonar"] = {"tilt_deg": self.sonar.tilt_deg, "spread_deg": self.sonar.spread_deg,
                            "window_start": self.sonar.window_start,
                            "window_length": self.sonar.window_length, "device": self.sonar.device}
        if self.can is not None:
            out["can"] = {"dbc": self.can.dbc}
        if self.site is not None:
            out["site"] = self.site.to_dict()
        return out


# -- validation helpers ---------------------------------------------------------------------
def _check_keys(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            raise ConfigError(f"{where}{key}", "unknown key", f"allowed here: {', '.join(sorted(allowed))}")


def _table(data: Mapping[str, Any], key: str, where: str = "") -> Mapping[str, Any]:
    value = data[key]
    if not isinstance(value, Mapping):
        raise ConfigError(f"{where}{key}", f"must be a table, got {type(value).__name__}",
                          f"write [{where}{key}] or {key} = {{ ... }}")
    return value


def _str(data: Mapping[str, Any], key: str, where: str, required: bool = True) -> str | None:
    if key not in data:
        if required:
            raise ConfigError(f"{where}{key}", "missing", f"add {key} = \"...\"")
        return None
    value = data[key]
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{where}{key}", f"must be a non-empty string, got {value!r}", "quote it")
    return value


def _float(data: Mapping[str, Any], key: str, where: str, lo: float | None = None,
           hi: float | None = None) -> float:
    if key not in data:
        raise ConfigError(f"{where}{key}", "missing", f"add {key} = <number>")
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"{where}{key}", f"must be a finite number, got {value!r}", "write e.g. 1.0")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise ConfigError(f"{where}{key}", f"{value} is out of range", f"use a value in [{lo}, {hi}]")
    return float(value)


def _vec3(data: Mapping[str, Any], key: str, where: str) -> tuple[float, float, float]:
    value = data.get(key, [0.0, 0.0, 0.0])
    ok = isinstance(value, list) and len(value) == 3 and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    if not ok:
        raise ConfigError(f"{where}{key}", f"must be a list of 3 numbers, got {value!r}",
                          f"write {key} = [x, y, z]")
    return (float(value[0]), float(value[1]), float(value[2]))


def _device(raw: Any, i: int, format_names: list[str]) -> DeviceConfig:
    where = f"devices[{i}]."
    if not isinstance(raw, Mapping):
        raise ConfigError(f"devices[{i}]", "must be a table", "write [[devices]] blocks")
    _check_keys(raw, _DEVICE_KEYS, where)
    name = _str(raw, "name", where)
    fmt = _str(raw, "format", where)
    url = _str(raw, "url", where)
    assert name is not None and fmt is not None and url is not None
    if fmt not in format_names:
        raise ConfigError(f"{where}format", f"unknown wire format {fmt!r}",
                          f"one of {', '.join(format_names)}")
    mounting = Mounting()
    if "mounting" in raw:
        m = _table(raw, "mounting", where)
        _check_keys(m, _MOUNTING_KEYS, f"{where}mounting.")
        mounting = Mounting(_vec3(m, "xyz", f"{where}mounting."), _vec3(m, "rpy_deg", f"{where}mounting."))
    options: Mapping[str, Any] = dict(_table(raw, "options", where)) if "options" in raw else {}
    return DeviceConfig(name, fmt, url, mounting, options)


def parse_config(data: Mapping[str, Any], source: str = "<string>", text: str = "") -> VehicleConfig:
    """Validate a parsed TOML document and build the :class:`VehicleConfig`."""
    _check_keys(data, _TOP_KEYS, "")
    name = "vehicle"
    if "vehicle" in data:
        vehicle = _table(data, "vehicle")
        _check_keys(vehicle, _VEHICLE_KEYS, "vehicle.")
        name = _str(vehicle, "name", "vehicle.", required=False) or name
    raw_devices = data.get("devices", [])
    if not isinstance(raw_devices, list) or not raw_devices:
        raise ConfigError("devices", "at least one [[devices]] block is needed",
                          "add [[devices]] with name, format and url")
    format_names = formats.names()
    devices = tuple(_device(raw, i, format_names) for i, raw in enumerate(raw_devices))
    seen: set[str] = set()
    for i, dev in enumerate(devices):
        if dev.name in seen:
            raise ConfigError(f"devices[{i}].name", f"duplicate device name {dev.name!r}",
                              "names must be unique")
        seen.add(dev.name)
    sonar = None
    if "sonar" in data:
        s = _table(data, "sonar")
        _check_keys(s, _SONAR_KEYS, "sonar.")
        device = _str(s, "device", "sonar.", required=False)
        if device is not None and device not in seen:
            raise ConfigError("sonar.device", f"no device named {device!r}", f"one of {sorted(seen)}")
        sonar = SonarConfig(
            tilt_deg=_float(s, "tilt_deg", "sonar.", -90.0, 90.0),
            spread_deg=_float(s, "spread_deg", "sonar.", 0.0, 90.0),
            window_start=_float(s, "window_start", "sonar.", 0.0),
            window_length=_float(s, "window_length", "sonar.", 0.0),
            device=device,
        )
    can = None
    if "can" in data:
        c = _table(data, "can")
        _check_keys(c, _CAN_KEYS, "can.")
        can = CanConfig(dbc=_str(c, "dbc", "can.", required=False))
    site = parse_site(dict(_table(data, "site")), "site.") if "site" in data else None
    return VehicleConfig(name=name, devices=devices, sonar=sonar, can=can, site=site, source=source, text=text)


def loads_config(text: str, source: str = "<string>") -> VehicleConfig:
    """Parse a configuration from TOML text."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(source, f"not valid TOML: {exc}", "fix the syntax at the position given") from exc
    return parse_config(data, source=source, text=text)


def load_config(path: str | Path) -> VehicleConfig:
    """Read and validate a configuration file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(str(p), f"cannot read: {exc.strerror or exc}", "check the path") from exc
    return loads_config(text, source=str(p))
