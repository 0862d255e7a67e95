"""Framer for the KVH DSP-1750/1760 36-byte binary message (KVH DSP-1760 technical manual).

A message is ``FE 81 FF 55`` + 28 bytes of payload + a CRC-32/MPEG-2 of bytes 0..31 (u32, big
endian). The framer finds the header, waits for 36 bytes and checks the CRC. A message whose CRC
fails is counted in ``stats.bad_checksums`` and the search resumes one byte after its header, so a
good message that overlaps a damaged one is still found. Bytes that cannot start a message
(anything before a header, the KVH built-in-test messages among them) are dropped and counted.
"""

from __future__ import annotations

from auvlink.crc import crc32_mpeg2
from auvlink.framing.base import Framer

#: the four header bytes of a normal (rate or delta-angle) message
HEADER = b"\xfe\x81\xff\x55"
#: total message length in bytes, CRC included
FRAME_SIZE = 36
#: bytes covered by the CRC (everything before it)
CRC_SPAN = 32


def crc_ok(frame: bytes | bytearray | memoryview) -> bool:
    """True when the CRC in bytes 32..35 matches the CRC-32/MPEG-2 of bytes 0..31."""
    return crc32_mpeg2(bytes(frame[:CRC_SPAN])) == int.from_bytes(frame[CRC_SPAN:FRAME_SIZE], "big")


def _partial_header(buf: bytearray) -> int:
    """Length of the longest tail of ``buf`` that is a proper prefix of :data:`HEADER`."""
    for n in range(min(len(HEADER) - 1, len(buf)), 0, -1):
        if buf[-n:] == HEADER[:n]:
            return n
    return 0


class Dsp1760Framer(Framer):
    """Cuts a byte stream into whole, CRC-checked 36-byte DSP-1760 messages."""

    format_name = "dsp1760"
    max_frame = FRAME_SIZE

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        if len(data) == FRAME_SIZE and data[:4] == HEADER and crc_ok(data):
            return bytes(data)
        return None

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        while True:
            start = buf.find(HEADER)
            if start < 0:
                # keep a tail that may be the beginning of the next header (unless at end of stream)
                keep = 0 if final else _partial_header(buf)
                self._drop(buf, len(buf) - keep)
                return frames
            self._drop(buf, start)
            if len(buf) < FRAME_SIZE:
                return frames  # partial message: wait (flush counts it as truncated)
            if crc_ok(buf):
                frames.append(bytes(buf[:FRAME_SIZE]))
                del buf[:FRAME_SIZE]
            else:
                self.stats.bad_checksums += 1
                self._drop(buf, 1)
