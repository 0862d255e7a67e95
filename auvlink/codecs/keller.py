"""Keller Series 30 pressure transmitters on the Keller bus (RS-485): F48 and F73 frames.

Specification followed: Keller "Communication protocol for Keller Series 30 (bus)". Every frame
ends with a CRC-16/MODBUS of the bytes before it, sent HIGH byte first::

    F48 initialise   request   [addr, 48, CRC_H, CRC_L]
                     response  [addr, 48, class, group, year, week, buffer, status, CRC_H, CRC_L]
    F73 read channel request   [addr, 73, channel, CRC_H, CRC_L]
                     response  [addr, 73, float32 (big endian), status, CRC_H, CRC_L]
    exception        response  [addr, function | 0x80, code, CRC_H, CRC_L]

A F73 response does not say which channel it answers, so :class:`KellerReadResponse` keeps the
float as sent (bar for pressure channels, degC for temperature channels). :func:`pair` and
:func:`iter_readings` join a request with its response into a :class:`KellerReading` in SI units
(pressure in Pa = bar * 1e5). Assumption: the transmitter is set to its factory pressure unit, bar.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from auvlink.crc import crc16_modbus
from auvlink.errors import ChecksumError, DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.keller import EXCEPTION_FLAG, F_INIT, F_READ, KellerFramer

FMT = "keller"
PA_PER_BAR = 1e5

#: F73 channel numbers -> (name, unit of the float on the wire)
CHANNELS: dict[int, tuple[str, str]] = {
    0: ("CH0", ""),
    1: ("P1", "bar"),
    2: ("P2", "bar"),
    3: ("T", "degC"),
    4: ("TOB1", "degC"),
    5: ("TOB2", "degC"),
}
CH_P1, CH_P2, CH_T, CH_TOB1, CH_TOB2 = 1, 2, 3, 4, 5

EXCEPTION_CODES: dict[int, str] = {
    1: "illegal non-implemented function",
    2: "illegal data address",
    3: "illegal data value",
    32: "initialisation required (send F48 first)",
}

_INIT_RESPONSE = struct.Struct(">BB6B")  # addr, 48, class, group, year, week, buffer, status
_READ_RESPONSE = struct.Struct(">BBfB")  # addr, 73, value, status
_F32 = struct.Struct(">f")


@dataclass(frozen=True, slots=True)
class KellerInitRequest:
    """F48: initialise and identify (the first request after power-up)."""

    address: int


@dataclass(frozen=True, slots=True)
class KellerInitResponse:
    """Answer to F48: device identification."""

    address: int
    device_class: int = 5
    group: int = 20
    year: int = 0
    week: int = 0
    buffer: int = 0
    status: int = 0


@dataclass(frozen=True, slots=True)
class KellerReadRequest:
    """F73: read the floating-point value of a channel (1 = P1 pressure, 4 = TOB1 temperature)."""

    address: int
    channel: int

    @property
    def channel_name(self) -> str:
        return CHANNELS.get(self.channel, (f"CH{self.channel}", ""))[0]


@dataclass(frozen=True, slots=True)
class KellerReadResponse:
    """Answer to F73: the value in the channel's wire unit (bar or degC) and the status byte."""

    address: int
    value: float
    status: int = 0


@dataclass(frozen=True, slots=True)
class KellerException:
    """An exception response: the function asked for (without the 0x80 flag) and the error code."""

    address: int
    function: int
    code: int

    @property
    def message(self) -> str:
        return EXCEPTION_CODES.get(self.code, f"exception code {self.code}")


KellerRecord = (
    KellerInitRequest | KellerInitResponse | KellerReadRequest | KellerReadResponse | KellerException
)


@dataclass(frozen=True, slots=True)
class KellerReading:
    """A F73 response joined with its request: the value now knows its channel."""

    address: int
    channel: int
    value: float  # wire unit: bar (P1, P2) or degC (T, TOB1, TOB2)
    status: int = 0

    @property
    def channel_name(self) -> str:
        return CHANNELS.get(self.channel, (f"CH{self.channel}", ""))[0]

    @property
    def wire_unit(self) -> str:
        return CHANNELS.get(self.channel, ("", ""))[1]

    @property
    def pressure_pa(self) -> float | None:
        """Pressure in Pa for a pressure channel (P1, P2), else None."""
        return self.value * PA_PER_BAR if self.wire_unit == "bar" else None

    @property
    def temperature_c(self) -> float | None:
        """Temperature in degC for a temperature channel (T, TOB1, TOB2), else None."""
        return self.value if self.wire_unit == "degC" else None


def _with_crc(body: bytes) -> bytes:
    return body + crc16_modbus(body).to_bytes(2, "big")


