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
from dataclasses import dataclass, field
from io import BytesIO
from typing import BinaryIO

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Schema

from logs_format.chunkref import BadChunk, ChunkRef, inflate
from logs_format.profile import CH_DEVICE, CH_FORMAT

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
