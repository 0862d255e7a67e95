"""Walk the records of an MCAP file without trusting its summary: survives truncation and garbage.

A log cut off mid-write (kill -9, power loss, full disk) has no summary section and usually ends
inside a record. :func:`scan` reads only record headers (opcode, length) and the small fixed
headers of chunk records, seeking over their payloads, so a 1 GB log is indexed in milliseconds.
It stops at the first record that does not fit in the file (or is not a record at all) and
reports what is lost. It never raises for a damaged file; only a file that does not start with
the MCAP magic is refused (:class:`~logs_format.profile.LogError`).

Record layout (https://mcap.dev/spec): ``opcode u8 | length u64 | body[length]``; chunk body:
``start u64 | end u64 | uncompressed_size u64 | uncompressed_crc u32 | compression str | records
bytes``.
"""

from __future__ import annotations

import struct
from dataclasses import asdict, dataclass, field
from io import BytesIO
from typing import Any, BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Metadata, Schema

from logs_format.profile import LogError

MAGIC = b"\x89MCAP0\r\n"
_REC = struct.Struct("<BQ")
_CHUNK_HEAD = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression length
_U64 = struct.Struct("<Q")
_MSG_HEAD = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time
_KNOWN = {int(op) for op in Opcode}


@dataclass(frozen=True, slots=True)
class ChunkRef:
    """Where one chunk (or one message written outside any chunk) lies in the file."""

    offset: int  # first byte of the record (its opcode)
    start_ns: int
    end_ns: int
    compression: str  # "", "zstd", "lz4"; "message" for a bare top-level Message record
    uncompressed_size: int
    uncompressed_crc: int
    data_offset: int  # first byte of the (compressed) records
    data_length: int


@dataclass(frozen=True, slots=True)
class AttachmentRef:
    offset: int
    length: int  # whole record, header included
    name: str
    media_type: str
    log_time_ns: int
    create_time_ns: int
    size: int


@dataclass
class LossReport:
    """What a damaged or cut-off log lost. ``complete`` logs report nothing lost."""

    complete: bool = False
    file_bytes: int = 0
    valid_bytes: int = 0  # bytes up to the end of the last whole record
    lost_bytes: int = 0  # bytes after it (a partial record, garbage, zeros)
    first_time_ns: int | None = None  # oldest log time in the log
    last_time_ns: int | None = None  # newest log time among the chunks that survived whole
    lost_from_ns: int | None = None  # start time of the partial chunk, when its header survived
    bad_chunks: int = 0  # whole chunks whose CRC or decompression failed (skipped)
    bad_chunk_bytes: int = 0
    orphan_messages: int = 0  # messages whose channel definition was lost
    reason: str = ""

    @property
    def truncated(self) -> bool:
        return not self.complete

    @property
    def lossy(self) -> bool:
        """True when messages (not only the summary) may be missing."""
        return self.lost_bytes > 0 or self.bad_chunks > 0 or self.orphan_messages > 0

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "truncated": self.truncated, "lossy": self.lossy}

    def describe(self) -> str:
        """One line for people."""
        if self.complete and not self.lossy:
            return "complete"
        parts = ["complete" if self.complete else "incomplete (no summary: cut off or not closed)"]
        if self.lost_bytes:
            parts.append(f"{self.lost_bytes} bytes lost at the end")
        if self.last_time_ns is not None and self.first_time_ns is not None and not self.complete:
            into = (self.last_time_ns - self.first_time_ns) * 1e-9
            parts.append(f"readable up to {into:.3f} s into the log")
        if self.bad_chunks:
            parts.append(f"{self.bad_chunks} damaged chunk(s) skipped ({self.bad_chunk_bytes} bytes)")
        if self.orphan_messages:
            parts.append(f"{self.orphan_messages} message(s) without a channel definition")
        if self.reason:
            parts.append(self.reason)
        return "; ".join(parts)


@dataclass
class LogIndex:
    """Everything :func:`scan` found: chunk positions, metadata, attachments, summary channels."""

    profile: str = ""
    library: str = ""
    chunks: list[ChunkRef] = field(default_factory=list)
    metadata: list[tuple[str, dict[str, str]]] = field(default_factory=list)
    attachments: list[AttachmentRef] = field(default_factory=list)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    loss: LossReport = field(default_factory=LossReport)


def _parse(record: bytes) -> ReadDataStream:
    return ReadDataStream(BytesIO(record))


def _str_at(buf: bytes, pos: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, pos)
    end = pos + 4 + n
    if end > len(buf):
        raise ValueError("string runs past the record")
    return buf[pos + 4 : end].decode("utf-8"), end


