"""Walk the records of an MCAP data section in file order, stepping over damage.

Each step reads one record (:func:`logs_format.records.read_record`). Where none parses, the bytes are
first tried as a chunk whose opcode byte was damaged (its header is consistent and a plausible record
follows), else the walk resynchronises on the next plausible record and records the skipped stretch as
a gap. Two guards keep damage from costing more than it hit:

* a weakly checked record (a top-level message or a private record: nothing verifies their bodies)
  never swallows a chunk: a consistent chunk header inside one wins, and the record is a gap;
* a file of chunks (every auvlink log) holds no top-level message: one met there is a damaged record
  (another record's opcode flipped to 0x05, or the inner records of a damaged uncompressed chunk that a
  resync landed in), and nothing verifies it, so it is dropped as a gap (:meth:`Walk.settle`); schema
  and channel records met right after a resync are not taken either (chunks carry their own). A file
  without chunks keeps its top-level messages.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import BinaryIO

from mcap.opcode import Opcode
from mcap.records import Channel, Schema

from logs_format.records import (
    AttachmentRef,
    ChunkRef,
    Rec,
    chunk_at,
    chunk_verifies,
    header_fits,
    read_record,
    resync,
)

_CHUNK_OP = bytes([Opcode.CHUNK])
_INNER = frozenset(int(op) for op in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE))  # may sit in a chunk


@dataclass
class Walk:
    """What the walk over the data section met, by file offset."""

    chunks: dict[int, ChunkRef] = field(default_factory=dict)  # chunks, and top-level messages
    indexes: dict[int, Rec] = field(default_factory=dict)  # message index records
    metadata: dict[int, tuple[str, dict[str, str]]] = field(default_factory=dict)
    attachments: dict[int, AttachmentRef] = field(default_factory=dict)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    profile: str = ""
    library: str = ""
    gaps: list[tuple[int, int]] = field(default_factory=list)  # [start, end) where nothing parsed
    messages: list[tuple[int, int]] = field(default_factory=list)  # [start, end) of top-level messages
    tail: int | None = None  # first byte of an unreadable end (no record parses up to the limit)
    tail_chunk: ChunkRef | None = None  # the header of a chunk the file ends inside
    end: int = 0  # end of the last whole record
    in_summary: bool = False  # the walk passed a DataEnd record
    distrust_summary: bool = False  # the footer's summary failed its checks

    def take(self, rec: Rec, unverified: bool) -> None:
        op, item = rec.op, rec.item
        if op == Opcode.DATA_END:
            self.in_summary = True
        elif self.in_summary and self.distrust_summary:
            return  # a summary that failed its CRC: its schemas and channels are not taken either
        elif unverified and op != Opcode.MESSAGE:
            return  # a definition from inside a damaged chunk: the chunks carry their own
        elif op == Opcode.SCHEMA:
            self.schemas[item.id] = item
        elif op == Opcode.CHANNEL:
            self.channels[item.id] = item
        elif op == Opcode.HEADER:
            self.profile, self.library = item.profile, item.library
        elif op == Opcode.METADATA:
            self.metadata[rec.pos] = (item.name, dict(item.metadata))
        elif self.in_summary:
            return  # summary records the walk met because the footer or summary was not trusted
        elif op == Opcode.CHUNK:
            self.chunks[rec.pos] = item
        elif op == Opcode.MESSAGE_INDEX:
            self.indexes[rec.pos] = rec
        elif op == Opcode.MESSAGE:
            n = rec.end - rec.pos - 9
            self.chunks[rec.pos] = ChunkRef(rec.pos, item[2], item[2], "message", n, 0, rec.pos + 9, n)
            self.messages.append((rec.pos, rec.end))
        elif op == Opcode.ATTACHMENT:
            self.attachments[rec.pos] = item

    def settle(self) -> None:
        """In a file of chunks, drop the top-level messages (see the module docstring): gaps grow over them."""
        if not self.messages or all(c.compression == "message" for c in self.chunks.values()):
            return
        for pos, _ in self.messages:
            del self.chunks[pos]
        spans = sorted(self.gaps + self.messages)
        self.gaps = []
        for a, b in spans:
            if self.gaps and a <= self.gaps[-1][1]:
                self.gaps[-1] = (self.gaps[-1][0], max(b, self.gaps[-1][1]))
            else:
                self.gaps.append((a, b))
        self.messages = []


def as_chunk(f: BinaryIO, pos: int, limit: int, size: int) -> Rec | None:
    """The record at ``pos`` read as a chunk whose opcode byte was damaged (header and successor fit)."""
    ref = chunk_at(f, pos)
    if ref is None or ref.end > limit:
        return None
    if header_fits(f, ref.end, limit, size) or chunk_verifies(f, ref):
        return Rec(Opcode.CHUNK, pos, ref.end, ref)
    return None


def _chunk_inside(f: BinaryIO, rec: Rec, limit: int, size: int) -> Rec | None:
    """A chunk that starts inside a weakly checked record (see the module docstring)."""
    f.seek(rec.pos + 1)
    body = f.read(rec.end - rec.pos - 1)
    at = body.find(_CHUNK_OP)
    while at >= 0:
        found = as_chunk(f, rec.pos + 1 + at, limit, size)
        if found is not None:
            return found
        at = body.find(_CHUNK_OP, at + 1)
    return None


def walk(f: BinaryIO, start: int, limit: int, size: int, distrust_summary: bool) -> Walk:
    """Walk the records in ``[start, limit)`` of a file of ``size`` bytes (see the module docstring)."""
    out = Walk(end=start, distrust_summary=distrust_summary)
    pos = start
    unverified = False  # right after a resync: inner chunk records are not trusted
    while pos < limit:
        rec = read_record(f, pos, limit)
        if rec is None or rec.op == Opcode.MESSAGE or rec.op >= 0x80:
            rec = as_chunk(f, pos, limit, size) or rec
        if rec is None:
            found = resync(f, pos + 1, limit, size)
            if found is None:
                out.tail = pos
                f.seek(pos)
                head = chunk_at(f, pos) if f.read(1) == _CHUNK_OP else None
                out.tail_chunk = head if not out.in_summary else None
                break
            out.gaps.append((pos, found.pos))
            rec, unverified = found, True
        if rec.op == Opcode.MESSAGE or rec.op >= 0x80:
            inner = _chunk_inside(f, rec, limit, size)
            if inner is not None:
                out.gaps.append((rec.pos, inner.pos))
                rec = inner
        unverified = unverified and rec.op in _INNER
        out.take(rec, unverified)
        pos = out.end = rec.end
    return out
