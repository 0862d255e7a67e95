"""Index the records of an MCAP file without trusting any single byte: survives truncation and damage.

A log cut off mid-write (kill -9, power loss, full disk) has no summary section and usually ends
inside a record; a damaged one has a record that does not parse. :func:`scan` walks the data section
reading only record headers and the small fixed headers of chunks (seeking over their payloads, so
a 1 GB log is indexed in milliseconds). Where a record does not parse it first tries the bytes as a
chunk whose opcode was damaged, then resynchronises on the next plausible record
(:mod:`logs_format.walk`), so damage costs only the records it hit. When the file has a
whole footer and a summary whose CRC matches (:mod:`logs_format.summary`), the summary's chunk index
locates every chunk, including one whose record header is damaged, and its metadata and attachment
indexes recover records the walk skipped. What is lost goes into a :class:`LossReport`; nothing
raises for damage; only a file that does not start with the MCAP magic is refused
(:class:`~logs_format.profile.LogError`).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from io import BytesIO
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Metadata, Schema

from logs_format.loss import CUT_OFF, UNREADABLE, LossReport, LostSpan
from logs_format.profile import LogError
from logs_format.records import CHUNK_HEAD, MAGIC, AttachmentRef, ChunkRef, IndexRun, read_record
from logs_format.summary import Summary, read_summary
from logs_format.walk import Walk
from logs_format.walk import walk as walk_records

__all__ = ["MAGIC", "AttachmentRef", "ChunkRef", "IndexRun", "LogIndex", "LossReport", "scan"]


@dataclass
class LogIndex:
    """Everything :func:`scan` found: chunk positions, metadata, attachments, schemas and channels."""

    profile: str = ""
    library: str = ""
    chunks: list[ChunkRef] = field(default_factory=list)
    metadata: list[tuple[str, dict[str, str]]] = field(default_factory=list)
    attachments: list[AttachmentRef] = field(default_factory=list)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    loss: LossReport = field(default_factory=LossReport)
    #: per chunk offset: what its message index records say (messages, time range), when they survived
    chunk_messages: dict[int, IndexRun] = field(default_factory=dict)


def _index_run(runs: list[IndexRun]) -> IndexRun:
    starts = [r.start_ns for r in runs if r.start_ns is not None]
    ends = [r.end_ns for r in runs if r.end_ns is not None]
    return IndexRun(-1, sum(r.count for r in runs), min(starts, default=None), max(ends, default=None))


def _run_after(walk: Walk, pos: int) -> IndexRun | None:
    """The message index records that follow ``pos`` back to back (a chunk's), merged; None if none."""
    runs = []
    while pos in walk.indexes:
        rec = walk.indexes[pos]
        runs.append(rec.item)
        pos = rec.end
    return _index_run(runs) if runs else None


def _from_summary(f: BinaryIO, index: LogIndex, walk: Walk, summary: Summary) -> None:
    """Chunks, metadata and attachments the summary indexes but the walk did not find."""
    for ci in summary.chunk_indexes:
        off, span = ci.chunk_start_offset, ci.chunk_length
        if off in walk.chunks or any(off < p < off + span for p in walk.chunks if walk.chunks[p].compression
                                     != "message"):
            continue  # the walk found this chunk, or a whole chunk where the index says this one lies
        data_offset = off + 9 + CHUNK_HEAD.size + len(ci.compression.encode()) + 8
        f.seek(off + 9 + 24)
        crc_bytes = f.read(4)
        if data_offset + ci.compressed_size != off + span or len(crc_bytes) != 4:
            continue  # an index entry that cannot describe a chunk record
        (crc,) = struct.unpack("<I", crc_bytes)
        walk.chunks[off] = ChunkRef(off, ci.message_start_time, ci.message_end_time, ci.compression,
                                    ci.uncompressed_size, crc, data_offset, ci.compressed_size)
        runs = [walk.indexes[p].item for p in ci.message_index_offsets.values() if p in walk.indexes]
        if runs:
            index.chunk_messages[off] = _index_run(runs)
        # what the walk made of the bytes of this chunk (inner records, a gap) is superseded
        for d in (walk.chunks, walk.metadata, walk.attachments):
            for p in [p for p in d if off < p < off + span]:
                del d[p]
        walk.gaps = [g for a, b in walk.gaps for g in ((a, min(b, off)), (max(a, off + span), b)) if g[0] < g[1]]
    known = set(walk.metadata)
    for mi in summary.metadata_indexes:
        if mi.offset not in known:
            f.seek(mi.offset + 9)
            try:
                meta = Metadata.read(ReadDataStream(BytesIO(f.read(max(0, mi.length - 9)))))
            except Exception:  # damaged beyond its header: stays lost
                continue
            walk.metadata[mi.offset] = (meta.name, dict(meta.metadata))
    for ai in summary.attachment_indexes:
        if ai.offset not in walk.attachments:
            rec = read_record(f, ai.offset, ai.offset + ai.length)
            if rec is not None and rec.op == Opcode.ATTACHMENT:
                walk.attachments[ai.offset] = rec.item


def _losses(index: LogIndex, walk: Walk, limit: int, size: int, complete: bool) -> None:
    loss = index.loss
    chunks = sorted(walk.chunks.values(), key=lambda c: c.offset)

    def around(a: int, b: int) -> tuple[int | None, int | None]:
        before = [c.end_ns for c in chunks if c.offset < a]
        after = [c.start_ns for c in chunks if c.offset >= b]
        return (max(before) if before else None), (min(after) if after else None)

    def owned_by_previous(a: int, run: IndexRun) -> bool:
        """The index records after a gap are the rest of the index of the chunk before it (read whole)."""
        prev = [c for c in chunks if c.offset < a and c.compression != "message"]
        return bool(prev) and run.start_ns is not None and run.end_ns is not None \
            and prev[-1].start_ns <= run.start_ns and run.end_ns <= prev[-1].end_ns

    for a, b in walk.gaps:
        run = _run_after(walk, b)
        if run is not None and run.count and not owned_by_previous(a, run):
            loss.add(LostSpan(UNREADABLE, a, b - a, run.start_ns, run.end_ns, run.count,
                              "damaged chunk: no record parses"))
        else:
            t0, t1 = around(a, b)
            loss.add(LostSpan(UNREADABLE, a, b - a, t0, t1, None, "damaged records skipped",
                              times_estimated=True))
    if walk.tail is not None and walk.tail < limit:
        nbytes = limit - walk.tail
        if complete:
            t0, t1 = around(walk.tail, limit)
            loss.add(LostSpan(UNREADABLE, walk.tail, nbytes, t0, t1, None, "no record parses",
                              times_estimated=True))
        elif walk.in_summary:
            loss.add(LostSpan(CUT_OFF, walk.tail, nbytes, None, None, 0, "file ends inside the summary"))
        elif walk.tail_chunk is not None:
            head = walk.tail_chunk
            loss.lost_from_ns = head.start_ns
            loss.add(LostSpan(CUT_OFF, walk.tail, nbytes, head.start_ns, head.end_ns, None,
                              "file ends inside a chunk"))
        else:
            t0, _ = around(walk.tail, limit)
            loss.add(LostSpan(CUT_OFF, walk.tail, nbytes, t0, None, None, "file ends inside a record"))
    if not complete:
        loss.valid_bytes = walk.end if walk.tail is not None else size
        loss.lost_bytes = size - loss.valid_bytes
    for ref in chunks:
        if ref.offset not in index.chunk_messages:
            run = _run_after(walk, ref.end)
            if run is not None:
                index.chunk_messages[ref.offset] = run


def scan(f: BinaryIO, size: int) -> LogIndex:
    """Index the records of an MCAP stream of ``size`` bytes (see the module docstring)."""
    index = LogIndex(loss=LossReport(file_bytes=size))
    loss = index.loss
    f.seek(0)
    magic = f.read(8)
    if magic != MAGIC[: len(magic)]:
        raise LogError("not an MCAP file (bad magic bytes)")
    if len(magic) < 8:
        loss.lost_bytes = size
        loss.reason = "file ends inside the magic bytes"
        return index
    summary = read_summary(f, size)
    limit = summary.start if summary.usable else summary.footer_pos if summary.complete else size
    walk = walk_records(f, 8, limit, size, distrust_summary=bool(summary.problem))
    walk.settle()
    index.schemas, index.channels = walk.schemas, walk.channels
    index.profile, index.library = walk.profile, walk.library
    if summary.usable:
        index.schemas.update(summary.schemas)
        index.channels.update(summary.channels)
        _from_summary(f, index, walk, summary)
        loss.summary_index = True
    loss.complete = summary.complete
    if summary.complete:
        loss.valid_bytes = size
    _losses(index, walk, limit, size, summary.complete)
    if summary.problem:
        loss.reason = summary.problem
    index.chunks = sorted(walk.chunks.values(), key=lambda c: c.offset)
    index.metadata = [walk.metadata[p] for p in sorted(walk.metadata)]
    index.attachments = [walk.attachments[p] for p in sorted(walk.attachments)]
    loss.last_time_ns = max((c.end_ns for c in index.chunks), default=None)
    starts = [c.start_ns for c in index.chunks] + [s.start_ns for s in loss.spans if s.start_ns is not None]
    loss.first_time_ns = min(starts, default=None)
    return index
