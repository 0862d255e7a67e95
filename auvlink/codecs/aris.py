"""Sound Metrics ARIS recordings (``.aris``) and frames: 1024-byte headers + a beams x samples image.

Specification followed: SoundMetrics aris-file-sdk (MIT licence): ``type-definitions/C/*Header.h``
(layouts, :mod:`auvlink.framing.aris_defs`), ``docs/understanding-aris-data.md`` (file structure,
ranges, beam order), ``common-code/FrameFuncs.c`` (ping mode -> beams), ``beam-width-metrics``.

* A file is a :class:`ArisFileHeader` then frames; a frame is a 1024-byte header then
  ``SamplesPerBeam x beams`` bytes (beams from ``PingMode``), samples-major: each sample row holds
  every beam. Frames are found with the framer's :func:`~auvlink.framing.aris.scan`.
* Range of image row m (the SDK's ``SampleRange``): ``SampleStartDelay*1e-6*SoundSpeed/2 +
  m * SamplePeriod*1e-6*SoundSpeed/2``.
* Beam order: the SDK numbers beams from right to left (beam 0 = right-most = starboard-most, with a
  negative table angle). The decoded ``image`` is a zero-copy view of the frame bytes with the
  beam axis reversed: column 0 is the port-most beam, and ``azimuths_rad`` (+ to starboard, equal
  to minus the SDK angle) increases with the column. :func:`encode` writes the SDK order back.
* Beam table: telephoto lens (``LargeLens``) with 48/96 beams -> ``ARIS_Telephoto_48/96``;
  otherwise 48 -> ``ARIS1800_1200_48``, 96 -> ``ARIS1800_96``, 64 -> ``ARIS3000_64``,
  128 -> ``ARIS3000_128`` (the SDK has no telephoto tables for 64/128 beams).
* ``.aris`` recordings hold reordered samples (``ReorderedSamples`` = 1). Raw frames straight
  from an ARIS (``ReorderedSamples`` = 0) decode as they are (``samples_reordered`` is False); the
  aris-integration-sdk reordering of such frames is not implemented here.

The header is kept whole (a numpy structured scalar, vendor units), so ``encode(decode(x)) == x``.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from auvlink.codecs.aris_lib import ArisFrame, HeaderValue, decode_as, encode_frame
from auvlink.errors import DecodeError, EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.aris import CUT, DROP, FRAME, WAIT, ArisFramer, frame_length, scan
from auvlink.framing.aris_defs import (
    FILE_HEADER_DTYPE,
    FILE_HEADER_SIZE,
    PING_MODE_BEAMS,
    SIGNATURE,
    beam_azimuths_rad,
    beam_table_name,
    beam_tables,
)

__all__ = [
    "PING_MODE_BEAMS", "WIRE_FORMAT", "ArisFile", "ArisFileHeader", "ArisFrame", "beam_azimuths_rad",
    "beam_table_name", "beam_tables", "decode", "decode_file_header", "encode", "encode_file",
    "encode_file_header", "ping_mode_azimuths_rad", "read_file",
]


def _latin1(value: Any) -> str:
    return bytes(value).decode("latin-1")


@dataclass(frozen=True, eq=False)
class ArisFileHeader:
    """The 1024-byte file header, kept whole (SDK field names, vendor units)."""

    header: np.void

    def __post_init__(self) -> None:
        if not isinstance(self.header, np.void) or self.header.dtype != FILE_HEADER_DTYPE:
            raise EncodeError("aris: ArisFileHeader.header must be a FILE_HEADER_DTYPE scalar")

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ArisFileHeader) and self.header.tobytes() == other.header.tobytes()

    version = HeaderValue("Version", int)
    #: as written by the recorder; :func:`read_file` counts the frames itself
    frame_count = HeaderValue("FrameCount", int)
    num_raw_beams = HeaderValue("NumRawBeams", int)
    samples_per_channel = HeaderValue("SamplesPerChannel", int)
    serial_number = HeaderValue("SN", int)
    date = HeaderValue("strDate", _latin1)
    header_id = HeaderValue("strHeaderID", _latin1)


def decode_file_header(raw: bytes | bytearray | memoryview) -> ArisFileHeader:
    """The file header at the start of ``raw`` (:class:`DecodeError` when it is not one)."""
    if len(raw) < FILE_HEADER_SIZE or bytes(raw[:4]) != SIGNATURE:
        raise DecodeError("aris: not an ARIS file (no DDF_05 file header)", fmt="aris", offset=0)
    return ArisFileHeader(np.frombuffer(raw, FILE_HEADER_DTYPE, count=1)[0])


def encode_file_header(header: ArisFileHeader) -> bytes:
    return header.header.tobytes()


def ping_mode_azimuths_rad(ping_mode: int, large_lens: bool = False) -> npt.NDArray[np.float64]:
    """Azimuth (rad, + to starboard) of each image column for an ARIS ping mode (column 0 = port)."""
    beams = PING_MODE_BEAMS.get(ping_mode)
    if beams is None:
        raise DecodeError(f"aris: unknown ping mode {ping_mode} (known: 1..12)", fmt="aris")
    return beam_azimuths_rad(beams, large_lens)


def decode(raw: bytes | bytearray | memoryview) -> ArisFrame:
    """One raw frame (header + image) -> :class:`ArisFrame`; the image is a view of ``raw``."""
    return decode_as(raw, ArisFrame)


def encode(frame: ArisFrame) -> bytes:
    """:class:`ArisFrame` -> raw frame bytes (header verbatim, image in the SDK beam order)."""
    return encode_frame(frame)


@dataclass(frozen=True)
class ArisFile:
    """A decoded recording; unpacks as ``header, frames = read_file(data)``.

    ``header`` is ``None`` for a bare stream of frames (no file header), e.g. exported from a log.
    """

    header: ArisFileHeader | None
    frames: list[ArisFrame]
    problems: list[str] = field(default_factory=list)
    stats: dict[str, int] = field(default_factory=dict)

    def __iter__(self) -> Iterator[Any]:
        return iter((self.header, self.frames))


#: how far into a file :func:`read_file` looks for a displaced file header (leading damage)
HEADER_SEARCH = 1 << 16


def _file_header_at(buf: bytes | bytearray) -> int:
    """Offset of the file header: 0 when the file starts with one; else the first ``DDF_05`` in the
    first :data:`HEADER_SEARCH` bytes that a sane frame header follows 1024 bytes later (bytes were
    inserted before the header); -1 when there is none (a bare stream, or a damaged file header)."""
    if bytes(buf[:4]) == SIGNATURE:
        return 0
    p = buf.find(SIGNATURE, 0, HEADER_SEARCH)
    while p >= 0:
        if frame_length(buf, p + FILE_HEADER_SIZE) > 0:
            return p
        p = buf.find(SIGNATURE, p + 1, HEADER_SEARCH)
    return -1


def read_file(data: bytes | bytearray | memoryview) -> ArisFile:
    """Decode a whole ``.aris`` recording (or a bare frame stream). Bad content never raises (see
    ``problems``): leading damage, a damaged or cut file header, a damaged frame header cost only the
    bytes they spoil, because frames are found by their header signature and sanity (resync). Only
    data holding neither a file header nor any frame raises. Images view ``data``."""
    buf = data if isinstance(data, bytes | bytearray) else bytes(data)
    header: ArisFileHeader | None = None
    problems: list[str] = []
    stats = {"frames": 0, "bytes_in": len(buf), "dropped_bytes": 0, "bad_checksums": 0, "truncated": 0}
    start = _file_header_at(buf)
    if start >= 0:
        header = decode_file_header(buf[start:])
        if start:
            problems.append(f"{start} bytes at offset 0 before the file header are not ARIS data")
            stats["dropped_bytes"] += start
        start += FILE_HEADER_SIZE
    else:
        start = 0
        if frame_length(buf, 0) <= 0:
            problems.append("no intact file header or frame at offset 0 (damaged or cut): frames found by headers")
    view = memoryview(buf)
    frames: list[ArisFrame] = []
    pos, garbage_at = start, -1
    while pos < len(buf):
        step = scan(buf, pos, final=True)
        if step.kind == DROP:
            garbage_at = pos if garbage_at < 0 else garbage_at
            stats["dropped_bytes"] += step.n
            pos += step.n
            continue
        if garbage_at >= 0:
            problems.append(f"{pos - garbage_at} bytes at offset {garbage_at} are not an ARIS frame")
            garbage_at = -1
        if step.kind == WAIT:
            want = frame_length(buf, pos)
            problems.append(f"truncated frame at offset {pos}: {len(buf) - pos} of {max(want, 1024)} bytes")
            stats["truncated"] += 1
            stats["dropped_bytes"] += len(buf) - pos
            break
        if step.kind == CUT:
            problems.append(f"frame at offset {pos} cut short after {step.n} bytes by the next frame")
            stats["truncated"] += 1
            stats["dropped_bytes"] += step.n
        elif step.kind == FRAME:
            try:
                frames.append(decode(view[pos : pos + step.n]))
            except DecodeError as exc:
                problems.append(f"frame at offset {pos}: {exc}")
        pos += step.n
    if garbage_at >= 0:
        problems.append(f"{len(buf) - garbage_at} bytes at offset {garbage_at} are not an ARIS frame")
    if header is None and not frames and not stats["truncated"]:
        raise DecodeError(f"aris: neither an ARIS file header nor an ARIS frame in {len(buf)} bytes", fmt="aris")
    stats["frames"] = len(frames)
    if header is not None and header.frame_count not in (0, len(frames)):
        problems.append(f"file header says {header.frame_count} frames, {len(frames)} found")
    return ArisFile(header, frames, problems, stats)


def encode_file(header: ArisFileHeader | None, frames: Iterable[ArisFrame]) -> bytes:
    """A recording's bytes: the file header (if any) then every frame (inverse of :func:`read_file`)."""
    head = [] if header is None else [encode_file_header(header)]
    return b"".join([*head, *(encode(f) for f in frames)])


def sensor_time(frame: ArisFrame) -> float:
    return frame.time


def to_json(frame: ArisFrame) -> dict[str, Any]:
    """A compact JSON summary (the image itself is left out)."""
    r, az = frame.ranges_m, frame.azimuths_rad
    return {
        "frame_index": frame.frame_index, "time": frame.time, "ping_mode": frame.ping_mode,
        "beams": frame.beam_count, "samples": frame.samples_per_beam, "sound_speed": frame.sound_speed,
        "window_start_m": frame.window_start_m, "window_length_m": frame.window_length_m,
        "range_min_m": float(r[0]), "range_max_m": float(r[-1]),
        "azimuth_min_rad": float(az[0]), "azimuth_max_rad": float(az[-1]),
        "heading": frame.heading, "pitch": frame.pitch, "roll": frame.roll,
        "image_mean": float(frame.image.mean()), "image_max": int(frame.image.max()),
    }


WIRE_FORMAT = WireFormat(
    name="aris",
    encoding="soundmetrics.aris",
    description="Sound Metrics ARIS frames (1024-byte header + beams x samples image); .aris files",
    decode=decode,
    encode=encode,
    framer=ArisFramer,
    sensor_time=sensor_time,
    to_json=to_json,
    read_file=read_file,
)
