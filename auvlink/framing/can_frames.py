"""CAN messages as fixed 16-byte raw frames, and the framer that cuts a stream of them.

A CAN bus carries messages, not bytes. So that the drivers, framers and the mission log treat a
CAN device like every other one, each message travels as one raw frame of :data:`FRAME_SIZE`
bytes (the auvlink CAN record, version 1; big-endian like the bus itself):

======  ====  ============================================================================
offset  size  content
======  ====  ============================================================================
0       4     arbitration id, u32 big-endian (<= 0x7FF standard, <= 0x1FFFFFFF extended)
4       1     flags: bit 0 extended id, 1 remote (RTR), 2 error frame, 3 CAN FD,
              4 bit-rate switch (FD only), 5 error-state indicator (FD only); bits 6-7 zero
5       1     DLC as a byte count, 0..8 (for a remote frame: the requested length)
6       2     marker ``A5 5A`` (never a valid flags or DLC byte, so the framer resyncs fast)
8       8     data, zero-padded after DLC bytes (all zero for a remote frame)
======  ====  ============================================================================

The layout is auvlink's own (no vendor specification); python-can's ``can.Message`` fields map
one to one. CAN FD payloads longer than 8 bytes cannot be carried and are refused.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING

from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.base import Framer

if TYPE_CHECKING:
    import can

FRAME_SIZE = 16
MARKER = b"\xa5\x5a"
MAX_DATA = 8

FLAG_EXTENDED = 0x01
FLAG_REMOTE = 0x02
FLAG_ERROR = 0x04
FLAG_FD = 0x08
FLAG_BRS = 0x10
FLAG_ESI = 0x20
_KNOWN_FLAGS = 0x3F

_LAYOUT = struct.Struct(">IBB2s8s")  # id, flags, dlc, marker, data
_ZEROS = bytes(MAX_DATA)


@dataclass(frozen=True, slots=True)
class CanFrame:
    """One CAN message as carried in a raw frame (python-can's field names)."""

    arbitration_id: int
    data: bytes = b""
    is_extended_id: bool = False
    is_remote_frame: bool = False
    is_error_frame: bool = False
    is_fd: bool = False
    bitrate_switch: bool = False
    error_state_indicator: bool = False
    #: requested length of a remote frame; ``None`` means ``len(data)``
    remote_dlc: int | None = None

    @property
    def dlc(self) -> int:
        return self.remote_dlc if self.is_remote_frame and self.remote_dlc is not None else len(self.data)

    @property
    def flags(self) -> int:
        bits = (
            (self.is_extended_id, FLAG_EXTENDED),
            (self.is_remote_frame, FLAG_REMOTE),
            (self.is_error_frame, FLAG_ERROR),
            (self.is_fd, FLAG_FD),
            (self.bitrate_switch, FLAG_BRS),
            (self.error_state_indicator, FLAG_ESI),
        )
        return sum(bit for on, bit in bits if on)


def frame_problem(raw: bytes | bytearray | memoryview, offset: int = 0) -> str | None:
    """Why the 16 bytes at ``offset`` are not a valid raw CAN frame, or ``None`` when they are."""
    if len(raw) - offset < FRAME_SIZE:
        return f"{len(raw) - offset} bytes, a raw CAN frame has {FRAME_SIZE}"
    arb_id, flags, dlc, marker, data = _LAYOUT.unpack_from(raw, offset)
    if marker != MARKER:
        return f"marker {marker.hex()} is not {MARKER.hex()}"
    if flags & ~_KNOWN_FLAGS:
        return f"unknown flag bits 0x{flags:02X}"
    if flags & (FLAG_BRS | FLAG_ESI) and not flags & FLAG_FD:
        return "bit-rate switch / error-state flags on a classic (non-FD) frame"
    if flags & FLAG_REMOTE and flags & (FLAG_FD | FLAG_ERROR):
        return "remote flag combined with FD or error flag"
    if dlc > MAX_DATA:
        return f"DLC {dlc} > {MAX_DATA}"
    limit = 0x1FFFFFFF if flags & FLAG_EXTENDED else 0x7FF
    if arb_id > limit:
        return f"arbitration id 0x{arb_id:X} exceeds 0x{limit:X}"
    used = 0 if flags & FLAG_REMOTE else dlc
    if data[used:] != _ZEROS[used:]:
        return "non-zero padding after the data bytes"
    return None


def pack_frame(frame: CanFrame) -> bytes:
    """The 16-byte raw frame of ``frame``; :class:`EncodeError` when it cannot be carried."""
    if len(frame.data) > MAX_DATA:
        raise EncodeError(
            f"CAN id 0x{frame.arbitration_id:X}: {len(frame.data)} data bytes, a raw frame carries {MAX_DATA}"
        )
    if frame.is_remote_frame and frame.data:
        raise EncodeError(f"CAN id 0x{frame.arbitration_id:X}: a remote frame carries no data")
    if not 0 <= frame.dlc <= MAX_DATA or not 0 <= frame.arbitration_id <= 0xFFFFFFFF:
        raise EncodeError(f"CAN id 0x{frame.arbitration_id:X}: DLC {frame.dlc} or id out of range")
    raw = _LAYOUT.pack(frame.arbitration_id, frame.flags, frame.dlc, MARKER, frame.data)
    problem = frame_problem(raw)
    if problem is not None:
        raise EncodeError(f"CAN id 0x{frame.arbitration_id:X}: {problem}")
    return raw


def unpack_frame(raw: bytes | bytearray | memoryview) -> CanFrame:
    """The :class:`CanFrame` in a 16-byte raw frame; :class:`DecodeError` when it is not one."""
    if len(raw) != FRAME_SIZE:
        raise DecodeError(f"can: {len(raw)} bytes, a raw CAN frame has {FRAME_SIZE}", fmt="can")
    problem = frame_problem(raw)
    if problem is not None:
        raise DecodeError(f"can: invalid raw frame: {problem}", fmt="can")
    arb_id, flags, dlc, _marker, data = _LAYOUT.unpack(bytes(raw))
    remote = bool(flags & FLAG_REMOTE)
    return CanFrame(
        arbitration_id=arb_id,
        data=b"" if remote else data[:dlc],
        is_extended_id=bool(flags & FLAG_EXTENDED),
        is_remote_frame=remote,
        is_error_frame=bool(flags & FLAG_ERROR),
        is_fd=bool(flags & FLAG_FD),
        bitrate_switch=bool(flags & FLAG_BRS),
        error_state_indicator=bool(flags & FLAG_ESI),
        remote_dlc=dlc if remote else None,
    )


def message_to_frame(msg: can.Message) -> bytes:
    """A python-can message -> its 16-byte raw frame (the timestamp and channel are not kept)."""
    remote = bool(msg.is_remote_frame)
    return pack_frame(
        CanFrame(
            arbitration_id=int(msg.arbitration_id),
            data=b"" if remote else bytes(msg.data),
            is_extended_id=bool(msg.is_extended_id),
            is_remote_frame=remote,
            is_error_frame=bool(msg.is_error_frame),
            is_fd=bool(msg.is_fd),
            bitrate_switch=bool(msg.bitrate_switch),
            error_state_indicator=bool(msg.error_state_indicator),
            remote_dlc=int(msg.dlc) if remote else None,
        )
    )


def frame_to_message(raw: bytes | bytearray | memoryview, timestamp: float = 0.0) -> can.Message:
    """A 16-byte raw frame -> ``can.Message`` (:class:`DecodeError` when the frame is invalid)."""
    import can

    f = unpack_frame(raw)
    return can.Message(
        timestamp=timestamp,
        arbitration_id=f.arbitration_id,
        is_extended_id=f.is_extended_id,
        is_remote_frame=f.is_remote_frame,
        is_error_frame=f.is_error_frame,
        is_fd=f.is_fd,
        bitrate_switch=f.bitrate_switch,
        error_state_indicator=f.error_state_indicator,
        dlc=f.dlc,
        data=None if f.is_remote_frame else f.data,
    )


class CanFrameFramer(Framer):
    """Cuts 16-byte raw CAN frames; an invalid window is dropped one byte at a time."""

    format_name = "can"
    max_frame = FRAME_SIZE

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        if len(data) == FRAME_SIZE and data[6:8] == MARKER and frame_problem(data) is None:
            return bytes(data)
        return None

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        out: list[bytes] = []
        pos = 0
        end = len(buf)
        dropped = 0
        while end - pos >= FRAME_SIZE:
            if (buf[pos + 6] == 0xA5 and buf[pos + 7] == 0x5A and not buf[pos + 4] & ~_KNOWN_FLAGS
                    and buf[pos + 5] <= MAX_DATA and frame_problem(buf, pos) is None):  # cheap checks first
                out.append(bytes(buf[pos : pos + FRAME_SIZE]))
                pos += FRAME_SIZE
                continue
            # Resync by one byte; the windows up to the next marker cannot be valid, so jump there.
            nxt = buf.find(MARKER, pos + 7)
            skip = nxt - 6 - pos if nxt >= 0 else end - pos - (FRAME_SIZE - 1)
            skip = max(1, skip)
            pos += skip
            dropped += skip
        del buf[:pos]
        self.stats.dropped_bytes += dropped
        return out
