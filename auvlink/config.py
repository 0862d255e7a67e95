"""The vehicle / mission configuration file read by ``auvlink record``, ``live`` and ``sim --live``.

TOML, one file per vehicle set-up. Units are those a person types (m, deg, s); the loaded objects
also give radians. The file is validated by the pydantic model :class:`VehicleFile` (the JSON Schema
is ``docs/schemas/vehicle.schema.json``): a wrong, missing or unknown key raises
:class:`~auvlink.errors.ConfigError` naming the key, the problem and the allowed keys or range.
The same model validates the configuration a mission log stores (:func:`config_from_metadata`).

.. code-block:: toml

    [vehicle]
    name = "auv1"

    [site]                            # optional: WGS84 position of the NED origin (degrees)
    latitude = 36.0412
    longitude = 129.3915

    [[devices]]                       # repeatable: one per port
    name = "dvl"                      # channel name in the log
    format = "pd0"                    # a wire-format name (auvlink.formats.names())
    url = "/dev/ttyUSB0?baudrate=115200"
    mounting = { xyz = [0.50, 0.00, 0.20], rpy_deg = [0.0, 0.0, 45.0] }  # lever arm in body FRD (m)
    options = { }                     # optional; only ``oculus`` takes options (auvlink.oculus_driver)

    [sonar]                           # optional: the forward-scan sonar's geometry (auvlink.sonar.Sonar)
    device = "sonar"                  # optional: which device is the sonar
    tilt_deg = 30.0                   # pitch down of the boresight (positive = looking down)
    spread_deg = 14.0                 # vertical beam spread
    window_start = 1.0                # m
    window_length = 10.0              # m

    [can]                             # optional
    dbc = "auvlink_nav.dbc"           # DBC file: relative to the config file, absolute, or shipped in auvlink/data

A GNSS receiver is a device with ``format = "nmea"``; its ``mounting.xyz`` is the antenna's lever arm.
``[site]`` is the WGS84 datum of the local NED frame; without one the mean of the first GNSS fixes that
agree becomes the datum, never a single fix (docs/GEO.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import field
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field
from pydantic.dataclasses import dataclass

from auvlink import formats
from auvlink.errors import ConfigError
from auvlink.oculus_driver import OPTIONS as OCULUS_OPTIONS
from auvlink.oculus_driver import OculusSettings
from auvlink.sonar import Mounting, Sonar
from auvlink.transports.urls import check_url
from auvlink.validation import CONFIG, Site, Text, loads_toml, plain, read_toml, validate

__all__ = ["CanConfig", "DeviceConfig", "Mounting", "Site", "SonarConfig", "VehicleConfig", "VehicleSonar",
           "config_from_metadata", "load_config", "loads_config", "parse_config"]

#: options each wire format reads from ``devices[i].options`` (the Oculus sonar's SimpleFire settings)
DEVICE_OPTIONS: dict[str, frozenset[str]] = {"oculus": OCULUS_OPTIONS}


@dataclass(frozen=True, config=CONFIG)
class DeviceConfig:
    """One port: a device name, its wire format, the transport URL and its mounting."""

    name: Text
    format: Text
    url: Text
    mounting: Mounting = field(default_factory=Mounting)
    options: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, kw_only=True, config=CONFIG)
class VehicleSonar(Sonar):
    """``[sonar]`` of the vehicle configuration: the shared :class:`~auvlink.sonar.Sonar` and its device."""

    device: Text | None = None


SonarConfig = VehicleSonar  # the name this module used before the sonar model moved to auvlink.sonar


@dataclass(frozen=True, config=CONFIG)
class CanConfig:
    """``[can]``: the DBC file describing the CAN messages."""

    dbc: Text | None = None


@dataclass(frozen=True, config=CONFIG)
class VehicleTable:
    name: Text = "vehicle"


@dataclass(frozen=True, kw_only=True, config=CONFIG)
class VehicleFile:
    """A vehicle configuration file as written (the model its JSON Schema is generated from)."""

    vehicle: VehicleTable = field(default_factory=VehicleTable)
    site: Site | None = None
    devices: Annotated[list[DeviceConfig], Field(min_length=1, max_length=64)]
    sonar: VehicleSonar | None = None
    can: CanConfig | None = None


@dataclass(frozen=True, kw_only=True)
class VehicleConfig:
    """A whole configuration file, validated."""

    name: str
    devices: tuple[DeviceConfig, ...]
    sonar: VehicleSonar | None = None
    can: CanConfig | None = None
    site: Site | None = None
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
            "devices": [plain(d) for d in self.devices],
        }
        if self.sonar is not None:
            out["sonar"] = plain(self.sonar)
        if self.can is not None:
            out["can"] = plain(self.can)
        if self.site is not None:
            out["site"] = plain(self.site)
        return out


# -- checks the model cannot make alone ----------------------------------------------------------
def _check_devices(devices: list[DeviceConfig]) -> None:
    names = formats.names()
    seen: set[str] = set()
    for i, dev in enumerate(devices):
        where = f"devices[{i}]."
        if dev.format not in names:
            raise ConfigError(f"{where}format", f"unknown wire format {dev.format!r}", f"one of {', '.join(names)}")
        if dev.name in seen:
            raise ConfigError(f"{where}name", f"duplicate device name {dev.name!r}", "names must be unique")
        seen.add(dev.name)
        allowed = DEVICE_OPTIONS.get(dev.format, frozenset())
        for key in dev.options:
            if key not in allowed:
                raise ConfigError(f"{where}options.{key}", f"unknown option of format {dev.format!r}",
                                  f"allowed here: {', '.join(sorted(allowed)) or 'none (remove options)'}")
        if dev.format == "oculus":  # the SimpleFire settings' values, checked before any port opens
            try:
                OculusSettings.from_options(dev.options)
            except ConfigError as exc:
                raise ConfigError(f"{where}{exc.key}", exc.problem, exc.fix) from exc
        try:
            check_url(dev.url)
        except ConfigError as exc:
            raise ConfigError(f"{where}url", exc.problem, exc.fix) from exc


def resolve_dbc(dbc: str, source: str) -> Path:
    """The DBC file ``dbc`` names: absolute, relative to the config file, or shipped in auvlink/data."""
    p = Path(dbc)
    base = Path(source).parent if source and Path(source).is_file() else Path.cwd()
    tried = [p] if p.is_absolute() else [base / p]
    if not p.is_absolute() and len(p.parts) == 1:
        shipped = resources.files("auvlink").joinpath("data", dbc)
        if shipped.is_file():
            return Path(str(shipped))
    for cand in tried:
        if cand.is_file():
            return cand
    raise ConfigError("can.dbc", f"DBC file not found: {tried[0]}",
                      "give a path relative to the config file, an absolute path, or auvlink_nav.dbc (shipped)")


def parse_config(data: Mapping[str, Any], source: str = "<string>", text: str = "", *,
                 check_files: bool = True) -> VehicleConfig:
    """Validate a parsed TOML document and build the :class:`VehicleConfig`.

    ``check_files`` False skips checks against this machine's files (a log's stored DBC path).
    """
    if data.get("devices") is None or data.get("devices") == []:
        raise ConfigError("devices", "at least one [[devices]] block is needed",
                          "add [[devices]] with name, format and url")
    doc = validate(VehicleFile, data)
    _check_devices(doc.devices)
    if doc.sonar is not None and doc.sonar.device is not None and doc.sonar.device not in {
            d.name for d in doc.devices}:
        raise ConfigError("sonar.device", f"no device named {doc.sonar.device!r}",
                          f"one of {sorted(d.name for d in doc.devices)}")
    if check_files and doc.can is not None and doc.can.dbc is not None:
        resolve_dbc(doc.can.dbc, source)
    return VehicleConfig(name=doc.vehicle.name, devices=tuple(doc.devices), sonar=doc.sonar, can=doc.can,
                         site=doc.site, source=source, text=text)


def loads_config(text: str, source: str = "<string>") -> VehicleConfig:
    """Parse a configuration from TOML text."""
    return parse_config(loads_toml(text, source), source=source, text=text)


def load_config(path: str | Path) -> VehicleConfig:
    """Read and validate a configuration file."""
    data, text = read_toml(path, str(path))
    return parse_config(data, source=str(path), text=text)


def config_from_metadata(meta: Mapping[str, Any]) -> VehicleConfig:
    """The vehicle configuration a mission log stores (``vehicle_config`` metadata), validated.

    Raises :class:`ConfigError` naming the bad key; files named there (the DBC) are not looked up.
    """
    vc = meta.get("vehicle_config")
    if vc is None:
        raise ConfigError("vehicle_config", "missing from the log's metadata", "give --config CONFIG.toml")
    cfg = vc.get("config", vc) if isinstance(vc, Mapping) else vc
    if not isinstance(cfg, Mapping):
        raise ConfigError("vehicle_config", f"expected a table, got {type(cfg).__name__}", "give --config")
    text = vc.get("toml", "") if isinstance(vc, Mapping) else ""
    return parse_config(cfg, source="<log metadata>", text=text if isinstance(text, str) else "",
                        check_files=False)
