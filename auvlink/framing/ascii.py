"""Line framers for the ASCII sensors: KVH DSP-3000 lines and Paroscientific Digiquartz lines.

A line ends with ``\\n`` (the instruments send CR LF). Each format says where in a terminated line
its frame starts (:meth:`AsciiLineFramer._frame_start`): bytes before that are garbage and are
dropped and counted, and a line with no frame in it is dropped whole. A run of bytes with no
terminator longer than ``max_line`` is cut, and a frame longer than ``max_line`` is dropped. At
end of stream an unterminated tail that may be the beginning of a frame counts as truncated; other
tails are dropped.
"""

from __future__ import annotations

import re

from auvlink.framing.base import Framer


class AsciiLineFramer(Framer):
    """Base: cut at ``terminator``, keep the frame the subclass finds at the end of each line."""

    terminator: bytes = b"\n"
    max_line: int = 256

    @property
    def max_frame(self) -> int:  # type: ignore[override]
        return self.max_line

    def _frame_start(self, line: bytes) -> int | None:
        """Offset in ``line`` (terminator included) where its frame starts, or None if it has none."""
        raise NotImplementedError

    def _may_start(self, tail: bytes) -> bool:
        """Whether an unterminated ``tail`` at end of stream may be the beginning of a frame."""
        return True

    def _whole(self, data: bytes | bytearray | memoryview) -> bytes | None:
        line = data if isinstance(data, bytes) else bytes(data)
        term = self.terminator
        if line.endswith(term) and line.find(term) == len(line) - len(term) and self._frame_start(line) == 0:
            return line  # one terminated line, all of it the frame
        return None

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        term = self.terminator
        while True:
            end = buf.find(term)
            if end < 0:
                if len(buf) > self.max_line:
                    self._drop(buf, len(buf) - self.max_line)
                if final and buf and not self._may_start(bytes(buf)):
                    self._drop(buf, len(buf))
                return frames
            line = bytes(buf[: end + len(term)])
            start = self._frame_start(line)
            if start is None or len(line) - start > self.max_line:  # no frame, or one longer than any
                self._drop(buf, len(line))
                continue
            self._drop(buf, start)
            frames.append(line[start:])
            del buf[: len(line) - start]


class Dsp3000Framer(AsciiLineFramer):
    """KVH DSP-3000 lines: a 15-character value (6 decimals), a 4-character valid flag, CR LF.

    The fixed width is what tells a whole line from one joined in the middle: a line is taken as
    the last 21 bytes before its terminator, and only when they have exactly this layout. A value
    wider than its field (|value| >= 1e7, starting with a digit) extends the frame over the digits
    and sign before it.
    """

    format_name = "dsp3000"
    max_line = 64
    WIDTH = 21
    _CANONICAL = re.compile(rb" *[-+]?\d+\.\d{6} {3}[01]\r\n")
    _PARTIAL = re.compile(rb"[ 0-9.+\-\r]*")

    def _frame_start(self, line: bytes) -> int | None:
        start = len(line) - self.WIDTH
        if start < 0 or not self._CANONICAL.fullmatch(line, start):
            return None
        if line[start] in b"0123456789":  # a value that may overflow its field: take all its digits
            while start > 0 and line[start - 1] in b"0123456789":
                start -= 1
            if start > 0 and line[start - 1] in b"+-":
                start -= 1
        return start

    def _may_start(self, tail: bytes) -> bool:
        return self._PARTIAL.fullmatch(tail) is not None


class ParoFramer(AsciiLineFramer):
    """Paroscientific Digiquartz lines: ``*`` + 2-digit destination + 2-digit source + text, CR LF."""

    format_name = "paro"
    max_line = 128
    _LINE = re.compile(rb"\*\d{4}[\x20-\x7e]+\r\n")

    def _frame_start(self, line: bytes) -> int | None:
        start = line.rfind(b"*")
        if start < 0 or not self._LINE.fullmatch(line, start):
            return None
        return start

    def _may_start(self, tail: bytes) -> bool:
        return b"*" in tail
