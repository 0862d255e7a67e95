"""Where a chunk lies in a mission log, and how its stored bytes are opened with bounded memory.

:func:`inflate` checks a chunk's claimed uncompressed size against a ceiling and against what its
compressed bytes can expand to (:func:`check_claim`) before anything is allocated, then decompresses
streaming with a limit, and checks the size and the CRC. Used by the chunk reader
(:mod:`logs_format.chunks`) and by the resynchronising walk (:mod:`logs_format.records`).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import lz4.frame
import zstandard
from mcap.opcode import Opcode

_REC = struct.Struct("<BQ")
_OP_MESSAGE = int(Opcode.MESSAGE)


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

    @property
    def end(self) -> int:
        """First byte after the record."""
        return self.data_offset + self.data_length


class BadChunk(Exception):
    """Internal: a chunk that cannot be opened (CRC, compression, layout)."""


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