def decode(raw: bytes) -> KellerRecord:
    """Decode one whole frame (request, response or exception), CRC checked."""
    raw = bytes(raw)
    if len(raw) < 4:
        raise DecodeError(f"{FMT}: a frame has at least 4 bytes, got {len(raw)}", fmt=FMT)
    expected = int.from_bytes(raw[-2:], "big")
    actual = crc16_modbus(raw[:-2])
    if expected != actual:
        raise ChecksumError(FMT, expected, actual)
    addr, func, n = raw[0], raw[1], len(raw)
    if func & EXCEPTION_FLAG and n == 5:
        return KellerException(addr, func & ~EXCEPTION_FLAG & 0xFF, raw[2])
    if func == F_INIT and n == 4:
        return KellerInitRequest(addr)
    if func == F_INIT and n == 10:
        _, _, cls, group, year, week, buf, stat = _INIT_RESPONSE.unpack(raw[:-2])
        return KellerInitResponse(addr, cls, group, year, week, buf, stat)
    if func == F_READ and n == 5:
        return KellerReadRequest(addr, raw[2])
    if func == F_READ and n == 9:
        _, _, value, stat = _READ_RESPONSE.unpack(raw[:-2])
        return KellerReadResponse(addr, value, stat)
    raise DecodeError(f"{FMT}: no frame of function {func} has {n} bytes", fmt=FMT, offset=1)


def encode(record: KellerRecord) -> bytes:
    """Encode a record into its wire frame (CRC appended, high byte first)."""
    try:
        if isinstance(record, KellerInitRequest):
            body = bytes([record.address, F_INIT])
        elif isinstance(record, KellerInitResponse):
            r = record
            body = _INIT_RESPONSE.pack(
                r.address, F_INIT, r.device_class, r.group, r.year, r.week, r.buffer, r.status
            )
        elif isinstance(record, KellerReadRequest):
            body = bytes([record.address, F_READ, record.channel])
        elif isinstance(record, KellerReadResponse):
            body = _READ_RESPONSE.pack(record.address, F_READ, record.value, record.status)
        elif isinstance(record, KellerException):
            body = bytes([record.address, record.function | EXCEPTION_FLAG, record.code])
        else:
            raise EncodeError(f"{FMT}: cannot encode a {type(record).__name__}")
    except (struct.error, OverflowError, ValueError, TypeError) as exc:
        raise EncodeError(f"{FMT}: cannot encode {record!r}: {exc}") from exc
    return _with_crc(body)


def pair(request: KellerReadRequest, response: KellerReadResponse) -> KellerReading:
    """Join a F73 request with its response (same address) into a reading that knows its channel."""
    if request.address != response.address:
        raise DecodeError(
            f"{FMT}: response from address {response.address} does not answer a request to "
            f"address {request.address}",
            fmt=FMT,
        )
    return KellerReading(response.address, request.channel, response.value, response.status)


def iter_readings(records: Iterable[Any]) -> Iterator[KellerReading]:
    """Readings from a stream of decoded records: each response paired with the last request to
    its address. A response without a request, or an exception, is skipped (and clears the wait)."""
    pending: dict[int, KellerReadRequest] = {}
    for rec in records:
        if isinstance(rec, KellerReadRequest):
            pending[rec.address] = rec
        elif isinstance(rec, KellerReadResponse):
            req = pending.pop(rec.address, None)
            if req is not None:
                yield pair(req, rec)
        elif isinstance(rec, KellerException):
            pending.pop(rec.address, None)


def _f32(x: float) -> float:
    try:
        return float(_F32.unpack(_F32.pack(x))[0])
    except (struct.error, OverflowError) as exc:
        raise EncodeError(f"{FMT}: {x!r} does not fit a float32") from exc


def build_read_response(address: int, channel: int, value_si: float, status: int = 0) -> KellerReadResponse:
    """A F73 response carrying an SI value (Pa for P1/P2, degC for temperatures), float32-rounded."""
    unit = CHANNELS.get(channel, ("", ""))[1]
    wire = value_si / PA_PER_BAR if unit == "bar" else value_si
    return KellerReadResponse(address, _f32(wire), status)


def build_pressure_response(address: int, pressure_pa: float, status: int = 0) -> KellerReadResponse:
    """A read-P1 response for ``pressure_pa`` (for the simulator)."""
    return build_read_response(address, CH_P1, pressure_pa, status)


def sensor_time(record: Any) -> float | None:
    """Keller bus frames carry no clock."""
    return None


def to_json(record: KellerRecord | KellerReading) -> dict[str, Any]:
    """JSON-ready dict. A bare F73 response keeps its wire value (its channel is not known)."""
    if isinstance(record, KellerReading):
        return {
            "type": "reading",
            "address": record.address,
            "channel": record.channel,
            "channel_name": record.channel_name,
            "pressure_pa": record.pressure_pa,
            "temperature_c": record.temperature_c,
            "value": record.value,
            "status": record.status,
        }
    kind = {
        KellerInitRequest: "init_request",
        KellerInitResponse: "init_response",
        KellerReadRequest: "read_request",
        KellerReadResponse: "read_response",
        KellerException: "exception",
    }[type(record)]
    out: dict[str, Any] = {"type": kind}
    out.update({name: getattr(record, name) for name in record.__dataclass_fields__})
    if isinstance(record, KellerReadRequest):
        out["channel_name"] = record.channel_name
    elif isinstance(record, KellerException):
        out["message"] = record.message
    return out


WIRE_FORMAT = WireFormat(
    name=FMT,
    encoding="keller.bus",
    description="Keller Series 30 bus frames: F48 initialise, F73 read channel, exceptions (CRC-16)",
    decode=decode,
    encode=encode,
    framer=KellerFramer,
    sensor_time=sensor_time,
    to_json=to_json,
)
