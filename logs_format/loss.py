"""What a damaged or cut-off mission log lost: a structured report (JSON-ready) and one line for people.

Every stretch of the file whose messages could not be read is one :class:`LostSpan`:

* ``damaged_chunk``: a chunk found (by its header or the summary's chunk index) whose CRC,
  decompression, size claim or layout failed; its bytes and, from its message index records when they
  survived, its message count are known.
* ``unreadable``: bytes where no record parses (a damaged record header, garbage, zeros), skipped by
  resynchronising on the next record that parses (plausible length, consistent body), and records
  nothing can verify there (a top-level message in a file of chunks, see :mod:`logs_format.walk`).
* ``cut_off``: the end of the file after the last whole record (a log cut off mid-write).

Times are log times (UTC ns). A span's time range comes from the chunk's own header or index entry,
else it is bounded by the readable chunks before and after it (``times_estimated``). Messages lost are
exact where the message indexes survived and are otherwise unknown (``messages_lost_exact`` False);
nothing here guesses a count.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

DAMAGED_CHUNK = "damaged_chunk"
UNREADABLE = "unreadable"
CUT_OFF = "cut_off"


@dataclass
class LostSpan:
    """One stretch of the file whose messages are lost."""

    kind: str  # DAMAGED_CHUNK, UNREADABLE or CUT_OFF
    offset: int  # first byte in the file
    length: int  # bytes
    start_ns: int | None = None  # log-time range the span covered, when known
    end_ns: int | None = None
    messages: int | None = None  # messages lost, when the message indexes tell
    reason: str = ""
    times_estimated: bool = False  # the time range is bounded by the neighbouring chunks

    @property
    def seconds(self) -> float | None:
        if self.start_ns is None or self.end_ns is None:
            return None
        return max(0, self.end_ns - self.start_ns) * 1e-9

    def to_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "offset": self.offset, "bytes": self.length, "start_ns": self.start_ns,
                "end_ns": self.end_ns, "seconds": self.seconds, "messages": self.messages,
                "times_estimated": self.times_estimated, "reason": self.reason}


@dataclass
class LossReport:
    """What a damaged or cut-off log lost. A ``complete`` log that read whole reports nothing lost."""

    complete: bool = False  # footer and closing magic present
    file_bytes: int = 0
    valid_bytes: int = 0  # bytes up to the end of the last whole record
    lost_bytes: int = 0  # bytes after it (a partial record, garbage, zeros): the cut-off tail
    first_time_ns: int | None = None  # oldest log time in the log
    last_time_ns: int | None = None  # newest log time among the chunks that survived whole
    lost_from_ns: int | None = None  # start time of the partial chunk at the end, when its header survived
    bad_chunks: int = 0  # chunks whose CRC, decompression or layout failed (skipped)
    bad_chunk_bytes: int = 0
    orphan_messages: int = 0  # messages whose channel definition was lost
    reason: str = ""  # the last problem met, for people
    summary_index: bool = False  # chunks were located with the summary's chunk index
    spans: list[LostSpan] = field(default_factory=list)

    # -- filled by the scan and the reader ---------------------------------------------------
    def add(self, span: LostSpan) -> None:
        """Record one lost span (a damaged chunk is counted once, by its offset)."""
        if any(s.offset == span.offset and s.kind == span.kind for s in self.spans):
            return
        self.spans.append(span)
        self.spans.sort(key=lambda s: s.offset)
        if span.kind == DAMAGED_CHUNK:
            self.bad_chunks += 1
            self.bad_chunk_bytes += span.length
        if span.reason:
            self.reason = f"{span.reason} at byte {span.offset}"

    # -- derived -----------------------------------------------------------------------------
    @property
    def truncated(self) -> bool:
        return not self.complete

    @property
    def cut_off(self) -> LostSpan | None:
        return next((s for s in self.spans if s.kind == CUT_OFF), None)

    @property
    def bytes_skipped(self) -> int:
        """Bytes skipped inside the file (unreadable stretches and damaged chunks; the tail excluded)."""
        return sum(s.length for s in self.spans if s.kind != CUT_OFF)

    @property
    def lossy(self) -> bool:
        """True when messages (not only the summary) may be missing."""
        return self.lost_bytes > 0 or bool(self.spans) or self.orphan_messages > 0

    @property
    def messages_lost(self) -> int:
        """Messages known lost (from the message indexes of lost chunks, plus orphans)."""
        return sum(s.messages or 0 for s in self.spans) + self.orphan_messages

    @property
    def messages_lost_exact(self) -> bool:
        """False when some lost span's message count is unknown (see :attr:`messages_lost`)."""
        return all(s.messages is not None or s.length == 0 for s in self.spans)

    @property
    def seconds_lost(self) -> float:
        """Log time covered by lost spans (the union of their time ranges), s."""
        ranges = sorted((s.start_ns, s.end_ns) for s in self.spans
                        if s.start_ns is not None and s.end_ns is not None and s.end_ns >= s.start_ns)
        total, cur_a, cur_b = 0, None, None
        for a, b in ranges:
            if cur_b is None or a > cur_b:
                if cur_a is not None and cur_b is not None:
                    total += cur_b - cur_a
                cur_a, cur_b = a, b
            else:
                cur_b = max(cur_b, b)
        if cur_a is not None and cur_b is not None:
            total += cur_b - cur_a
        return total * 1e-9

    @property
    def state(self) -> str:
        """``complete``, ``damaged``, ``cut_off`` or ``damaged_and_cut_off``."""
        damaged = any(s.kind != CUT_OFF for s in self.spans) or self.orphan_messages > 0
        if self.complete:
            return "damaged" if damaged else "complete"
        return "damaged_and_cut_off" if damaged else "cut_off"

    def to_json(self) -> dict[str, Any]:
        """The report as one JSON object (``summary.json``'s ``log_loss``, ``log info --json``'s ``loss``)."""
        tail = self.cut_off
        return {
            "state": self.state,
            "summary": self.describe(),
            "complete": self.complete,
            "truncated": self.truncated,
            "lossy": self.lossy,
            "damaged_chunks": self.bad_chunks,
            "damaged_chunk_bytes": self.bad_chunk_bytes,
            "bytes_skipped": self.bytes_skipped,
            "messages_lost": self.messages_lost,
            "messages_lost_exact": self.messages_lost_exact,
            "seconds_lost": self.seconds_lost,
            "cut_off": None if tail is None else tail.to_json(),
            "orphan_messages": self.orphan_messages,
            "file_bytes": self.file_bytes,
            "valid_bytes": self.valid_bytes,
            "lost_bytes": self.lost_bytes,
            "bad_chunks": self.bad_chunks,
            "bad_chunk_bytes": self.bad_chunk_bytes,
            "first_time_ns": self.first_time_ns,
            "last_time_ns": self.last_time_ns,
            "lost_from_ns": self.lost_from_ns,
            "summary_index": self.summary_index,
            "spans": [s.to_json() for s in self.spans],
            "reason": self.reason,
        }

    as_dict = to_json

    def describe(self) -> str:
        """One line for people: what was lost, in seconds and messages."""
        if self.complete and not self.lossy:
            return f"complete; {self.reason}" if self.reason else "complete"
        parts = []
        inner = [s for s in self.spans if s.kind != CUT_OFF]
        if inner:
            n_bad = sum(1 for s in inner if s.kind == DAMAGED_CHUNK)
            n_skip = len(inner) - n_bad
            what = []
            if n_bad:
                what.append(f"{n_bad} damaged chunk(s) skipped")
            if n_skip:
                what.append(f"{n_skip} unreadable stretch(es) skipped")
            parts.append(f"damaged: {' and '.join(what)} ({sum(s.length for s in inner)} bytes, "
                         f"{_seconds(inner)}, {_messages(inner)} lost)")
        if not self.complete:
            tail = self.cut_off
            if tail is not None:
                parts.append(f"cut off: {tail.length} bytes lost at the end ({_seconds([tail])}, "
                             f"{_messages([tail])} lost)")
            else:
                parts.append("cut off: no summary (the log was not closed)")
            if self.last_time_ns is not None and self.first_time_ns is not None:
                into = (self.last_time_ns - self.first_time_ns) * 1e-9
                parts.append(f"readable up to {into:.3f} s into the log")
        if self.orphan_messages:
            parts.append(f"{self.orphan_messages} message(s) without a channel definition")
        if self.reason:
            parts.append(self.reason)
        return "; ".join(parts)


def _seconds(spans: list[LostSpan]) -> str:
    secs = [s.seconds for s in spans]
    if any(x is None for x in secs):
        known = sum(x for x in secs if x is not None)
        return f"at least {known:.3f} s" if known else "time unknown"
    approx = "about " if any(s.times_estimated for s in spans) else ""
    return f"{approx}{sum(x for x in secs if x is not None):.3f} s"


def _messages(spans: list[LostSpan]) -> str:
    counts = [s.messages for s in spans]
    known = sum(c for c in counts if c is not None)
    if all(c is not None for c in counts):
        return f"{known} messages"
    return f"at least {known} messages" if known else "messages unknown"
