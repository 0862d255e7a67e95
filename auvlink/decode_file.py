"""Decode a whole capture file of one wire format: framer + codec, counting everything bad.

Used by ``auvlink decode``, the log importers and the benchmarks. Nothing here raises for bad
content: every good frame is decoded and every bad one is described in ``problems``.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auvlink.errors import AuvlinkError
from auvlink.formats import WireFormat

CHUNK = 1 << 20
#: problem lines kept per file; the rest are counted (``problems_left_out``) so memory stays bounded
MAX_PROBLEMS = 1000


@dataclass
class DecodeResult:
    """What decoding one file gave."""

    format: str
    file_bytes: int = 0
    records: int = 0
    decode_errors: int = 0
    framer: dict[str, int] = field(default_factory=dict)
    t_first: float | None = None
    t_last: float | None = None
    problems: list[str] = field(default_factory=list)
    #: problems beyond :data:`MAX_PROBLEMS` (counted, not kept; ``problems[-1]`` is always the latest)
    problems_left_out: int = 0

    def reason(self) -> str:
        if self.file_bytes == 0:
            return "the file is empty"
        if self.decode_errors:
            return f"{self.decode_errors} frames failed to decode; last: {self.problems[-1]}"
        return f"no {self.format} frame found in {self.file_bytes} bytes"

    def losses(self) -> dict[str, int]:
        """What was skipped, by kind: ``skipped_bytes`` outside any whole frame (garbage, damaged frames;
        the truncated tail excluded), ``bad_checksums`` (frames), ``truncated_frames`` and
        ``truncated_tail_bytes`` (the partial frame the file ends in)."""
        fr = self.framer
        tail = fr.get("truncated_bytes", 0)
        return {"skipped_bytes": fr.get("dropped_bytes", 0) - tail, "bad_checksums": fr.get("bad_checksums", 0),
                "truncated_frames": fr.get("truncated", 0), "truncated_tail_bytes": tail}

    def summary(self) -> dict[str, Any]:
        return {
            "format": self.format,
            "file_bytes": self.file_bytes,
            "records": self.records,
            "decode_errors": self.decode_errors,
            "losses": self.losses(),
            "framer": self.framer,
            "t_first": _iso(self.t_first),
            "t_last": _iso(self.t_last),
            "problems": len(self.problems) + self.problems_left_out,
        }

    def human_summary(self) -> str:
        lo = self.losses()
        lines = [
            f"format      {self.format}",
            f"bytes       {self.file_bytes}",
            f"records     {self.records}",
            f"time span   {_iso(self.t_first) or '-'} .. {_iso(self.t_last) or '-'}",
            f"bad         {self.decode_errors} undecodable frames, {lo['bad_checksums']} bad checksums, "
            f"{lo['skipped_bytes']} bytes skipped outside frames, "
            f"truncated tail {lo['truncated_tail_bytes']} bytes",
        ]
        return "\n".join(lines)


def _iso(t: float | None) -> str | None:
    if t is None:
        return None
    return dt.datetime.fromtimestamp(t, dt.UTC).isoformat().replace("+00:00", "Z")


def decode_bytes(data: bytes, fmt: WireFormat, emit: Callable[[Any], None]) -> DecodeResult:
    """Frame and decode ``data``; call ``emit(record)`` for each good record in order."""
    result = DecodeResult(format=fmt.name, file_bytes=len(data))
    if fmt.read_file is not None:
        frames_or_records = fmt.read_file(data)
        frames = list(frames_or_records.frames) if hasattr(frames_or_records, "frames") else []
        problems = getattr(frames_or_records, "problems", [])
        result.problems.extend(problems)
        for record in frames:
            _take(result, fmt, record, emit)
        result.framer = dict(getattr(frames_or_records, "stats", {}) or {})
        return result
    framer = fmt.framer()
    view = memoryview(data)
    index = 0
    for start in range(0, max(len(data), 1), CHUNK):
        raw_frames = framer.feed(bytes(view[start : start + CHUNK]))
        index = _decode_frames(result, fmt, raw_frames, emit, index)
    index = _decode_frames(result, fmt, framer.flush(), emit, index)
    result.framer = framer.stats.as_dict()
    lo = result.losses()
    if lo["bad_checksums"]:
        result.problems.append(f"{lo['bad_checksums']} frame(s) with a bad checksum were skipped")
    if lo["skipped_bytes"]:
        result.problems.append(f"{lo['skipped_bytes']} bytes outside any whole frame were skipped "
                               "(garbage, or the bytes of damaged frames)")
    cut_inside = lo["truncated_frames"] - (1 if lo["truncated_tail_bytes"] else 0)
    if cut_inside > 0:
        result.problems.append(f"{cut_inside} frame(s) cut short by the next frame")
    if lo["truncated_tail_bytes"]:
        result.problems.append(f"the file ends inside a frame: a truncated frame of "
                               f"{lo['truncated_tail_bytes']} bytes at the end")
    return result


def _decode_frames(
    result: DecodeResult, fmt: WireFormat, raw_frames: list[bytes], emit: Callable[[Any], None], index: int
) -> int:
    for raw in raw_frames:
        try:
            record = fmt.decode(raw)
        except (AuvlinkError, ValueError) as exc:
            result.decode_errors += 1
            if len(result.problems) < MAX_PROBLEMS:
                result.problems.append(f"frame {index}: {exc}")
            else:  # a file of a million bad frames must not hold a million strings
                result.problems[-1] = f"frame {index}: {exc}"
                result.problems_left_out += 1
        else:
            _take(result, fmt, record, emit)
        index += 1
    return index


def _take(result: DecodeResult, fmt: WireFormat, record: Any, emit: Callable[[Any], None]) -> None:
    result.records += 1
    t = fmt.sensor_time(record)
    if t is not None:
        result.t_first = t if result.t_first is None else min(result.t_first, t)
        result.t_last = t if result.t_last is None else max(result.t_last, t)
    emit(record)


def decode_path(path: Path, fmt: WireFormat, emit: Callable[[Any], None]) -> DecodeResult:
    """:func:`decode_bytes` on a file's contents."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise AuvlinkError(f"{path}: cannot read: {exc.strerror}") from exc
    return decode_bytes(data, fmt, emit)
