"""Framer for a Keller bus line as a serial tap sees it: requests and responses interleaved.

Specification followed: Keller "Communication protocol for Keller Series 30 (bus)". A frame is
``[address, function, data..., CRC_H, CRC_L]`` with a CRC-16/MODBUS of everything before it, sent
high byte first. Frames carry no length, so the framer knows the lengths of each function it
supports (:data:`FRAME_LENGTHS`: F48 initialise, F73 read channel, and their exception responses)
and accepts the length whose CRC matches.

To decide between a request and a response of the same function (both start ``addr, function``),
the framer waits until the longest candidate could be complete. When two lengths both pass their
CRC (a 1-in-65536 coincidence) it prefers the one followed by another valid frame, then the
shorter. A position where every candidate fails its CRC counts as a bad checksum; the search
resumes one byte later. Bytes with an unknown function are dropped and counted.
"""

from __future__ import annotations

from auvlink.crc import crc16_modbus
from auvlink.framing.base import Framer

F_INIT = 48
F_READ = 73
EXCEPTION_FLAG = 0x80

#: function byte -> possible frame lengths (CRC included), shortest first
FRAME_LENGTHS: dict[int, tuple[int, ...]] = {
    F_INIT: (4, 10),  # request [addr, 48, crc]; response [addr, 48, class, group, year, week, buf, stat, crc]
    F_READ: (5, 9),  # request [addr, 73, ch, crc]; response [addr, 73, float32, stat, crc]
    F_INIT | EXCEPTION_FLAG: (5,),  # exception [addr, 0xB0, code, crc]
    F_READ | EXCEPTION_FLAG: (5,),  # exception [addr, 0xC9, code, crc]
}
MAX_FRAME = max(max(v) for v in FRAME_LENGTHS.values())


def crc_ok(frame: bytes | bytearray | memoryview) -> bool:
    """True when the last two bytes (high byte first) are the CRC-16/MODBUS of the rest."""
    return len(frame) >= 3 and crc16_modbus(bytes(frame[:-2])) == int.from_bytes(frame[-2:], "big")


def _matches(buf: bytearray | bytes, start: int = 0) -> list[int]:
    """Lengths of the frames at ``buf[start:]`` whose bytes are all present and whose CRC matches."""
    if len(buf) - start < 2:
        return []
    lengths = FRAME_LENGTHS.get(buf[start + 1], ())
    return [n for n in lengths if start + n <= len(buf) and crc_ok(buf[start : start + n])]


def _choose(buf: bytearray, matches: list[int]) -> int:
    """Among several CRC-valid lengths, prefer one that the next frame confirms, else the shortest."""
    if len(matches) > 1:
        for n in matches:
            if len(buf) == n or _matches(buf, n):
                return n
    return matches[0]


class KellerFramer(Framer):
    """Cuts a stream of Keller bus requests and responses into whole, CRC-checked frames."""

    format_name = "keller"
    max_frame = MAX_FRAME

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        while len(buf) >= 2:
            lengths = FRAME_LENGTHS.get(buf[1])
            if lengths is None:
                self._drop(buf, 1)
                continue
            if not final and len(buf) < lengths[-1]:
                break  # wait until every candidate length could be complete
            matches = _matches(buf)
            if not matches:
                if len(buf) >= lengths[-1]:
                    self.stats.bad_checksums += 1
                elif not any(_matches(buf, i) for i in range(1, len(buf) - 1)):
                    break  # end of stream inside a frame: flush counts it as truncated
                self._drop(buf, 1)
                continue
            if len(matches) > 1 and not final and len(buf) < matches[-1] + MAX_FRAME:
                break  # two lengths pass their CRC: wait for the next frame to tell which is right
            n = _choose(buf, matches)
            frames.append(bytes(buf[:n]))
            del buf[:n]
        if final and len(buf) == 1:
            self._drop(buf, 1)  # a lone byte cannot be the start of a frame
        return frames
