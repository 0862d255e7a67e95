"""KVH DSP-3000 fibre-optic gyro: ASCII output lines.

Specification followed: KVH DSP-3000 technical manual, ASCII output. One line per sample::

    "       0.015733   1\\r\\n"
     |-- 15 chars --||4 |CRLF
     value, 6 decimals  valid flag (1 = data valid, 0 = not)

The value is deg/s in rate mode, deg turned since the previous sample in incremental-angle mode,
and deg since the last reset in integrated-angle mode. The line does not say which mode the unit
is in, so :func:`decode` takes ``mode`` ("rate", "incremental", "integrated"; default "rate") and
keeps it in the record. The record is in SI: rad/s or rad.

:func:`encode` writes the canonical field widths, so ``encode(decode(line)) == line`` for every
line the unit sends; :func:`decode` also accepts other spacing. :func:`build` rounds an SI value
to what the line can carry (6 decimals of a degree), so ``decode(encode(build(...)))`` returns it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from auvlink.errors import DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.ascii import Dsp3000Framer

FMT = "dsp3000"
MODES = ("rate", "incremental", "integrated")
VALUE_WIDTH = 15  # characters of the value field, right justified
DECIMALS = 6
FLAG_WIDTH = 4  # characters of the valid-flag field, right justified
TERMINATOR = "\r\n"

_LINE = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+))\s+([01])\s*")


@dataclass(frozen=True, slots=True)
class Dsp3000Reading:
    """One DSP-3000 sample: ``value`` in rad/s (rate mode) or rad (angle modes)."""

    value: float
    valid: bool = True
    mode: str = "rate"

    @property
    def rate(self) -> float | None:
        """Angular rate in rad/s in rate mode, else None."""
        return self.value if self.mode == "rate" else None

    @property
    def angle(self) -> float | None:
        """Angle in rad in the incremental or integrated mode, else None."""
        return self.value if self.mode != "rate" else None

    @property
    def value_deg(self) -> float:
        """The value in the wire's unit (deg/s or deg)."""
        return math.degrees(self.value)


def _check_mode(mode: str) -> None:
    if mode not in MODES:
        raise ValueError(f"{FMT}: mode must be one of {MODES}, not {mode!r}")


def decode(raw: bytes, mode: str = "rate") -> Dsp3000Reading:
    """Decode one line (terminator optional)."""
    _check_mode(mode)
    try:
        text = bytes(raw).decode("ascii")
    except UnicodeDecodeError as exc:
        raise DecodeError(f"{FMT}: line is not ASCII: {bytes(raw)!r}", fmt=FMT) from exc
    m = _LINE.fullmatch(text)
    if m is None:
        raise DecodeError(f"{FMT}: not a '<value> <flag>' line: {text!r}", fmt=FMT)
    return Dsp3000Reading(math.radians(float(m.group(1))), m.group(2) == "1", mode)


def encode(reading: Dsp3000Reading) -> bytes:
    """The canonical line: value in a 15-character field with 6 decimals, flag in 4, CR LF."""
    deg = math.degrees(reading.value)
    if not math.isfinite(deg):
        raise EncodeError(f"{FMT}: cannot encode a non-finite value {reading.value!r}")
    flag = 1 if reading.valid else 0
    return f"{deg:{VALUE_WIDTH}.{DECIMALS}f}{flag:{FLAG_WIDTH}d}{TERMINATOR}".encode("ascii")


def build(value: float, *, valid: bool = True, mode: str = "rate") -> Dsp3000Reading:
    """A reading from an SI value (rad/s or rad), rounded to the line's 6 decimals of a degree."""
    _check_mode(mode)
    if not math.isfinite(value):
        raise EncodeError(f"{FMT}: cannot build a reading from {value!r}")
    return Dsp3000Reading(math.radians(round(math.degrees(value), DECIMALS)), bool(valid), mode)


def sensor_time(record: Any) -> float | None:
    """The DSP-3000 line carries no clock."""
    return None


def to_json(record: Dsp3000Reading) -> dict[str, Any]:
    """JSON-ready dict in SI units."""
    return {
        "mode": record.mode,
        "value": record.value,
        "unit": "rad/s" if record.mode == "rate" else "rad",
        "valid": record.valid,
    }


def wire_format(mode: str = "rate") -> WireFormat:
    """The wire format for a unit set to ``mode``. Only "rate" is the registered ``dsp3000``; the
    others are named ``dsp3000_incremental`` / ``dsp3000_integrated`` (register them to use them)."""
    _check_mode(mode)
    name = FMT if mode == "rate" else f"{FMT}_{mode}"
    encoding = "kvh.dsp3000" if mode == "rate" else f"kvh.dsp3000.{mode}"

    def _decode(raw: bytes) -> Dsp3000Reading:
        return decode(raw, mode)

    return WireFormat(
        name=name,
        encoding=encoding,
        description=f"KVH DSP-3000 ASCII FOG lines ({mode} mode)",
        decode=_decode,
        encode=encode,
        framer=Dsp3000Framer,
        sensor_time=sensor_time,
        to_json=to_json,
    )


WIRE_FORMAT = wire_format("rate")
WIRE_FORMAT_INCREMENTAL = wire_format("incremental")
WIRE_FORMAT_INTEGRATED = wire_format("integrated")
