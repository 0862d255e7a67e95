"""A vehicle configuration over a scene: which simulated instrument serves each device, and the vehicle's own
mountings and sonar put over the scene's (``auvlink sim --live``, :mod:`auvlink.sim.device_server`).

Devices are matched by wire format (:data:`ROLES`). The configuration wins over the scene for the DVL and
pressure lever arms, the DVL mounting angles, the sonar's lever arm, tilt, spread, window, model and frequency
mode, the pressure sensor's kind and the GNSS antenna's lever arm. A device that speaks ``oculus`` needs an
Oculus model (``[sonar] model``, in the configuration or the scene): the simulator's pings are that model's; one
that speaks ``aris`` an ARIS model (its frames are that model's), one that speaks ``didson`` the DIDSON.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal, cast

from pydantic import ValidationError

from auvlink.config import DeviceConfig, VehicleConfig
from auvlink.sim.noise import SimError
from auvlink.sim.oculus_ping import sonar_format
from auvlink.sim.scene import Scene, SonarConfig
from auvlink.sim.settings import SimSettings
from auvlink.validation import config_error

#: wire format -> the simulated instrument that serves it
ROLES = {"pd0": "dvl", "dsp1760": "gyro", "paro": "pressure", "keller": "pressure", "can": "can",
         "didson": "sonar", "aris": "sonar", "oculus": "sonar", "nmea": "gnss"}


def match_devices(config: VehicleConfig) -> dict[str, DeviceConfig]:
    """Simulated role (dvl, gyro, pressure, can, sonar) -> the config's device serving it."""
    out: dict[str, DeviceConfig] = {}
    for dev in config.devices:
        role = ROLES.get(dev.format)
        if role is None:
            raise SimError(f"device {dev.name!r}: the simulator does not emit format {dev.format!r} "
                           f"(it emits {', '.join(ROLES)})")
        if role in out:
            raise SimError(f"devices {out[role].name!r} and {dev.name!r} both ask for the simulated {role}")
        out[role] = dev
    return out


def adapt(scene: Scene, settings: SimSettings, config: VehicleConfig) -> tuple[Scene, SimSettings]:
    """The scene and settings with the vehicle described by ``config`` (mountings, sonar geometry)."""
    devices = match_devices(config)
    s = settings.sensors
    if "dvl" in devices:
        m = devices["dvl"].mounting
        s = replace(s, dvl_lever_arm=m.xyz, dvl_rpy_deg=m.rpy_deg)
    if "pressure" in devices:
        kind = devices["pressure"].format
        if kind != "paro" and kind != "keller":
            raise SimError(f"device {devices['pressure'].name!r}: no simulated pressure sensor speaks {kind!r}")
        s = replace(s, pressure=cast(Literal["paro", "keller"], kind),
                    pressure_lever_arm=devices["pressure"].mounting.xyz)
    if "gnss" in devices and scene.gnss is not None:
        scene = replace(scene, gnss=replace(scene.gnss, lever_arm=devices["gnss"].mounting.xyz))
    sonar = scene.sonar
    if "sonar" in devices:
        sonar = replace(sonar, lever_arm=devices["sonar"].mounting.xyz)
    if config.sonar is not None:
        c = config.sonar
        try:  # the simulator renders a narrower range of geometries than a vehicle config may describe
            sonar = replace(sonar, tilt_deg=c.tilt_deg, spread_deg=c.spread_deg, window_start=c.window_start,
                            window_length=c.window_length, model=c.model or sonar.model,
                            frequency_mode=c.frequency_mode or sonar.frequency_mode)
        except ValidationError as exc:
            raise config_error(SonarConfig, exc, "sonar.") from exc
    if "sonar" in devices and devices["sonar"].format != sonar_format(sonar):
        raise SimError(f"device {devices['sonar'].name!r} speaks {devices['sonar'].format!r} but the simulated sonar "
                       f"is a {sonar.description.model}: set [sonar] model to match (oculus-m750d or oculus-m1200d "
                       "for an oculus device, aris1800 or aris3000 for an aris one, didson for a didson one)")
    return replace(scene, sonar=sonar), replace(settings, sensors=s)
