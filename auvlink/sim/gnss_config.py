"""The ``[gnss]`` table of a scene: a GNSS receiver, and a mission that starts and ends at the surface.

Present (and not ``enabled = false``): the vehicle waits on the surface at the start point with GNSS
fixes, dives on its way to the first line's start, flies the survey, climbs back at the end of the
last line and waits on the surface again with fixes (:mod:`auvlink.sim.trajectory`,
:mod:`auvlink.sim.gnss`). Keys, all optional:

- ``rate_hz`` (1.0, in [1, 10]): fixes per second (GGA + RMC + ZDA each);
- ``sigma_m`` (0.3): horizontal noise of a fix per axis, m (a DGPS-class receiver);
- ``start_offset = [north, east]``: where the vehicle waits, m from the first line's start (at least
  5 m away); default: on the line's extension behind its start, far enough to dive on the way;
- ``wait_before_s`` (20.0) on the surface before the dive, ``wait_after_s`` (20.0) after surfacing;
- ``lever_arm`` (``[0, 0, -0.5]``): the antenna in the body frame FRD, m (a mast above the origin);
- ``vertical_rate`` (0.5 m/s): the fastest dive and climb;
- ``quality`` (2 = DGPS), ``satellites`` (12), ``hdop`` (0.8): what the receiver reports with a fix.

The receiver reports fix quality 0 (empty position) while its antenna is under water.
"""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import Field
from pydantic.dataclasses import dataclass as model

from auvlink.errors import ConfigError
from auvlink.validation import CONFIG, Boolean, Integer, Number, Vec2, Vec3


@model(frozen=True, config=CONFIG)
class Gnss:
    """The GNSS receiver and the surface phases of a mission (see the module docstring)."""

    enabled: Boolean = True
    rate_hz: Annotated[Number, Field(ge=1.0, le=10.0, description="fixes per second")] = 1.0
    sigma_m: Annotated[Number, Field(ge=0.0, le=50.0, description="horizontal noise per axis, m")] = 0.3
    start_offset: Annotated[Vec2 | None, Field(description="north, east (m) from the first line's start")] = None
    wait_before_s: Annotated[Number, Field(ge=2.0, le=3600.0, description="s on the surface before the dive")] = 20.0
    wait_after_s: Annotated[Number, Field(ge=2.0, le=3600.0, description="s on the surface after surfacing")] = 20.0
    lever_arm: Annotated[Vec3, Field(description="antenna in the body frame FRD, m")] = (0.0, 0.0, -0.5)
    vertical_rate: Annotated[Number, Field(ge=0.05, le=5.0, description="fastest dive / climb, m/s")] = 0.5
    quality: Annotated[Integer, Field(ge=1, le=8, description="GGA fix quality with a fix")] = 2
    satellites: Annotated[Integer, Field(ge=0, le=99)] = 12
    hdop: Annotated[Number, Field(ge=0.1, le=99.0)] = 0.8


def check_gnss(g: Gnss | None) -> Gnss | None:
    """The table's checks beyond single values; None when absent or ``enabled = false``."""
    if g is None or not g.enabled:
        return None
    if g.start_offset is not None and math.hypot(*g.start_offset) < 5.0:
        raise ConfigError("gnss.start_offset", f"{list(g.start_offset)} is closer than 5 m to the first line's start",
                          "leave room to dive on the way, or leave the key out (a default approach)")
    if any(abs(v) > 10.0 for v in g.lever_arm):
        raise ConfigError("gnss.lever_arm", f"{list(g.lever_arm)} is out of range", "use values in [-10, 10] m")
    return g
