"""Paroscientific Digiquartz pressure sensors: ASCII ``*ddss...`` lines (RS-232/RS-485).

Specification followed: Paroscientific "Digiquartz programming and operation manual" (command
and response formats). Every line the sensor sends is ``*`` + 2-digit destination + 2-digit source
+ text + CR LF, e.g. ``*00012991.11891`` (to the host 00 from sensor 01):

- a measurement (``*0001`` + number): :class:`ParoReading`;
- a command response ``*ddssXX=...`` (``*0001P4=16.7509,23.01532``, ``*0001UN=1``): kept generically
  as :class:`ParoResponse` (command name and the text after ``=``). For the commands in
  :data:`PRESSURE_TEMPERATURE_COMMANDS` the text is ``pressure,temperature``.

The text is kept exactly as sent, so ``encode(decode(line)) == line``. The pressure unit is a
setting of the sensor (``UN`` command) and is not in the line: :func:`decode` takes ``unit``
(default ``"psi"``, the factory setting) and keeps it in the record; ``pressure_pa`` converts
where the unit is known. Temperatures are taken as degC.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from auvlink.errors import DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.ascii import ParoFramer

FMT = "paro"
TERMINATOR = "\r\n"

#: pressure units the sensor can be set to -> Pa per unit
PA_PER_UNIT: dict[str, float] = {
    "psi": 6894.757293168361,
    "Pa": 1.0,
    "hPa": 100.0,
    "mbar": 100.0,
    "kPa": 1e3,
    "bar": 1e5,
    "MPa": 1e6,
    "inHg": 3386.389,
    "mmHg": 133.322387415,
    "torr": 101325.0 / 760.0,
    "mH2O": 9806.65,
}
#: responses whose text is "pressure,temperature"
PRESSURE_TEMPERATURE_COMMANDS = frozenset({"P4"})

_HEAD = re.compile(r"\*(\d\d)(\d\d)(.+)", re.DOTALL)
_COMMAND = re.compile(r"([A-Z][A-Z0-9]{1,3})=(.*)", re.DOTALL)
_NUMBER = re.compile(r"\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*")
_PRINTABLE = re.compile(r"[\x20-\x7e]*")


def _to_pa(value: float, unit: str) -> float | None:
    factor = PA_PER_UNIT.get(unit)
    return None if factor is None else value * factor


@dataclass(frozen=True, slots=True)
class ParoReading:
    """A measurement line: ``text`` is the number as sent, in ``unit`` (pressure by default)."""

    destination: int
    source: int
    text: str
    unit: str = "psi"

    @property
    def value(self) -> float:
        return float(self.text)

    @property
    def pressure_pa(self) -> float | None:
        """The value in Pa when ``unit`` is a pressure unit, else None."""
        return _to_pa(self.value, self.unit)

    @property
    def temperature_c(self) -> float | None:
        """The value when the sensor was set to send temperature (``unit="degC"``), else None."""
        return self.value if self.unit == "degC" else None


@dataclass(frozen=True, slots=True)
class ParoResponse:
    """A ``*ddssXX=text`` line: the command (``"P4"``, ``"UN"``, ...) and the text after ``=``."""

    destination: int
    source: int
    command: str
    text: str
    unit: str = "psi"

    @property
    def values(self) -> tuple[float, ...] | None:
        """The comma-separated numbers of the text, or None when it is not all numbers."""
        parts = self.text.split(",")
        if not all(_NUMBER.fullmatch(p) for p in parts):
            return None
        return tuple(float(p) for p in parts)

    @property
    def pressure_pa(self) -> float | None:
        """Pressure in Pa for a pressure-and-temperature response in a known unit, else None."""
        v = self.values
        if self.command not in PRESSURE_TEMPERATURE_COMMANDS or not v:
            return None
        return _to_pa(v[0], self.unit)

    @property
    def temperature_c(self) -> float | None:
        """Temperature in degC for a pressure-and-temperature response, else None."""
        v = self.values
        if self.command not in PRESSURE_TEMPERATURE_COMMANDS or not v or len(v) < 2:
            return None
        return v[1]


ParoRecord = ParoReading | ParoResponse


def decode(raw: bytes, unit: str = "psi") -> ParoRecord:
    """Decode one line (the CR LF terminator is optional)."""
    try:
        text = bytes(raw).decode("ascii")
    except UnicodeDecodeError as exc:
        raise DecodeError(f"{FMT}: line is not ASCII: {bytes(raw)!r}", fmt=FMT) from exc
    if text.endswith("\n"):
        text = text[:-2] if text.endswith("\r\n") else text[:-1]
    m = _HEAD.fullmatch(text)
    if m is None or not _PRINTABLE.fullmatch(m.group(3)):
        raise DecodeError(f"{FMT}: not a '*ddss...' line: {text!r}", fmt=FMT)
    dest, src, body = int(m.group(1)), int(m.group(2)), m.group(3)
    cmd = _COMMAND.fullmatch(body)
    if cmd is not None:
        return ParoResponse(dest, src, cmd.group(1), cmd.group(2), unit)
    if _NUMBER.fullmatch(body):
        return ParoReading(dest, src, body, unit)
    raise DecodeError(f"{FMT}: neither a number nor a 'XX=...' response: {text!r}", fmt=FMT, offset=5)


def encode(record: ParoRecord) -> bytes:
    """The line exactly as the sensor sends it, CR LF included."""
    if not (0 <= record.destination <= 99 and 0 <= record.source <= 99):
        raise EncodeError(f"{FMT}: addresses are two decimal digits: {record!r}")
    body = f"{record.command}={record.text}" if isinstance(record, ParoResponse) else record.text
    if not body or not _PRINTABLE.fullmatch(body):
        raise EncodeError(f"{FMT}: text must be printable ASCII on one line: {body!r}")
    return f"*{record.destination:02d}{record.source:02d}{body}{TERMINATOR}".encode("ascii")


def build_reading(
    pressure_pa: float, *, unit: str = "psi", decimals: int = 5, destination: int = 0, source: int = 1
) -> ParoReading:
    """A measurement line for ``pressure_pa`` (for the simulator), written with ``decimals``."""
    factor = PA_PER_UNIT.get(unit)
    if factor is None:
        raise EncodeError(f"{FMT}: unknown pressure unit {unit!r}; known: {', '.join(PA_PER_UNIT)}")
    return ParoReading(destination, source, f"{pressure_pa / factor:.{decimals}f}", unit)


def sensor_time(record: Any) -> float | None:
    """Digiquartz lines carry no clock."""
    return None


def to_json(record: ParoRecord) -> dict[str, Any]:
    """JSON-ready dict: the text as sent, and SI values where the unit is known."""
    out: dict[str, Any] = {
        "type": "response" if isinstance(record, ParoResponse) else "reading",
        "destination": record.destination,
        "source": record.source,
    }
    if isinstance(record, ParoResponse):
        values = record.values
        out.update(command=record.command, text=record.text, values=None if values is None else list(values))
    else:
        out.update(text=record.text, value=record.value)
    out.update(unit=record.unit, pressure_pa=record.pressure_pa, temperature_c=record.temperature_c)
    return out


WIRE_FORMAT = WireFormat(
    name=FMT,
    encoding="paro.digiquartz",
    description="Paroscientific Digiquartz ASCII '*ddss' lines (pressure in psi unless configured)",
    decode=decode,
    encode=encode,
    framer=ParoFramer,
    sensor_time=sensor_time,
    to_json=to_json,
)
