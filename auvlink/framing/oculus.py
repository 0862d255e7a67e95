"""Framer for a TCP stream of Blueprint Oculus network messages (16-byte header + payload).

A message has no checksum. It is found by its id (``53 4F``, 0x4F53 little-endian) and a sane header:
a known message id, version 0..2 and a payload no larger than
:data:`~auvlink.framing.oculus_defs.MAX_PAYLOAD`
(the largest image accepted: 1024 beams x 4096 range lines x 4 bytes, a gain per line, 4096 B of fields
and bearings). Its length is ``16 + payloadSize``. A damaged header can claim the wrong length, so a
candidate that holds another sane header is treated as cut short (dropped, counted as truncated) and
framing resumes at the inner header: a message after a damaged one is not swallowed. The search
position is remembered between feeds, so every byte is searched once (linear time).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from auvlink.framing.base import ResumingFramer
from auvlink.framing.oculus_defs import HEADER, KNOWN_MESSAGES, MAX_PAYLOAD, OCULUS_ID_BYTES

#: highest ``msgVersion`` of the messages in Oculus.h (SimplePingResult V2)
MAX_VERSION = 2
#: the low byte of every known message id (each id is below 256: its high byte is 0)
_KNOWN_LOW = np.zeros(256, dtype=bool)
_KNOWN_LOW[sorted(KNOWN_MESSAGES)] = True


def header_ids(buf: bytes, start: int) -> npt.NDArray[np.intp]:
    """Offsets ``>= start`` of every header id (``53 4F``) in ``buf``, ascending."""
    v = np.frombuffer(buf, np.uint8)
    first = np.flatnonzero(v[start:-1] == OCULUS_ID_BYTES[0]) + start
    return first[v[first + 1] == OCULUS_ID_BYTES[1]]


def message_length(buf: bytes | bytearray, pos: int) -> int:
    """Length of the message whose header starts at ``pos``: > 0 when the header is sane, 0 when it is
    not a message header, -1 when ``buf`` is too short to tell."""
    if len(buf) - pos < HEADER.size:
        return -1
    h = HEADER.unpack_raw(bytes(buf[pos : pos + HEADER.size]))
    if (h["oculus_id"] != 0x4F53 or h["msg_id"] not in KNOWN_MESSAGES or h["msg_version"] > MAX_VERSION
            or h["payload_size"] > MAX_PAYLOAD):
        return 0
    return HEADER.size + int(h["payload_size"])


class OculusFramer(ResumingFramer):
    """Cuts Oculus messages out of a byte stream (see the module docstring)."""

    format_name = "oculus"
    max_frame = HEADER.size + MAX_PAYLOAD

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        raw = data if isinstance(data, bytes) else bytes(data)
        if message_length(raw, 0) != len(raw):
            return None
        # what _extract checks: no sane (or undecidable) header inside the message. The ids are found by numpy (a
        # 2 MB ping read in one pass, the GIL released), those followed by a known message id and version picked
        # at once, and only these headers read whole; an id in the last header's length cannot be told
        ids = header_ids(raw, 1)
        tail = max(1, len(raw) - HEADER.size + 1)
        if ids.size and ids[-1] >= tail:
            return None
        v = np.frombuffer(raw, np.uint8)
        sane = (_KNOWN_LOW[v[ids + 6]] & (v[ids + 7] == 0) & (v[ids + 8] <= MAX_VERSION) & (v[ids + 9] == 0))
        if any(message_length(raw, int(p)) != 0 for p in ids[sane]):
            return None
        return raw

    def _inner_header(self, buf: bytearray, pos: int, n: int, final: bool) -> int:
        """Position of a sane header inside the candidate ``[pos, pos + n)``; -1 none yet (``self._checked``
        records how far the search went), -2 one may start at ``self._checked`` (more bytes needed)."""
        lo = max(pos + 1, self._checked)
        hi = min(len(buf), pos + n + 1)
        while True:
            p = buf.find(OCULUS_ID_BYTES, lo, hi)
            if p < 0:
                self._checked = max(lo, hi - 1)
                return -1
            inner = message_length(buf, p)
            if inner > 0:
                return p
            if inner < 0 and not final:
                self._checked = p
                return -2
            lo = p + 1

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        out: list[bytes] = []
        pos = 0
        while pos < len(buf):
            start = buf.find(OCULUS_ID_BYTES, pos)
            if start < 0:
                keep = 0 if final or buf[-1] != OCULUS_ID_BYTES[0] else 1
                self.stats.dropped_bytes += len(buf) - keep - pos
                pos = len(buf) - keep
                break
            if start > pos:
                self.stats.dropped_bytes += start - pos
                pos = start
                self._checked = 0
            n = message_length(buf, pos)
            if n < 0:
                break
            if n == 0:
                self.stats.dropped_bytes += 1
                pos += 1
                self._checked = 0
                continue
            inner = self._inner_header(buf, pos, n, final)
            if inner >= 0:
                self.stats.dropped_bytes += inner - pos
                self.stats.truncated += 1
                pos = inner
                self._checked = 0
                continue
            if len(buf) - pos < n:
                break
            out.append(bytes(buf[pos : pos + n]))
            pos += n
            self._checked = 0
        self._consume(buf, pos)
        return out
