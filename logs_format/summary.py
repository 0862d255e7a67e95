"""The footer and summary section of an MCAP file, read from the end and checked before any use.

A closed log ends with ``Footer | magic``; the footer points at the summary section (schemas,
channels, statistics, one chunk index record per chunk, metadata and attachment indexes). The summary
is used only when the footer is whole, its offsets lie inside the file and its CRC (when written)
matches; it then locates every chunk even when the data section has a damaged record header.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field
from typing import BinaryIO

from mcap.opcode import Opcode
from mcap.records import AttachmentIndex, Channel, ChunkIndex, MetadataIndex, Schema, Statistics

from logs_format.records import MAGIC, REC, read_record

_FOOTER = struct.Struct("<QQI")  # summary start, summary offset start, summary crc
FOOTER_BYTES = 9 + _FOOTER.size + len(MAGIC)  # the footer record and the closing magic
_SUMMARY_OPS = frozenset(int(op) for op in (
    Opcode.SCHEMA, Opcode.CHANNEL, Opcode.STATISTICS, Opcode.CHUNK_INDEX, Opcode.METADATA_INDEX,
    Opcode.ATTACHMENT_INDEX, Opcode.SUMMARY_OFFSET))


@dataclass
class Summary:
    """What the end of the file says (``complete``: a whole footer and the closing magic)."""

    complete: bool = False
    footer_pos: int = 0  # first byte of the footer record (the data section ends before it)
    start: int = 0  # first byte of the summary section; 0 when there is none (or it is not trusted)
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    metadata_indexes: list[MetadataIndex] = field(default_factory=list)
    attachment_indexes: list[AttachmentIndex] = field(default_factory=list)
    statistics: Statistics | None = None
    problem: str = ""  # why the summary is not used, for people

    @property
    def usable(self) -> bool:
        return self.complete and self.start > 0


def _crc(f: BinaryIO, start: int, end: int, footer_head: bytes) -> int:
    """CRC-32 of the file's bytes ``[start, end)`` followed by ``footer_head``, read in blocks."""
    crc, pos = 0, start
    f.seek(start)
    while pos < end:
        block = f.read(min(1 << 20, end - pos))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        pos += len(block)
    return zlib.crc32(footer_head, crc)


def read_summary(f: BinaryIO, size: int) -> Summary:
    """The footer and (when trustworthy) the summary section of a file of ``size`` bytes."""
    out = Summary()
    if size < len(MAGIC) + FOOTER_BYTES:
        return out
    footer_pos = size - FOOTER_BYTES
    f.seek(footer_pos)
    tail = f.read(FOOTER_BYTES)
    op, length = REC.unpack_from(tail)
    if tail[-len(MAGIC):] != MAGIC or op != Opcode.FOOTER or length != _FOOTER.size:
        return out
    out.complete, out.footer_pos = True, footer_pos
    start, _offsets, crc = _FOOTER.unpack_from(tail, 9)
    if start == 0:
        return out
    if not len(MAGIC) <= start <= footer_pos:
        out.problem = f"footer points the summary at byte {start}, outside the file"
        return out
    if crc and _crc(f, start, footer_pos, tail[: 9 + 16]) != crc:
        out.problem = "summary CRC mismatch"
        return out
    pos = start
    while pos < footer_pos:
        rec = read_record(f, pos, footer_pos)
        if rec is None or (rec.op not in _SUMMARY_OPS and rec.op < 0x80):
            what = "damaged" if rec is None else f"data record (opcode 0x{rec.op:02X}) in the"
            out.problem = f"{what} summary record at byte {pos}: the summary is not used"
            out.chunk_indexes.clear()
            return out
        if rec.op == Opcode.CHUNK_INDEX:
            out.chunk_indexes.append(rec.item)
        elif rec.op == Opcode.SCHEMA:
            out.schemas[rec.item.id] = rec.item
        elif rec.op == Opcode.CHANNEL:
            out.channels[rec.item.id] = rec.item
        elif rec.op == Opcode.METADATA_INDEX:
            out.metadata_indexes.append(rec.item)
        elif rec.op == Opcode.ATTACHMENT_INDEX:
            out.attachment_indexes.append(rec.item)
        elif rec.op == Opcode.STATISTICS:
            out.statistics = rec.item
        pos = rec.end
    out.start = start
    return out
