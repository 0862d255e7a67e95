"""One MCAP record where it stands, checked for plausibility, and the search for the next one after damage.

Record layout (https://mcap.dev/spec): ``opcode u8 | length u64 | body[length]``; chunk body:
``start u64 | end u64 | uncompressed_size u64 | uncompressed_crc u32 | compression str | records
bytes``. :func:`read_record` accepts a record only when it is plausible: a known opcode, a length that
fits before ``limit``, and a body that parses to exactly its length (chunk and attachment headers are
checked against their data length; a message index's entry array against the record length).
:func:`chunk_at` reads a chunk header while ignoring the opcode (a flipped opcode byte does not lose
the chunk: its CRC still guards the content). :func:`resync` scans forward, a window at a time with
numpy, for the next offset where a plausible record starts *and* is followed by another plausible
record (or ends exactly at the limit); random or zeroed bytes essentially never pass both.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from io import BytesIO
from typing import Any, BinaryIO

import numpy as np
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    AttachmentIndex,
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from logs_format.chunkref import BadChunk, ChunkRef, inflate

MAGIC = b"\x89MCAP0\r\n"
REC = struct.Struct("<BQ")
CHUNK_HEAD = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression length
U64 = struct.Struct("<Q")
MSG_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
KNOWN = frozenset(int(op) for op in Opcode)
MAX_SMALL_RECORD = 64 << 20  # bytes: a schema, channel, metadata or index record larger than this is damage
MAX_COMPRESSION_NAME = 32
WINDOW = 1 << 20  # bytes scanned per step by resync

_PARSERS: dict[int, Any] = {
    Opcode.HEADER: Header, Opcode.SCHEMA: Schema, Opcode.CHANNEL: Channel, Opcode.METADATA: Metadata,
    Opcode.DATA_END: DataEnd, Opcode.FOOTER: Footer, Opcode.CHUNK_INDEX: ChunkIndex,
    Opcode.STATISTICS: Statistics, Opcode.SUMMARY_OFFSET: SummaryOffset, Opcode.METADATA_INDEX: MetadataIndex,
    Opcode.ATTACHMENT_INDEX: AttachmentIndex,
}
_RESYNC_OPS = np.array(sorted(KNOWN - {int(Opcode.HEADER)}), dtype=np.uint8)
# the shortest body each record kind can have (the fixed fields, empty strings and maps); others: never
_MIN_BODY = np.full(256, np.iinfo(np.uint64).max, dtype=np.uint64)
for _op, _n in ((Opcode.FOOTER, 20), (Opcode.SCHEMA, 14), (Opcode.CHANNEL, 16), (Opcode.MESSAGE, 22),
                (Opcode.CHUNK, 40), (Opcode.MESSAGE_INDEX, 6), (Opcode.CHUNK_INDEX, 64), (Opcode.ATTACHMENT, 36),
                (Opcode.ATTACHMENT_INDEX, 48), (Opcode.STATISTICS, 46), (Opcode.METADATA, 8),
                (Opcode.METADATA_INDEX, 20), (Opcode.SUMMARY_OFFSET, 17), (Opcode.DATA_END, 4)):
    _MIN_BODY[int(_op)] = _n
_NEXT_OK = np.zeros(256, dtype=bool)  # a byte that can start the record after a candidate
_NEXT_OK[sorted(KNOWN)] = True
_NEXT_OK[0x80:] = True


@dataclass(frozen=True, slots=True)
class AttachmentRef:
    offset: int
    length: int  # whole record, header included
    name: str
    media_type: str
    log_time_ns: int
    create_time_ns: int
    size: int


@dataclass(frozen=True, slots=True)
class IndexRun:
    """A message index record: how many messages of one channel a chunk held, and their time range."""

    channel_id: int
    count: int
    start_ns: int | None
    end_ns: int | None


@dataclass(frozen=True, slots=True)
class Rec:
    """A plausible record: its opcode, position, end, and what it says (parsed per kind)."""

    op: int
    pos: int
    end: int
    item: Any  # ChunkRef, AttachmentRef, IndexRun, a parsed mcap record, or the message head tuple


def _str_at(buf: bytes, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, pos)
    end = pos + 4 + n
    if end > len(buf):
        raise ValueError("string runs past the record")
    return buf[pos + 4 : end].decode("utf-8"), end


def chunk_at(f: BinaryIO, pos: int, length: int | None = None) -> ChunkRef | None:
    """The chunk whose record starts at ``pos`` (its opcode is not looked at), None when its header is
    inconsistent. ``length`` (the record body length) defaults to the one stored in the record."""
    f.seek(pos + 1)
    head = f.read(8 + 4096)
    if len(head) < 8:
        return None
    if length is None:
        (length,) = U64.unpack_from(head)
    body = head[8 : 8 + length]
    if len(body) < CHUNK_HEAD.size + 8:
        return None
    start, end, usize, crc, clen = CHUNK_HEAD.unpack_from(body)
    off = CHUNK_HEAD.size
    if clen > MAX_COMPRESSION_NAME or off + clen + 8 > len(body) or start > end:
        return None
    try:
        compression = body[off : off + clen].decode("ascii")
    except UnicodeDecodeError:
        return None
    if not compression.isprintable():
        return None
    (data_length,) = U64.unpack_from(body, off + clen)
    data_offset = pos + 9 + off + clen + 8
    if data_offset + data_length != pos + 9 + length:
        return None
    return ChunkRef(pos, start, end, compression, usize, crc, data_offset, data_length)


def _attachment(f: BinaryIO, pos: int, length: int) -> AttachmentRef | None:
    head = f.read(min(length, 65536))
    try:
        log_time, create_time = struct.unpack_from("<QQ", head)
        name, p = _str_at(head, 16)
        media, p = _str_at(head, p)
        (size,) = U64.unpack_from(head, p)
    except (struct.error, ValueError, UnicodeDecodeError):
        return None
    if p + 8 + size + 4 != length:
        return None
    return AttachmentRef(pos, 9 + length, name, media, log_time, create_time, size)


def _index_run(f: BinaryIO, length: int) -> IndexRun | None:
    if length < 6 or length > MAX_SMALL_RECORD:
        return None
    body = f.read(length)
    if len(body) != length:
        return None
    cid, n = struct.unpack_from("<HI", body)
    if 6 + n != length or n % 16:
        return None
    times = np.frombuffer(body, dtype="<u8", offset=6)[::2]
    if not times.size:
        return IndexRun(cid, 0, None, None)
    return IndexRun(cid, int(times.size), int(times.min()), int(times.max()))


def _parsed(f: BinaryIO, op: int, length: int) -> Any:
    if length > MAX_SMALL_RECORD:
        return None
    body = f.read(length)
    if len(body) != length:
        return None
    stream = ReadDataStream(BytesIO(body))
    try:
        item = _PARSERS[op].read(stream)
    except Exception:  # struct.error, UnicodeDecodeError, mcap's EndOfFile, ...: not this record
        return None
    return item if stream.count == length else None


def read_record(f: BinaryIO, pos: int, limit: int) -> Rec | None:
    """The record at ``pos`` when it is plausible and ends at or before ``limit`` (see the module
    docstring); records of private opcodes (>= 0x80) are plausible with any body."""
    f.seek(pos)
    head = f.read(9)
    if len(head) < 9:
        return None
    op, length = REC.unpack(head)
    end = pos + 9 + length
    if end > limit:
        return None
    item: Any
    if op == Opcode.CHUNK:
        item = chunk_at(f, pos, length)
    elif op == Opcode.MESSAGE_INDEX:
        item = _index_run(f, length)
    elif op == Opcode.MESSAGE:
        body = f.read(MSG_HEAD.size)
        item = MSG_HEAD.unpack(body) if length >= MSG_HEAD.size and len(body) == MSG_HEAD.size else None
    elif op == Opcode.ATTACHMENT:
        item = _attachment(f, pos, length)
    elif op in _PARSERS:
        item = _parsed(f, op, length)
    elif op >= 0x80:
        item = b""
    else:
        return None
    return None if item is None else Rec(op, pos, end, item)


def header_fits(f: BinaryIO, pos: int, limit: int, size: int) -> bool:
    """A plausible next record header at ``pos``: a known opcode and a length that fits in the file or is a
    sane size (the file was cut inside that record); or the limit itself; or a file cut inside the header."""
    if pos == limit:
        return True
    f.seek(pos)
    head = f.read(9)
    if len(head) < 9:
        return pos + len(head) == size
    op, length = REC.unpack(head)
    # one that runs past the end of the file is the partial last record of a cut-off log
    return (op in KNOWN or op >= 0x80) and (pos + 9 + length <= size or length <= MAX_SMALL_RECORD << 6)


def chunk_verifies(f: BinaryIO, ref: ChunkRef) -> bool:
    """True when the chunk's data decompresses (bounded) to its claimed size and CRC."""
    f.seek(ref.data_offset)
    try:
        inflate(ref, f.read(ref.data_length), zstandard.ZstdDecompressor())
    except BadChunk:
        return False
    return ref.uncompressed_crc != 0