def _chunk_ref(f: BinaryIO, pos: int, length: int) -> ChunkRef | None:
    """Read a chunk record's fixed header; None when it is inconsistent."""
    head = f.read(min(length, 4096))
    if len(head) < _CHUNK_HEAD.size + 8:
        return None
    start, end, usize, crc, clen = _CHUNK_HEAD.unpack_from(head)
    off = _CHUNK_HEAD.size
    if off + clen + 8 > len(head):
        return None
    try:
        compression = head[off : off + clen].decode("ascii")
    except UnicodeDecodeError:
        return None
    (data_length,) = _U64.unpack_from(head, off + clen)
    data_offset = pos + 9 + off + clen + 8
    if data_offset + data_length != pos + 9 + length:
        return None
    return ChunkRef(pos, start, end, compression, usize, crc, data_offset, data_length)


def _attachment_ref(f: BinaryIO, pos: int, length: int) -> AttachmentRef | None:
    head = f.read(min(length, 65536))
    try:
        log_time, create_time = struct.unpack_from("<QQ", head)
        name, p = _str_at(head, 16)
        media, p = _str_at(head, p)
        (size,) = _U64.unpack_from(head, p)
    except (struct.error, ValueError, UnicodeDecodeError):
        return None
    return AttachmentRef(pos, 9 + length, name, media, log_time, create_time, size)


def _start_loss(size: int, pos: int, loss: LossReport, reason: str) -> None:
    loss.valid_bytes = pos
    loss.lost_bytes = size - pos
    loss.reason = reason


def scan(f: BinaryIO, size: int) -> LogIndex:
    """Index the records of an MCAP stream of ``size`` bytes (see the module docstring)."""
    index = LogIndex(loss=LossReport(file_bytes=size))
    loss = index.loss
    f.seek(0)
    magic = f.read(8)
    if magic != MAGIC[: len(magic)]:
        raise LogError("not an MCAP file (bad magic bytes)")
    if len(magic) < 8:
        _start_loss(size, 0, loss, "file ends inside the magic bytes")
        return index
    pos = 8
    in_summary = False
    last_end: int | None = None
    while True:
        f.seek(pos)
        head = f.read(9)
        if len(head) < 9:
            if head:
                _start_loss(size, pos, loss, "file ends inside a record header")
            else:
                _start_loss(size, pos, loss, "file ends without a footer")
            break
        op, length = _REC.unpack(head)
        if op not in _KNOWN and op < 0x80:
            _start_loss(size, pos, loss, f"no record at byte {pos} (opcode 0x{op:02X}): garbage or zeros")
            break
        end = pos + 9 + length
        if end > size:
            _start_loss(size, pos, loss, f"file ends inside a record (opcode 0x{op:02X}) at byte {pos}")
            if op == Opcode.CHUNK and size - pos - 9 >= _CHUNK_HEAD.size:
                loss.lost_from_ns = _CHUNK_HEAD.unpack(f.read(_CHUNK_HEAD.size))[0]
            break
        if op == Opcode.CHUNK and not in_summary:
            ref = _chunk_ref(f, pos, length)
            if ref is None:
                loss.bad_chunks += 1
                loss.bad_chunk_bytes += 9 + length
            else:
                index.chunks.append(ref)
                last_end = ref.end_ns if last_end is None else max(last_end, ref.end_ns)
        elif op == Opcode.MESSAGE and not in_summary:
            body = f.read(min(length, _MSG_HEAD.size))
            if len(body) == _MSG_HEAD.size:
                t = _MSG_HEAD.unpack(body)[2]
                index.chunks.append(ChunkRef(pos, t, t, "message", length, 0, pos + 9, length))
                last_end = t if last_end is None else max(last_end, t)
        elif op in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.METADATA, Opcode.HEADER):
            try:
                stream = _parse(f.read(length))
                if op == Opcode.SCHEMA:
                    schema = Schema.read(stream)
                    index.schemas[schema.id] = schema
                elif op == Opcode.CHANNEL:
                    channel = Channel.read(stream)
                    index.channels[channel.id] = channel
                elif op == Opcode.METADATA:
                    meta = Metadata.read(stream)
                    index.metadata.append((meta.name, dict(meta.metadata)))
                else:
                    index.profile = stream.read_prefixed_string()
                    index.library = stream.read_prefixed_string()
            except Exception:  # a damaged small record: skip it, keep scanning
                loss.reason = f"damaged record (opcode 0x{op:02X}) at byte {pos} skipped"
        elif op == Opcode.ATTACHMENT and not in_summary:
            att = _attachment_ref(f, pos, length)
            if att is not None:
                index.attachments.append(att)
        elif op == Opcode.DATA_END:
            in_summary = True
        elif op == Opcode.FOOTER:
            f.seek(end)
            if f.read(8) == MAGIC and end + 8 == size:
                loss.complete = True
                loss.valid_bytes = size
            else:
                _start_loss(size, end, loss, "footer not followed by the closing magic")
            break
        pos = end
    loss.last_time_ns = last_end
    loss.first_time_ns = min((c.start_ns for c in index.chunks), default=None)
    return index
