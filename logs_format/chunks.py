"""Open one chunk: check its CRC, decompress it, and split it into schemas, channels and messages.

Messages are cut out of the decompressed buffer with ``struct.unpack_from`` (no per-message
stream objects): this is the hot path of replay. :meth:`ChunkOpener.prefetch` reads and decompresses
the next chunk in a background thread (zstd, lz4 and zlib release the GIL) while the caller decodes
the current one; the CRC and size checks are the same on either path.
"""

from __future__ import annotations

import os
import struct
import threading
import zlib
from dataclasses import dataclass, field
from io import BytesIO
from typing import BinaryIO

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Schema

from logs_format.profile import CH_DEVICE, CH_FORMAT
from logs_format.records import ChunkRef

_REC = struct.Struct("<BQ")
_MSG_HEAD = struct.Struct("<HIQQ")
_OP_MESSAGE = int(Opcode.MESSAGE)
_OP_CHANNEL = int(Opcode.CHANNEL)
_OP_SCHEMA = int(Opcode.SCHEMA)


@dataclass(frozen=True, slots=True)
class ChannelInfo:
    """One channel of a log: a device (raw wire frames) or a decoded JSON stream."""

    id: int
    topic: str
    message_encoding: str
    schema_name: str
    schema_encoding: str
    metadata: dict[str, str] = field(default_factory=dict)

    @property
    def format(self) -> str | None:
        """auvlink wire-format name (``"pd0"``), or None for a JSON or foreign channel."""
        return self.metadata.get(CH_FORMAT)

    @property
    def device(self) -> str:
        return self.metadata.get(CH_DEVICE, self.topic)


@dataclass(frozen=True, slots=True)
class LogMessage:
    """One message: for a device channel, one raw wire frame exactly as received."""

    channel: str  # topic (= device name for raw channels)
    format: str | None  # auvlink wire-format name, None for non-wire channels
    log_time_ns: int  # host receive time, UTC ns
    publish_time_ns: int  # sensor time when the writer knew it, else equal to log_time_ns
    sequence: int
    data: bytes
    channel_id: int

    @property
    def t_sensor_ns(self) -> int | None:
        return None if self.publish_time_ns == self.log_time_ns else self.publish_time_ns


class BadChunk(Exception):
    """Internal: a chunk that cannot be opened (CRC, compression, layout)."""


class _Prefetch:
    """One chunk being read (``os.pread``: the file position is not touched) and inflated in a thread."""

    def __init__(self, ref: ChunkRef, fd: int, zstd: zstandard.ZstdDecompressor) -> None:
        self.ref = ref
        self._out: bytes | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(fd, zstd), name="mcap-chunk-prefetch",
                                        daemon=True)
        self._thread.start()

    def _run(self, fd: int, zstd: zstandard.ZstdDecompressor) -> None:
        try:
            self._out = inflate(self.ref, os.pread(fd, self.ref.data_length, self.ref.data_offset), zstd)
        except BaseException as exc:  # handed to the caller's thread by result()
            self._error = exc

    def result(self) -> bytes:
        self._thread.join()
        if self._error is not None:
            raise self._error
        assert self._out is not None
        return self._out

    def join(self) -> None:
        self._thread.join()


#: no chunk may claim more uncompressed bytes than this (the writer's chunks are a few MB)
MAX_CHUNK_BYTES = 1 << 30
#: the most a compressed byte can expand to: zstd RLE blocks (4 bytes per 128 KiB), lz4's 255:1 matches
_MAX_RATIO = {"zstd": 1 << 15, "lz4": 256}
_SLACK = 1 << 17  # bytes: one block of headroom for tiny inputs


def check_claim(ref: ChunkRef) -> None:
    """Refuse a chunk whose claimed uncompressed size is over the ceiling or more than its compressed
    bytes can expand to (a crafted or damaged header), before anything is allocated."""
    usize = ref.uncompressed_size
    if usize > MAX_CHUNK_BYTES:
        raise BadChunk(f"claims {usize} uncompressed bytes, over the {MAX_CHUNK_BYTES}-byte ceiling")
    if ref.compression == "" and usize != ref.data_length:
        raise BadChunk(f"claims {usize} bytes but holds {ref.data_length} uncompressed")
    ratio = _MAX_RATIO.get(ref.compression)
    if ratio is not None and usize > ratio * ref.data_length + _SLACK:
        raise BadChunk(f"claims {usize} uncompressed bytes from {ref.data_length} {ref.compression} bytes: "
                       "more than the format can expand to")


