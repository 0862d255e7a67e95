"""Pipeline set-up from the validated vehicle configuration: sonar geometry, mountings, ground truth.

:class:`MissionSetup` is built directly from a :class:`~auvlink.config.VehicleConfig` (``auvlink
live``) or from the configuration a mission log stores, validated by the same model
(:func:`~auvlink.config.config_from_metadata`). A log whose stored configuration is damaged (a
tilt of ``"abc"``, ``devices`` a string) still replays: the setup falls back to the configuration
given on the command line (``--config``) or to the defaults, and :attr:`MissionSetup.warning`
says in one line which key was bad.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from auvlink.config import VehicleConfig, config_from_metadata
from auvlink.errors import ConfigError
from auvlink.pipeline.log_meta import TruthObject, truth_objects
from auvlink.sonar import DEFAULT_SONAR, Mounting, Sonar
from auvlink.validation import Site
from recon.frames import rdi_instrument_mounting
from recon.nav import NavConfig
from recon.sonar_geometry import SonarGeometry


@dataclass(frozen=True)
class MissionSetup:
    """What the pipeline needs to know about the vehicle: the sonar, every mounting, the site, the truth."""

    sonar: Sonar = DEFAULT_SONAR
    sonar_mounting: Mounting = field(default_factory=Mounting)
    dvl_mounting: Mounting = field(default_factory=Mounting)
    pressure_mounting: Mounting = field(default_factory=Mounting)
    site: Site | None = None
    gnss_mounting: Mounting | None = None  # the GNSS antenna (``nmea`` device); None: no GNSS receiver
    truth: tuple[TruthObject, ...] = ()
    warning: str = ""  # why the log's stored vehicle configuration was not used ("" when it was)
    truth_skipped: int = 0  # ground-truth entries left out as unusable (NaN, out of range, wrong type)
    truth_problem: str = ""  # why the first of them was

    # the sonar's numbers under the names the pipeline used before they moved into ``sonar``
    @property
    def tilt_deg(self) -> float:
        return self.sonar.tilt_deg

    @property
    def spread_deg(self) -> float:
        return self.sonar.spread_deg

    @property
    def window_start(self) -> float:
        return self.sonar.window_start

    @property
    def window_length(self) -> float:
        return self.sonar.window_length

    @classmethod
    def from_config(cls, config: VehicleConfig, truth: tuple[TruthObject, ...] = (), warning: str = "") -> MissionSetup:
        """The setup of a validated vehicle configuration (devices picked by format / the sonar's name)."""
        sonar = config.sonar.geometry() if config.sonar is not None else DEFAULT_SONAR
        sonar_dev = (config.sonar.device if config.sonar is not None else None) or "sonar"
        sonar_m = dvl_m = pressure_m = Mounting()
        gnss_m: Mounting | None = None
        for dev in config.devices:  # a later device of a role wins, as the log's re-parse did
            if dev.name == sonar_dev or dev.format in ("didson", "aris", "oculus"):
                sonar_m = dev.mounting
            elif dev.format == "pd0":
                dvl_m = dev.mounting
            elif dev.format in ("paro", "keller"):
                pressure_m = dev.mounting
            elif dev.format == "nmea":
                gnss_m = dev.mounting
        return cls(sonar=sonar, sonar_mounting=sonar_m, dvl_mounting=dvl_m, pressure_mounting=pressure_m,
                   site=config.site, gnss_mounting=gnss_m, truth=truth, warning=warning)

    @classmethod
    def from_metadata(cls, meta: Mapping[str, object], config: VehicleConfig | None = None) -> MissionSetup:
        """The setup of a mission log: ``config`` when given, else the log's stored configuration.

        A stored configuration that fails validation gives the defaults and a one-line :attr:`warning`; the
        ground truth is read entry by entry (:func:`~auvlink.pipeline.log_meta.truth_objects`), unusable
        entries counted in :attr:`truth_skipped`.
        """
        gt = truth_objects(meta.get("ground_truth"))
        try:
            if config is None and meta.get("vehicle_config") is not None:
                config = config_from_metadata(meta)
            warning = ""
        except ConfigError as exc:
            warning = (f"the log's vehicle configuration is not valid: {exc}; "
                       "using the default sonar and mountings (give --config CONFIG.toml)")
        setup = cls.from_config(config, gt.objects) if config is not None else cls(truth=gt.objects)
        return replace(setup, warning=warning, truth_skipped=gt.skipped, truth_problem=gt.problem)


def sonar_geometry(setup: MissionSetup, azimuths: np.ndarray | None = None,
                   window: tuple[float, float] | None = None, n_bins: int | None = None) -> SonarGeometry:
    """The :class:`recon.sonar_geometry.SonarGeometry` of this mission: the frames' own beam table, window (m) and
    range lines where given, else the configured sonar model's (:attr:`auvlink.sonar.Sonar.description`)."""
    return SonarGeometry.of(setup.sonar, setup.sonar_mounting, azimuths=azimuths, window=window, n_bins=n_bins)


def nav_config(setup: MissionSetup) -> NavConfig:
    """Navigation set-up: the DVL's full mounting (lever arm, roll, pitch, yaw) and the depth lever arm."""
    roll, pitch, yaw = setup.dvl_mounting.rpy
    mounting = rdi_instrument_mounting(lever_arm=setup.dvl_mounting.xyz, heading_misalignment=yaw,
                                       pitch=pitch, roll=roll)
    return NavConfig(dvl_mounting=mounting, depth_lever_arm=setup.pressure_mounting.xyz)
