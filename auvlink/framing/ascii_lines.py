"""A generic framer for ASCII line protocols: a line starts where a start predicate allows and ends
with a terminator (``\\r\\n`` by default). Used by RDI PD6 (``:`` ... CR LF) and reusable by any
line format.

Behaviour, for any chunking of the input:

- bytes before a start character are garbage: dropped and counted (``stats.dropped_bytes``);
- a frame is the line from its start character through the terminator, terminator included
  (exactly the bytes received, so the log can store them as they came);
- with ``resync_on_start`` a start character inside a line means the line before it was cut
  short: the cut part is dropped and the new line begins there (for formats whose start
  character never occurs inside a line, like PD6's ``:``);
- a line longer than ``max_length`` is garbage, dropped through its terminator (or, with
  ``resync_on_start``, up to the next start character), whatever the chunking: a missing
  terminator cannot block the stream;
- at end of stream an unterminated line counts as truncated (:meth:`Framer.flush`).
"""

from __future__ import annotations

import re
from collections.abc import Callable

from auvlink.framing.base import Framer

StartPredicate = Callable[[int], bool]


def _start_pattern(start: bytes | StartPredicate | None) -> re.Pattern[bytes] | None:
    """A regex matching one byte that may start a line (None: any byte): the scan runs in C."""
    if start is None:
        return None
    allowed = bytes(start) if isinstance(start, bytes | bytearray) else bytes(b for b in range(256) if start(b))
    if not allowed:
        return re.compile(rb"(?!)")  # nothing may start a line
    return re.compile(b"[" + b"".join(b"\\x%02x" % b for b in sorted(set(allowed))) + b"]")


class LineFramer(Framer):
    """Cut ASCII lines: ``start`` (bytes of allowed first characters, a predicate on the byte
    value, or None for "any byte") through ``terminator``."""

    format_name = "lines"

    def __init__(
        self,
        terminator: bytes = b"\r\n",
        start: bytes | StartPredicate | None = None,
        *,
        max_length: int = 1024,
        resync_on_start: bool = False,
        format_name: str | None = None,
    ) -> None:
        super().__init__()
        if not terminator:
            raise ValueError("terminator must not be empty")
        self.terminator = terminator
        self.start = start
        self.max_length = max_length
        self.resync_on_start = resync_on_start and start is not None
        if format_name is not None:
            self.format_name = format_name
        self._skipping = False  # inside a line longer than max_length, until its terminator
        self._start_re = _start_pattern(start)
        self._run_re = None if self._start_re is None else re.compile(self._start_re.pattern + b"+")

    def _find_start(self, buf: bytearray, pos: int, stop: int) -> int:
        """Index of the first byte in ``buf[pos:stop]`` that may start a line, or -1 (one C scan)."""
        if self._start_re is None:
            return pos if pos < stop else -1
        m = self._start_re.search(buf, pos, stop)
        return m.start() if m else -1

    @property
    def max_frame(self) -> int:  # type: ignore[override]
        return self.max_length + len(self.terminator)

    def reset(self) -> None:
        super().reset()
        self._skipping = False

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        term = self.terminator
        n = len(buf)
        pos = 0  # bytes before pos are consumed
        dropped = 0
        # The next terminator at or after ``t_from`` (-1: none in the buffer). Remembered, so a run of
        # start characters with no terminator (``::::...``) costs one scan, not one per character.
        t_next, t_from = -1, n + 1
        while pos < n:
            if self._skipping:  # inside an over-long line: discard through its terminator
                t = buf.find(term, pos)
                nxt = self._find_start(buf, pos, t if t >= 0 else n) if self.resync_on_start else -1
                if nxt >= 0:
                    end = nxt
                elif t >= 0:
                    end = t + len(term)
                else:  # keep what may be the first bytes of the terminator
                    end = max(pos, n - len(term) + 1)
                dropped += end - pos
                pos = end
                if nxt < 0 and t < 0:
                    break
                self._skipping = False
                continue
            s = self._find_start(buf, pos, n)
            if s < 0:
                dropped += n - pos  # nothing here can start a line
                pos = n
                break
            dropped += s - pos
            pos = s
            first = s + 1 if self.start is not None else s
            if not (t_from <= first and (t_next < 0 or t_next >= first)):
                t_next, t_from = buf.find(term, first), first
            t = t_next
            if self.resync_on_start:
                nxt = self._find_start(buf, s + 1, t if t >= 0 else n)
                if nxt >= 0:  # a new line began before this one ended: this one was cut short
                    if nxt == s + 1 and self._run_re is not None:  # a run of starts: all but its last are cut
                        run = self._run_re.match(buf, s, t if t >= 0 else n)
                        nxt = run.end() - 1 if run else nxt
                    dropped += nxt - s
                    pos = nxt
                    continue
            if t < 0:
                # too long already, whatever the chunking: more than max_length bytes besides what may be the
                # first bytes of its terminator at the end of the buffer
                if n - s > self.max_length + len(term) - 1:
                    self._skipping = True
                    dropped += 1
                    pos = s + 1
                    continue
                break  # wait for the terminator (flush counts the partial line as truncated)
            end = t + len(term)
            if t == s or end - s > self.max_length + len(term):
                dropped += end - s  # an empty or over-long line
            else:
                frames.append(bytes(buf[s:end]))
            pos = end
        if final:
            self._skipping = False
        self.stats.dropped_bytes += dropped
        del buf[:pos]
        return frames