def _bounded(ref: ChunkRef, data: bytes, zstd: zstandard.ZstdDecompressor) -> bytes:
    """Decompress at most ``uncompressed_size + 1`` bytes (one more shows a chunk that holds more than
    it claims), streaming: memory follows the checked claim, never the frame's own content size."""
    limit = ref.uncompressed_size + 1
    if ref.compression == "zstd":
        with zstd.stream_reader(data, read_across_frames=True) as reader:
            return reader.read(limit)
    if ref.compression == "lz4":
        return lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=limit)
    if ref.compression == "":
        return data
    raise BadChunk(f"unsupported compression {ref.compression!r}")


def inflate(ref: ChunkRef, data: bytes, zstd: zstandard.ZstdDecompressor) -> bytes:
    """The records of a chunk from its stored bytes: size claim bounded, decompressed, size and CRC checked."""
    if len(data) != ref.data_length:
        raise BadChunk("short read")
    if ref.compression == "message":
        return _REC.pack(_OP_MESSAGE, ref.data_length) + data
    check_claim(ref)
    try:
        out = _bounded(ref, data, zstd)
    except (zstandard.ZstdError, RuntimeError, ValueError, EOFError) as exc:
        raise BadChunk(f"decompression failed: {exc}") from exc
    if len(out) != ref.uncompressed_size:
        raise BadChunk(f"uncompressed size mismatch: {len(out)}{'+' if len(out) > ref.uncompressed_size else ''}"
                       f" bytes, the header claims {ref.uncompressed_size}")
    if ref.uncompressed_crc and zlib.crc32(out) != ref.uncompressed_crc:
        raise BadChunk("CRC mismatch")
    return out


class ChunkOpener:
    """Reads and opens chunks of one file; keeps its decompressors (not thread-safe: one caller)."""

    def __init__(self, f: BinaryIO) -> None:
        self._f = f
        self._zstd = zstandard.ZstdDecompressor()
        self._zstd_ahead = zstandard.ZstdDecompressor()  # the prefetch thread's (one at a time)
        self._ahead: _Prefetch | None = None

    def prefetch(self, ref: ChunkRef) -> None:
        """Start reading and decompressing ``ref`` in the background for a later :meth:`raw` / :meth:`open`
        (compressed chunks only; one at a time: a prefetch not yet used is dropped)."""
        if self._ahead is not None:
            if self._ahead.ref is ref:
                return
            self._ahead.join()
            self._ahead = None
        if ref.compression in ("zstd", "lz4"):
            self._ahead = _Prefetch(ref, self._f.fileno(), self._zstd_ahead)

    def close(self) -> None:
        """Wait for a prefetch still running (the file is about to close)."""
        if self._ahead is not None:
            self._ahead.join()
            self._ahead = None

    def raw(self, ref: ChunkRef) -> bytes:
        ahead = self._ahead
        if ahead is not None and ahead.ref is ref:
            self._ahead = None
            return ahead.result()
        self._f.seek(ref.data_offset)
        return inflate(ref, self._f.read(ref.data_length), self._zstd)

    def open(
        self, ref: ChunkRef
    ) -> tuple[list[Schema], list[Channel], list[tuple[int, int, int, int, bytes]]]:
        """Schemas, channels and messages ``(log_time, publish_time, sequence, channel_id, data)``."""
        buf = self.raw(ref)
        schemas: list[Schema] = []
        channels: list[Channel] = []
        messages: list[tuple[int, int, int, int, bytes]] = []
        pos, n = 0, len(buf)
        unpack_rec, unpack_msg = _REC.unpack_from, _MSG_HEAD.unpack_from
        try:
            while pos < n:
                op, length = unpack_rec(buf, pos)
                body = pos + 9
                end = body + length
                if end > n:
                    raise BadChunk("record runs past the chunk")
                if op == _OP_MESSAGE:
                    cid, seq, log_time, pub_time = unpack_msg(buf, body)
                    messages.append((log_time, pub_time, seq, cid, buf[body + 22 : end]))
                elif op == _OP_CHANNEL:
                    channels.append(Channel.read(ReadDataStream(BytesIO(buf[body:end]))))
                elif op == _OP_SCHEMA:
                    schemas.append(Schema.read(ReadDataStream(BytesIO(buf[body:end]))))
                pos = end
        except BadChunk:
            raise
        except Exception as exc:  # struct.error, UnicodeDecodeError, mcap's EndOfFile, ...
            raise BadChunk(f"damaged record inside the chunk: {exc}") from exc
        return schemas, channels, messages
