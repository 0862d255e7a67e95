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

import re

from auvlink.crc import _CRC16_MODBUS as _CRC16_TABLE
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
    """Lengths of the frames at ``buf[start:]`` whose bytes are all present and whose CRC matches.

    One incremental CRC pass serves every candidate length (they share their first bytes)."""
    size = len(buf)
    if size - start < 2:
        return []
    out: list[int] = []
    crc, done, table = 0xFFFF, start, _CRC16_TABLE
    for n in FRAME_LENGTHS.get(buf[start + 1], ()):
        end = start + n
        if end > size:
            break
        for b in buf[done : end - 2]:
            crc = (crc >> 8) ^ table[(crc ^ b) & 0xFF]
        done = end - 2
        if crc == buf[end - 2] << 8 | buf[end - 1]:
            out.append(n)
    return out


def _choose(buf: bytearray, matches: list[int], start: int = 0) -> int:
    """Among several CRC-valid lengths, prefer one that the next frame confirms, else the shortest."""
    if len(matches) > 1:
        for n in matches:
            if len(buf) - start == n or _matches(buf, start + n):
                return n
    return matches[0]


#: one byte that is a known function code: the scan jumps over everything else in C
_FUNCTION = re.compile(b"[" + b"".join(b"\\x%02x" % f for f in sorted(FRAME_LENGTHS)) + b"]")


class KellerFramer(Framer):
    """Cuts a stream of Keller bus requests and responses into whole, CRC-checked frames."""

    format_name = "keller"
    max_frame = 2 * MAX_FRAME  # two CRC-valid lengths wait for the next frame to tell

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        n = len(buf)
        p = 0  # bytes before p are consumed (one scan position, never revisited)
        dropped = 0
        while n - p >= 2:
            lengths = FRAME_LENGTHS.get(buf[p + 1])
            if lengths is None:  # jump to the byte before the next known function code
                m = _FUNCTION.search(buf, p + 2)
                q = m.start() - 1 if m else n - 1
                dropped += q - p
                p = q
                continue
            if not final and n - p < lengths[-1]:
                break  # wait until every candidate length could be complete
            matches = _matches(buf, p)
            if not matches:
                if n - p >= lengths[-1]:
                    self.stats.bad_checksums += 1
                elif not any(_matches(buf, i) for i in range(p + 1, n - 1)):
                    break  # end of stream inside a frame: flush counts it as truncated
                dropped += 1
                p += 1
                continue
            if len(matches) > 1 and not final and n - p < matches[-1] + MAX_FRAME:
                break  # two lengths pass their CRC: wait for the next frame to tell which is right
            k = _choose(buf, matches, p)
            frames.append(bytes(buf[p : p + k]))
            p += k
        if final and n - p == 1:
            dropped += 1  # a lone byte cannot be the start of a frame
            p += 1
        self.stats.dropped_bytes += dropped
        del buf[:p]
        return frames
