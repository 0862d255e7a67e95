"""The one description of the forward-scan sonar and of a device's mounting (core; no numpy).

:class:`Sonar` is the geometry every layer shares: the vehicle configuration's ``[sonar]`` table
(:class:`auvlink.config.VehicleSonar` adds which device it is), the scene's ``[sonar]`` table
(:class:`auvlink.sim.scene.SonarConfig` adds the frame rate, lever arm and rays per beam), the
pipeline's :class:`~auvlink.pipeline.setup.MissionSetup` and recon's
:class:`~recon.sonar_geometry.SonarGeometry` (built with ``SonarGeometry.of``). Degrees and metres
as a person writes them; :attr:`Sonar.tilt` and :attr:`Sonar.spread` give radians.

:class:`Mounting` places a device in the body frame B (FRD): lever arm ``xyz`` (m) and rotation
``rpy_deg`` (roll, pitch, yaw of the device in B, degrees, R_BX = Rz(yaw) Ry(pitch) Rx(roll)).
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field
from pydantic.dataclasses import dataclass

from auvlink.validation import CONFIG, Number, Vec3

#: largest range window start and length (m): far beyond any imaging sonar's reach
MAX_WINDOW_M = 200.0


@dataclass(frozen=True, kw_only=True, config=CONFIG)
class Sonar:
    """Geometry of the forward-scan sonar: tilt and vertical spread (deg), range window (m)."""

    tilt_deg: Annotated[Number, Field(gt=-90.0, lt=90.0, description="pitch down of the boresight, deg (+ looks down)")]
    spread_deg: Annotated[Number, Field(gt=0.0, lt=90.0, description="vertical beam spread, deg")] = 14.0
    window_start: Annotated[Number, Field(ge=0.0, le=MAX_WINDOW_M, description="start of the range window, m")]
    window_length: Annotated[Number, Field(gt=0.0, le=MAX_WINDOW_M, description="length of the range window, m")]

    @property
    def tilt(self) -> float:
        """Tilt in radians."""
        return math.radians(self.tilt_deg)

    @property
    def spread(self) -> float:
        """Vertical spread in radians."""
        return math.radians(self.spread_deg)

    @property
    def window_end(self) -> float:
        return self.window_start + self.window_length

    def geometry(self) -> Sonar:
        """The shared geometry alone (drops what a subclass adds)."""
        return Sonar(tilt_deg=self.tilt_deg, spread_deg=self.spread_deg, window_start=self.window_start,
                     window_length=self.window_length)


#: the DIDSON-class sonar of the architecture (tilt 30 deg, spread 14 deg, window 1 + 10 m)
DEFAULT_SONAR = Sonar(tilt_deg=30.0, spread_deg=14.0, window_start=1.0, window_length=10.0)

#: lever arms beyond this (m) are typing errors on any AUV
MAX_LEVER_M = 50.0
Lever = Annotated[Vec3, Field(description="lever arm in the body frame (FRD), m")]


@dataclass(frozen=True, config=CONFIG)
class Mounting:
    """Where a device sits on the vehicle: lever arm in the body frame (FRD, m) and its rotation (deg)."""

    xyz: Lever = (0.0, 0.0, 0.0)
    rpy_deg: Annotated[Vec3, Field(description="roll, pitch, yaw of the device in B, deg")] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if any(abs(v) > MAX_LEVER_M for v in self.xyz):
            raise ValueError(f"lever arm {list(self.xyz)} m beyond +-{MAX_LEVER_M} m")
        if any(abs(v) > 360.0 for v in self.rpy_deg):
            raise ValueError(f"rpy_deg {list(self.rpy_deg)} beyond +-360 deg")

    @property
    def rpy(self) -> tuple[float, float, float]:
        """Roll, pitch, yaw in radians."""
        r, p, y = (math.radians(v) for v in self.rpy_deg)
        return (r, p, y)
