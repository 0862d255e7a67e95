"""Whether a GNSS fix is a measured, plausible position: the gate every fix passes before navigation uses it.

- **Fix quality.** GGA quality 1 (GPS), 2 (DGPS), 4 (RTK fixed) and 5 (RTK float) are measured
  positions (:data:`MEASURED_QUALITY`). 0 is no fix; 3 (PPS), 6 (estimated: the receiver's own dead
  reckoning), 7 (manual input) and 8 (simulation) are not measurements of where the antenna is, and
  any other code is unknown. An RMC sentence has no quality field: status ``A`` with a mode of
  ``A`` / ``D`` / ``P`` / ``R`` / ``F`` (or no mode field, before NMEA 2.3) is measured; its mode is
  mapped to the GGA code of the same meaning (:data:`RMC_MODE_QUALITY`).
- **Plausible values.** Latitude in [-90, 90] deg, longitude in [-180, 180] deg, both finite; HDOP,
  when the receiver sends one, finite and > 0 (a dilution of precision is at least a fraction of 1).

:func:`fix_rejection` gives the reason a fix is not used (a count key: ``no_fix``, ``quality_<name>``,
``implausible``), or None; :func:`implausible` gives the human-readable reason for the values.
"""

from __future__ import annotations

import math

#: GGA fix-quality codes (NMEA 0183 v4.11)
QUALITY = {0: "no fix", 1: "GPS", 2: "DGPS", 3: "PPS", 4: "RTK fixed", 5: "RTK float", 6: "estimated",
           7: "manual", 8: "simulation"}
#: the qualities of a measured position (NMEA 0183 v4.11 GGA field 6)
MEASURED_QUALITY = frozenset({1, 2, 4, 5})
#: RMC mode indicator (NMEA 0183 v2.3+ field 12) -> the GGA quality of the same meaning; "" (no mode field,
#: NMEA before 2.3) with status A is an autonomous fix
RMC_MODE_QUALITY = {"A": 1, "D": 2, "P": 1, "R": 4, "F": 5, "E": 6, "M": 7, "S": 8, "N": 0, "": 1}


def implausible(latitude_deg: float, longitude_deg: float, hdop: float = math.nan) -> str | None:
    """Why a position cannot be a fix (out of range, not finite, HDOP <= 0), or None; NaN HDOP = not sent."""
    if not (math.isfinite(latitude_deg) and math.isfinite(longitude_deg)):
        return f"latitude {latitude_deg} / longitude {longitude_deg} not finite"
    if not -90.0 <= latitude_deg <= 90.0:
        return f"latitude {latitude_deg:g} deg outside [-90, 90]"
    if not -180.0 <= longitude_deg <= 180.0:
        return f"longitude {longitude_deg:g} deg outside [-180, 180]"
    if math.isinf(hdop) or (math.isfinite(hdop) and hdop <= 0.0):
        return f"HDOP {hdop:g} is not > 0"
    return None


def quality_key(quality: int) -> str:
    """The count key of a fix quality that is not a measured position (``no_fix``, ``quality_estimated``...)."""
    if quality <= 0:
        return "no_fix"
    return "quality_" + QUALITY.get(quality, "unknown").replace(" ", "_").lower()


def fix_rejection(quality: int, latitude_deg: float, longitude_deg: float, hdop: float = math.nan) -> str | None:
    """The count key of the reason a fix is not used (module docstring), or None for a usable fix."""
    if quality <= 0 or (math.isnan(latitude_deg) and math.isnan(longitude_deg)):
        return "no_fix"
    if quality not in MEASURED_QUALITY:
        return quality_key(quality)
    return "implausible" if implausible(latitude_deg, longitude_deg, hdop) is not None else None