def plausible(f: BinaryIO, pos: int, limit: int, size: int) -> Rec | None:
    """:func:`read_record` at ``pos``, kept only when a plausible record header follows it, or, for a
    chunk whose successor is damaged too, when its data checks out (:func:`chunk_verifies`)."""
    rec = read_record(f, pos, limit)
    if rec is None:
        return None
    if header_fits(f, rec.end, limit, size) or (rec.op == Opcode.CHUNK and chunk_verifies(f, rec.item)):
        return rec
    return None


def resync(f: BinaryIO, start: int, limit: int, size: int) -> Rec | None:
    """The first plausible record (see :func:`plausible`) at or after ``start``, before ``limit``."""
    pos = start
    while pos < limit - 8:
        f.seek(pos)
        window = f.read(min(WINDOW, limit - pos) + 8)
        buf = np.frombuffer(window, dtype=np.uint8)
        n = len(buf) - 8  # candidate starts with a whole length field in the window
        if n <= 0:
            break
        cand = np.flatnonzero(np.isin(buf[:n], _RESYNC_OPS))
        if cand.size:
            lengths = buf[cand[:, None] + np.arange(1, 9)].copy().view("<u8").ravel()
            room = np.maximum((limit - pos - 9) - cand.astype(np.int64), 0).astype(np.uint64)
            sel = np.flatnonzero((lengths <= room) & (lengths >= _MIN_BODY[buf[cand]]))  # rare in data
            cand, lengths = cand[sel], lengths[sel]
            nxt = cand + 9 + lengths.astype(np.int64)  # where the record after the candidate starts
            seen = nxt < len(buf)
            keep = np.ones(len(cand), dtype=bool)
            # a byte that can be an opcode, when in the window (a chunk may instead verify its data)
            keep[seen] = _NEXT_OK[buf[nxt[seen]]] | (buf[cand[seen]] == Opcode.CHUNK)
            for c in cand[keep].tolist():
                rec = plausible(f, pos + c, limit, size)
                if rec is not None:
                    return rec
        pos += n
    return None
