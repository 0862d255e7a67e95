"""KVH DSP-1750/1760 fibre-optic gyro / IMU: the 36-byte binary message.

Specification followed: KVH DSP-1760 technical manual, "message format" (normal mode). All fields
big endian::

    offset  size  field
    0       4     header FE 81 FF 55
    4       12    gyro x, y, z           float32  rad/s (rate mode) or rad per sample (delta mode)
    16      12    accel x, y, z          float32  g
    28      1     status                 u8       bit 0..2 gyro x/y/z valid, bit 4..6 accel x/y/z valid
    29      1     sequence               u8       0..127 (the unit counts modulo 128; any u8 is kept)
    30      2     temperature            i16      degC
    32      4     CRC-32/MPEG-2 of bytes 0..31 (u32)

Assumptions (the output units are configurable on the unit): ``=ROTUNITS RAD`` (radians, the
factory setting) and the accelerometers in g. ``=ROTFMT RATE`` gives rad/s, ``=ROTFMT DELTA`` gives
the angle turned during one sample (rad); the message does not say which, so :func:`decode` takes
``mode`` ("rate" or "delta", default "rate") and keeps it in the record.

The record is in SI: gyro in rad/s (or rad), accel in m/s^2 (``g * 9.80665``). Decoding then
encoding reproduces the bytes exactly: a float32 times 9.80665 in float64, divided back, rounds to
the same float32 (NaN payloads excepted). :func:`build` quantises SI values to what the wire can
carry, so ``decode(encode(build(...))) == build(...)``.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from auvlink.crc import crc32_mpeg2
from auvlink.errors import ChecksumError, DecodeError, EncodeError
from auvlink.fields import Field, Layout
from auvlink.formats import WireFormat
from auvlink.framing.dsp1760 import CRC_SPAN, FRAME_SIZE, HEADER, Dsp1760Framer

FMT = "dsp1760"
#: standard gravity, m/s^2 per g (the unit's accelerometer scale)
G = 9.80665
MODES = ("rate", "delta")

STATUS_GYRO_X, STATUS_GYRO_Y, STATUS_GYRO_Z = 0x01, 0x02, 0x04
STATUS_ACCEL_X, STATUS_ACCEL_Y, STATUS_ACCEL_Z = 0x10, 0x20, 0x40
STATUS_ALL_VALID = 0x77

MESSAGE = Layout(
    ">",
    [
        Field("header", "4s"),
        Field("gyro_x", "f", 1.0, "rad/s | rad"),
        Field("gyro_y", "f", 1.0, "rad/s | rad"),
        Field("gyro_z", "f", 1.0, "rad/s | rad"),
        Field("accel_x", "f", 1.0, "g"),
        Field("accel_y", "f", 1.0, "g"),
        Field("accel_z", "f", 1.0, "g"),
        Field("status", "B"),
        Field("sequence", "B"),
        Field("temperature", "h", 1.0, "degC"),
        Field("crc", "I"),
    ],
)
assert MESSAGE.size == FRAME_SIZE

#: numpy dtype of one message, for bulk decoding of contiguous captures (:func:`decode_array`)
DTYPE = np.dtype(
    [
        ("header", "S4"),
        ("gyro", ">f4", (3,)),
        ("accel", ">f4", (3,)),
        ("status", "u1"),
        ("sequence", "u1"),
        ("temperature", ">i2"),
        ("crc", ">u4"),
    ]
)
assert DTYPE.itemsize == FRAME_SIZE

_F32 = struct.Struct(">f")
Vec3 = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class Dsp1760Message:
    """One DSP-1760 message in SI units."""

    gyro: Vec3  # rad/s in rate mode, rad (angle per sample) in delta mode; body axes x, y, z
    accel: Vec3  # m/s^2
    status: int  # raw status byte; see the valid-flag properties
    sequence: int
    temperature_c: int
    mode: str = "rate"

    @property
    def gyro_valid(self) -> tuple[bool, bool, bool]:
        s = self.status
        return (bool(s & STATUS_GYRO_X), bool(s & STATUS_GYRO_Y), bool(s & STATUS_GYRO_Z))

    @property
    def accel_valid(self) -> tuple[bool, bool, bool]:
        s = self.status
        return (bool(s & STATUS_ACCEL_X), bool(s & STATUS_ACCEL_Y), bool(s & STATUS_ACCEL_Z))

    @property
    def valid(self) -> bool:
        """All three gyros and all three accelerometers report valid data."""
        return self.status & STATUS_ALL_VALID == STATUS_ALL_VALID

    @property
    def angular_rate(self) -> Vec3 | None:
        """Angular rate in rad/s (rate mode), else None."""
        return self.gyro if self.mode == "rate" else None

    @property
    def delta_angle(self) -> Vec3 | None:
        """Angle turned during the sample in rad (delta mode), else None."""
        return self.gyro if self.mode == "delta" else None

    @property
    def accel_g(self) -> Vec3:
        """Specific force in g, as on the wire."""
        return (self.accel[0] / G, self.accel[1] / G, self.accel[2] / G)


def _check_mode(mode: str) -> None:
    if mode not in MODES:
        raise ValueError(f"{FMT}: mode must be one of {MODES}, not {mode!r}")


def decode(raw: bytes, mode: str = "rate") -> Dsp1760Message:
    """Decode one 36-byte message (header and CRC checked)."""
    _check_mode(mode)
    if len(raw) != FRAME_SIZE:
        raise DecodeError(f"{FMT}: expected {FRAME_SIZE} bytes, got {len(raw)}", fmt=FMT)
    v = MESSAGE.unpack_raw(raw)
    if v["header"] != HEADER:
        raise DecodeError(f"{FMT}: bad header {v['header'].hex()}", fmt=FMT, offset=0)
    actual = crc32_mpeg2(bytes(raw[:CRC_SPAN]))
    if actual != v["crc"]:
        raise ChecksumError(FMT, v["crc"], actual)
    return Dsp1760Message(
        gyro=(v["gyro_x"], v["gyro_y"], v["gyro_z"]),
        accel=(v["accel_x"] * G, v["accel_y"] * G, v["accel_z"] * G),
        status=v["status"],
        sequence=v["sequence"],
        temperature_c=v["temperature"],
        mode=mode,
    )


def encode(msg: Dsp1760Message) -> bytes:
    """Encode a message into its 36 wire bytes (CRC appended)."""
    values = {
        "header": HEADER,
        "gyro_x": msg.gyro[0],
        "gyro_y": msg.gyro[1],
        "gyro_z": msg.gyro[2],
        "accel_x": msg.accel[0] / G,
        "accel_y": msg.accel[1] / G,
        "accel_z": msg.accel[2] / G,
        "status": msg.status,
        "sequence": msg.sequence,
        "temperature": msg.temperature_c,
        "crc": 0,
    }
    try:
        body = MESSAGE.pack(values)[:CRC_SPAN]
    except (struct.error, OverflowError, TypeError) as exc:
        raise EncodeError(f"{FMT}: cannot encode {msg!r}: {exc}") from exc
    return body + crc32_mpeg2(body).to_bytes(4, "big")


def _f32(x: float) -> float:
    try:
        return float(_F32.unpack(_F32.pack(x))[0])
    except (struct.error, OverflowError) as exc:
        raise EncodeError(f"{FMT}: {x!r} does not fit a float32") from exc


def build(
    gyro: Sequence[float] | np.ndarray,
    accel: Sequence[float] | np.ndarray,
    *,
    sequence: int = 0,
    temperature_c: float = 25.0,
    status: int = STATUS_ALL_VALID,
    mode: str = "rate",
) -> Dsp1760Message:
    """A message from SI values, quantised to what the wire carries (for the simulator).

    ``gyro`` is rad/s in rate mode and rad per sample in delta mode; ``accel`` is m/s^2. The
    sequence wraps modulo 128 like the unit's counter (0..127 per the manual); the temperature
    is rounded to whole degC.
    """
    _check_mode(mode)
    if len(gyro) != 3 or len(accel) != 3:
        raise EncodeError(f"{FMT}: gyro and accel need three components")
    g = (_f32(gyro[0]), _f32(gyro[1]), _f32(gyro[2]))
    a = (_f32(accel[0] / G) * G, _f32(accel[1] / G) * G, _f32(accel[2] / G) * G)
    return Dsp1760Message(g, a, status & 0xFF, sequence % 128, round(temperature_c), mode)


def _crc_table() -> np.ndarray:
    """The CRC-32/MPEG-2 lookup table (same polynomial as :func:`auvlink.crc.crc32_mpeg2`)."""
    table = np.zeros(256, dtype=np.uint32)
    for byte in range(256):
        crc = byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7) if crc & 0x80000000 else (crc << 1)
        table[byte] = crc & 0xFFFFFFFF
    return table


_TABLE = _crc_table()


def crc_array(frames: np.ndarray) -> np.ndarray:
    """CRC-32/MPEG-2 of the first 32 bytes of each row of an ``(n, 36)`` uint8 array (vectorized)."""
    crc = np.full(frames.shape[0], 0xFFFFFFFF, dtype=np.uint32)
    for i in range(CRC_SPAN):
        idx = ((crc >> np.uint32(24)) ^ frames[:, i].astype(np.uint32)) & np.uint32(0xFF)
        crc = (crc << np.uint32(8)) ^ _TABLE[idx]
    return crc


def decode_array(data: bytes, mode: str = "rate") -> dict[str, np.ndarray]:
    """Bulk-decode a contiguous run of whole messages (e.g. a framed capture joined back).

    Returns SI arrays: ``gyro`` (n, 3), ``accel`` (n, 3) m/s^2, ``status``, ``sequence``,
    ``temperature_c`` and ``ok`` (header and CRC good). No row is dropped; filter on ``ok``.
    """
    _check_mode(mode)
    if len(data) % FRAME_SIZE:
        raise DecodeError(f"{FMT}: {len(data)} bytes is not a whole number of messages", fmt=FMT)
    rec = np.frombuffer(data, dtype=DTYPE)
    rows = np.frombuffer(data, dtype=np.uint8).reshape(-1, FRAME_SIZE)
    ok = (rec["header"] == HEADER) & (crc_array(rows) == rec["crc"])
    return {
        "gyro": rec["gyro"].astype(np.float64),
        "accel": rec["accel"].astype(np.float64) * G,
        "status": rec["status"].copy(),
        "sequence": rec["sequence"].copy(),
        "temperature_c": rec["temperature"].astype(np.int16),
        "ok": ok,
    }


def sensor_time(record: Any) -> float | None:
    """The DSP-1760 message carries no clock."""
    return None


def to_json(record: Dsp1760Message) -> dict[str, Any]:
    """JSON-ready dict in SI units."""
    return {
        "mode": record.mode,
        "gyro": list(record.gyro),
        "gyro_unit": "rad/s" if record.mode == "rate" else "rad",
        "accel_m_s2": list(record.accel),
        "status": record.status,
        "gyro_valid": list(record.gyro_valid),
        "accel_valid": list(record.accel_valid),
        "sequence": record.sequence,
        "temperature_c": record.temperature_c,
    }


WIRE_FORMAT = WireFormat(
    name=FMT,
    encoding="kvh.dsp1760",
    description="KVH DSP-1750/1760 36-byte binary FOG/IMU messages (rate mode, rad/s, g)",
    decode=decode,
    encode=encode,
    framer=Dsp1760Framer,
    sensor_time=sensor_time,
    to_json=to_json,
)
