"""Pipeline set-up from a mission log's metadata: sonar geometry, DVL mounting, ground truth."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class TruthObject:
    """One object of a simulated mission's ground truth (world frame NED, m)."""

    class_name: str
    position_ned: tuple[float, float, float]
    heading_deg: float = 0.0


@dataclass(frozen=True)
class MissionSetup:
    """What the pipeline needs to know about the vehicle, from the log's ``vehicle_config``."""

    tilt_deg: float = 30.0
    spread_deg: float = 14.0
    window_start: float = 1.0
    window_length: float = 10.0
    sonar_lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dvl_lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    dvl_yaw_deg: float = 0.0
    pressure_lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    truth: tuple[TruthObject, ...] = ()
    truth_track: Any = None  # (times s since epoch, positions (n, 3)) when the log has it
    site: Any = None  # auvlink.geodesy.Datum of the configuration's [site], or None
    gnss_lever_arm: tuple[float, float, float] | None = None  # the GNSS antenna (None: no GNSS device)
    truth_site: Any = None  # the datum of the simulator's truth (its NED frame), when the log has one
    extra: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_metadata(cls, meta: dict[str, dict[str, Any]]) -> MissionSetup:
        vc = meta.get("vehicle_config", {})
        cfg = vc.get("config", vc) if isinstance(vc, dict) else {}
        kw: dict[str, Any] = {}
        sonar = cfg.get("sonar") or {}
        for key in ("tilt_deg", "spread_deg", "window_start", "window_length"):
            if sonar.get(key) is not None:
                kw[key] = float(sonar[key])
        sonar_dev = sonar.get("device") or "sonar"
        for dev in cfg.get("devices", []) or []:
            xyz = tuple(float(v) for v in (dev.get("mounting") or {}).get("xyz", (0, 0, 0)))
            rpy = (dev.get("mounting") or {}).get("rpy_deg", (0, 0, 0))
            if dev.get("name") == sonar_dev or dev.get("format") in ("didson", "aris"):
                kw["sonar_lever_arm"] = xyz
            elif dev.get("format") == "pd0":
                kw["dvl_lever_arm"] = xyz
                kw["dvl_yaw_deg"] = float(rpy[2])
            elif dev.get("format") in ("paro", "keller"):
                kw["pressure_lever_arm"] = xyz
            elif dev.get("format") == "nmea":
                kw["gnss_lever_arm"] = xyz
        from auvlink.geodesy import Datum

        kw["site"] = Datum.from_dict(cfg.get("site"))
        gt = meta.get("ground_truth") or {}
        kw["truth_site"] = Datum.from_dict(gt.get("site"))
        kw["truth"] = tuple(_truth_objects(gt))
        return cls(**kw)


def _truth_objects(gt: dict[str, Any]) -> list[TruthObject]:
    out = []
    for obj in gt.get("objects", []) or []:
        name = obj.get("class") or obj.get("class_name")
        pos = obj.get("position_ned") or obj.get("position")
        if name is None or pos is None:
            continue
        p = [float(v) for v in pos] + [math.nan] * (3 - len(pos))
        out.append(TruthObject(str(name), (p[0], p[1], p[2]), float(obj.get("heading_deg", 0.0))))
    return out


def sonar_geometry(setup: MissionSetup, azimuths: np.ndarray | None = None,
                   window: tuple[float, float] | None = None) -> Any:
    """The :class:`recon.sonar_geometry.SonarGeometry` of this mission."""
    from recon.sonar_geometry import SonarGeometry

    start, length = window if window is not None else (setup.window_start, setup.window_length)
    table = None if azimuths is None else tuple(float(a) for a in azimuths)
    return SonarGeometry(window_start=start, window_length=length, tilt=math.radians(setup.tilt_deg),
                         spread=math.radians(setup.spread_deg), lever_arm=setup.sonar_lever_arm,
                         azimuth_table=table)


def nav_config(setup: MissionSetup) -> Any:
    from recon.frames import rdi_instrument_mounting
    from recon.nav import NavConfig

    mounting = rdi_instrument_mounting(lever_arm=setup.dvl_lever_arm,
                                       heading_misalignment=math.radians(setup.dvl_yaw_deg))
    return NavConfig(dvl_mounting=mounting, depth_lever_arm=setup.pressure_lever_arm)
