"""The auvlink CAN navigation bus: DBC-defined messages <-> :class:`CanNavRecord` in SI units.

The messages (DVL bottom-track velocity and altitude, FOG rates, attitude, pressure and depth)
are defined in the DBC shipped with the package, ``auvlink/data/auvlink_nav.dbc`` (Vector DBC
format, read with cantools); its signals are already in SI units (m, m/s, rad, rad/s, Pa; the
temperature is ``temperature_c`` in degC), so a decoded value is the DBC's physical value.
On the wire (and in the log) each CAN message is one 16-byte raw frame of
:mod:`auvlink.framing.can_frames`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from importlib import resources
from typing import TYPE_CHECKING, Any, cast

from auvlink.errors import DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.can_frames import CanFrame, CanFrameFramer, pack_frame, unpack_frame

if TYPE_CHECKING:
    from cantools.database.can import Database, Message

DBC_RESOURCE = "auvlink_nav.dbc"


@dataclass(frozen=True)
class CanNavRecord:
    """One decoded navigation message: its CAN id, DBC message name and signal values (SI)."""

    arbitration_id: int
    name: str
    signals: dict[str, float]


def dbc_text() -> str:
    """The DBC source shipped with the package (also stored in the mission log's metadata)."""
    return (resources.files("auvlink") / "data" / DBC_RESOURCE).read_text(encoding="utf-8")


@functools.cache
def database() -> Database:
    """The navigation DBC, loaded once per process (cantools is imported on first use)."""
    import cantools

    db = cantools.database.load_string(dbc_text(), database_format="dbc", strict=True)
    assert isinstance(db, cantools.database.can.Database)
    return db


@functools.cache
def _by_id() -> dict[tuple[int, bool], Message]:
    return {(m.frame_id, bool(m.is_extended_frame)): m for m in database().messages}


def message_names() -> list[str]:
    """Names of the messages of the navigation bus, in DBC order."""
    return [m.name for m in database().messages]


def signal_names(name: str) -> list[str]:
    """Names of the signals of message ``name``."""
    return [s.name for s in _message(name).signals]


def _message(name: str) -> Message:
    try:
        return database().get_message_by_name(name)
    except KeyError as exc:
        known = ", ".join(message_names())
        raise EncodeError(f"can: no message {name!r} in the navigation DBC (known: {known})") from exc


def decode(raw: bytes) -> CanNavRecord:
    """A 16-byte raw CAN frame -> :class:`CanNavRecord` (unknown ids raise :class:`DecodeError`)."""
    frame = unpack_frame(raw)
    kind = "extended" if frame.is_extended_id else "standard"
    if frame.is_remote_frame or frame.is_error_frame or frame.is_fd:
        what = "remote" if frame.is_remote_frame else "error" if frame.is_error_frame else "CAN FD"
        raise DecodeError(
            f"can: id 0x{frame.arbitration_id:03X}: a {what} frame is not a navigation message", fmt="can"
        )
    msg = _by_id().get((frame.arbitration_id, frame.is_extended_id))
    if msg is None:
        raise DecodeError(
            f"can: unknown arbitration id 0x{frame.arbitration_id:03X} ({kind}) in the navigation DBC",
            fmt="can",
        )
    if len(frame.data) != msg.length:
        raise DecodeError(
            f"can: {msg.name} (id 0x{frame.arbitration_id:03X}): {len(frame.data)} data bytes, "
            f"expected {msg.length}",
            fmt="can",
        )
    try:
        values = msg.decode(frame.data, decode_choices=False, scaling=True)
    except Exception as exc:  # cantools raises its own error types
        raise DecodeError(f"can: {msg.name}: {exc}", fmt="can") from exc
    assert isinstance(values, dict)
    return CanNavRecord(msg.frame_id, msg.name, {k: float(cast(float, v)) for k, v in values.items()})


def encode(record: CanNavRecord) -> bytes:
    """:class:`CanNavRecord` -> 16-byte raw CAN frame (values out of the DBC range raise)."""
    msg = _message(record.name)
    if record.arbitration_id != msg.frame_id:
        raise EncodeError(
            f"can: {record.name} has id 0x{msg.frame_id:03X}, the record says 0x{record.arbitration_id:03X}"
        )
    try:
        data = msg.encode(dict(record.signals), scaling=True, padding=False, strict=True)
    except Exception as exc:  # cantools EncodeError / KeyError for a missing signal
        raise EncodeError(f"can: {record.name}: cannot encode {record.signals}: {exc}") from exc
    return pack_frame(CanFrame(msg.frame_id, bytes(data), is_extended_id=bool(msg.is_extended_frame)))


def build(name: str, **signals_si: float) -> CanNavRecord:
    """The record of message ``name`` exactly as a receiver will decode it (values quantized).

    A signal left out takes the DBC start value (``GenSigStartValue``: ``valid`` = 1, else 0).
    Used by the simulator: ``raw = encode(build("DVL_BT_VELOCITY", vx=1.0, vy=0.0, vz=0.0))``.
    """
    msg = _message(name)
    unknown = set(signals_si) - {s.name for s in msg.signals}
    if unknown:
        raise EncodeError(f"can: {name} has no signal(s) {sorted(unknown)}; it has {signal_names(name)}")
    values: dict[str, float] = {}
    for sig in msg.signals:
        if sig.name in signals_si:
            values[sig.name] = float(signals_si[sig.name])
        else:
            raw0 = sig.raw_initial if sig.raw_initial is not None else 0
            values[sig.name] = float(raw0) * sig.scale + sig.offset
    return decode(encode(CanNavRecord(msg.frame_id, msg.name, values)))


def to_json(record: CanNavRecord) -> dict[str, Any]:
    return {"arbitration_id": record.arbitration_id, "name": record.name, "signals": dict(record.signals)}


WIRE_FORMAT = WireFormat(
    name="can",
    encoding="can.dbc",
    description="CAN frames of the auvlink navigation DBC (16-byte raw frames, cantools)",
    decode=decode,
    encode=encode,
    framer=CanFrameFramer,
    to_json=to_json,
)
