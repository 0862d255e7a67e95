"""The NMEA 0183 sentence framer: ``$`` (or ``!``) ... ``*hh`` CR LF, tolerant of partial lines and garbage.

Behaviour, for any chunking of the input (linear time, bounded buffer):

- bytes before a ``$`` / ``!`` are garbage: dropped and counted (``stats.dropped_bytes``);
- a frame is the sentence from its start character through its LF (a CR before it is kept: the
  frame is exactly the bytes received, so the log stores them as they came);
- a start character inside a sentence means the sentence before it was cut short (a receiver that
  restarted, a line lost in a UART overrun): the cut part is dropped and counted, the new one begins;
- a sentence longer than :data:`MAX_SENTENCE` (NMEA 0183 allows 82 characters; proprietary sentences
  run longer) or holding a non-printable byte is garbage, dropped;
- a sentence whose ``*hh`` checksum does not match (computed by pynmea2) is dropped and counted in
  ``stats.bad_checksums``; one without a well-formed checksum (``*`` and two upper-case hex digits just
  before CR LF) is dropped as garbage: a sentence is only ever handed on whole and verified;
- every byte is looked at a bounded number of times: the search for the end of a partial sentence
  resumes where the previous feed stopped.
"""

from __future__ import annotations

import re

from auvlink.framing.base import Framer

#: longest sentence kept, start character to LF included
MAX_SENTENCE = 164
_START = re.compile(rb"[$!]")
_STOP = re.compile(rb"[$!\n]")
_PRINTABLE = re.compile(rb"[\x20-\x7e]*\r?\n")
_CHECKSUM = re.compile(rb"\*([0-9A-F]{2})\r?\n")


def checksum_ok(frame: bytes) -> bool | None:
    """True / False when ``frame`` carries a ``*hh`` checksum that matches / does not; None without one."""
    import pynmea2

    m = _CHECKSUM.search(frame)
    if m is None or m.end() != len(frame):
        return None
    body = frame[1 : m.start()].decode("ascii")
    return int(pynmea2.NMEASentence.checksum(body)) == int(m.group(1), 16)


class NmeaFramer(Framer):
    """Cut NMEA 0183 sentences (see the module docstring)."""

    format_name = "nmea"

    def __init__(self) -> None:
        super().__init__()
        self._clean = 1  # buf[1:_clean] (when buf starts a sentence) holds no start character and no LF

    def reset(self) -> None:
        super().reset()
        self._clean = 1

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        line = data if isinstance(data, bytes) else bytes(data)
        if not (6 <= len(line) <= MAX_SENTENCE and line[0] in b"$!"):
            return None
        m = _STOP.search(line, 1)
        if m is None or m.start() != len(line) - 1 or not _PRINTABLE.fullmatch(line, 1):
            return None
        return line if checksum_ok(line) else None

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        n = len(buf)
        pos = 0
        dropped = 0
        while pos < n:
            if buf[pos] not in b"$!":
                m = _START.search(buf, pos)
                s = m.start() if m is not None else n
                dropped += s - pos
                pos = s
                self._clean = 1
                continue
            scan_from = pos + max(1, self._clean) if pos == 0 else pos + 1
            limit = min(n, pos + MAX_SENTENCE)
            m = _STOP.search(buf, scan_from, limit)
            if m is None:
                if limit - pos >= MAX_SENTENCE:  # too long without an end: garbage up to the limit
                    dropped += limit - pos
                    pos = limit
                    self._clean = 1
                    continue
                # a partial sentence: keep it, remember how far it was searched
                self._clean = n - pos
                break
            end = m.start()
            self._clean = 1
            if buf[end] != 0x0A:  # a new sentence began before this one ended
                dropped += end - pos
                pos = end
                continue
            frame = bytes(buf[pos : end + 1])
            pos = end + 1
            if len(frame) < 6 or not _PRINTABLE.fullmatch(frame, 1):
                dropped += len(frame)
                continue
            ok = checksum_ok(frame)
            if not ok:
                self.stats.bad_checksums += ok is False
                dropped += len(frame)
                continue
            frames.append(frame)
        self.stats.dropped_bytes += dropped
        del buf[:pos]
        if not buf or final:
            self._clean = 1
        return frames
