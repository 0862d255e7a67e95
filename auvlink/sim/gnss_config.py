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
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from auvlink.errors import ConfigError
from auvlink.sim.scene import _int, _num, _table, _vec


@dataclass(frozen=True)
class Gnss:
    """The GNSS receiver and the surface phases of a mission (see the module docstring)."""

    rate_hz: float = 1.0
    sigma_m: float = 0.3  # horizontal, per axis
    start_offset: tuple[float, float] | None = None  # north, east (m) from the first line's start
    wait_before_s: float = 20.0
    wait_after_s: float = 20.0
    lever_arm: tuple[float, float, float] = (0.0, 0.0, -0.5)  # antenna in the body frame FRD (m)
    vertical_rate: float = 0.5  # m/s, fastest dive / climb
    quality: int = 2
    satellites: int = 12
    hdop: float = 0.8



def parse_gnss(doc: Mapping[str, Any]) -> Gnss | None:
    if "gnss" not in doc:
        return None
    t, p = _table(doc, "gnss"), "gnss."
    enabled = t.get("enabled", True)
    if not isinstance(enabled, bool):
        raise ConfigError(f"{p}enabled", f"expected true or false, got {enabled!r}", "write enabled = false")
    if not enabled:
        return None
    offset = _vec(t, "start_offset", p, 2, None) if t.get("start_offset") is not None else None
    if offset is not None and math.hypot(*offset) < 5.0:
        raise ConfigError(f"{p}start_offset", f"{list(offset)} is closer than 5 m to the first line's start",
                          "leave room to dive on the way, or leave the key out (a default approach)")
    lever = _vec(t, "lever_arm", p, 3, [0.0, 0.0, -0.5])
    return Gnss(
        rate_hz=_num(t, "rate_hz", p, 1.0, lo=1.0, hi=10.0),
        sigma_m=_num(t, "sigma_m", p, 0.3, lo=0.0, hi=50.0),
        start_offset=None if offset is None else (offset[0], offset[1]),
        wait_before_s=_num(t, "wait_before_s", p, 20.0, lo=2.0, hi=3600.0),
        wait_after_s=_num(t, "wait_after_s", p, 20.0, lo=2.0, hi=3600.0),
        lever_arm=(lever[0], lever[1], lever[2]),
        vertical_rate=_num(t, "vertical_rate", p, 0.5, lo=0.05, hi=5.0),
        quality=_int(t, "quality", p, 2, lo=1),
        satellites=_int(t, "satellites", p, 12, lo=0),
        hdop=_num(t, "hdop", p, 0.8, lo=0.1, hi=99.0),
    )
