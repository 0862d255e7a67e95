"""What is in a mission log: duration, per channel count, rate, gaps and decode errors, metadata.

:func:`log_info` reads the log once (streaming) and returns a JSON-ready dict; ``auvlink log info``
prints it (``--json``) or :func:`format_info` of it. A gap is an interval between two frames of
a channel longer than ``gap_factor`` times the channel's median period. Decode errors are counted
by running every frame through its wire format's codec (``decode=False`` skips that).
"""

from __future__ import annotations

import datetime as dt
from array import array
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from auvlink import formats
from auvlink.errors import AuvlinkError
from logs_format.reader import MissionLogReader


@dataclass
class _Acc:
    times: array = field(default_factory=lambda: array("Q"))  # log times are u64 ns (MCAP)
    bytes: int = 0
    decode_errors: int = 0
    last_error: str = ""
    sequence_jumps: int = 0
    last_seq: int | None = None


def iso_utc(t_ns: int | None) -> str | None:
    if t_ns is None:
        return None
    return dt.datetime.fromtimestamp(t_ns * 1e-9, dt.UTC).isoformat().replace("+00:00", "Z")


def _gaps(times: np.ndarray, t0: int, factor: float, max_gaps: int) -> dict[str, Any]:
    if times.size < 3:
        return {"median_period_s": None, "n_gaps": 0, "max_gap_s": None, "gaps": []}
    times = np.sort(times)
    d = np.diff(times)
    median = float(np.median(d))
    idx = np.flatnonzero(d > factor * median) if median > 0 else np.array([], dtype=np.int64)
    gaps = [{"start_s": (int(times[i]) - t0) * 1e-9, "duration_s": int(d[i]) * 1e-9} for i in idx[:max_gaps]]
    return {"median_period_s": median * 1e-9, "n_gaps": int(idx.size),
            "max_gap_s": float(d.max()) * 1e-9, "gaps": gaps}


def log_info(
    path: str | Path, *, decode: bool = True, gap_factor: float = 3.0, max_gaps: int = 20
) -> dict[str, Any]:
    """Summary of the log at ``path`` (see the module docstring). Never raises for damage."""
    path = Path(path)
    with MissionLogReader(path) as log:
        acc: dict[str, _Acc] = {}
        # per channel: its accumulator and its codec's decode (None: not decoded), looked up once
        routes: dict[str, tuple[_Acc, Callable[[bytes], Any] | None]] = {}
        for msg in log.messages():
            route = routes.get(msg.channel)
            if route is None:
                fn = None
                if decode and msg.format is not None:
                    try:
                        fn = formats.get(msg.format).decode
                    except (AuvlinkError, ImportError):
                        fn = None
                route = routes[msg.channel] = (acc.setdefault(msg.channel, _Acc()), fn)
            a, fn = route
            data, seq = msg.data, msg.sequence
            a.times.append(msg.log_time_ns)
            a.bytes += len(data)
            if a.last_seq is not None and seq != (a.last_seq + 1) & 0xFFFFFFFF:
                a.sequence_jumps += 1
            a.last_seq = seq
            if fn is not None:
                try:
                    fn(data)
                except (AuvlinkError, ValueError) as exc:
                    a.decode_errors += 1
                    a.last_error = str(exc)
        t0, t1 = log.start_ns, log.end_ns
        channels: dict[str, Any] = {}
        for topic, info in sorted(log.channels.items()):
            a = acc.get(topic, _Acc())
            times = np.frombuffer(a.times, dtype=np.uint64) if len(a.times) else np.zeros(0, np.uint64)
            n = int(times.size)
            span = (int(times.max()) - int(times.min())) * 1e-9 if n > 1 else 0.0
            channels[topic] = {
                "device": info.device,
                "format": info.format,
                "encoding": info.message_encoding,
                "schema": info.schema_name,
                "count": n,
                "bytes": a.bytes,
                "rate_hz": (n - 1) / span if span > 0 else None,
                "first_s": (int(times.min()) - (t0 or 0)) * 1e-9 if n else None,
                "last_s": (int(times.max()) - (t0 or 0)) * 1e-9 if n else None,
                **_gaps(times, t0 or 0, gap_factor, max_gaps),
                "decode_errors": a.decode_errors if decode and info.format is not None else None,
                "last_error": a.last_error,
                "sequence_jumps": a.sequence_jumps,
            }
        return {
            "path": str(path),
            "size_bytes": log.loss.file_bytes,
            "complete": log.complete,
            "profile": log.index.profile,
            "library": log.index.library,
            "start_time": iso_utc(t0),
            "end_time": iso_utc(t1),
            "duration_s": log.duration_s,
            "message_count": sum(c["count"] for c in channels.values()),
            "chunk_count": len(log.chunks),
            "channels": channels,
            "metadata": log.metadata(decode_json=True),
            "metadata_problems": list(log.metadata_problems),  # values refused (JSON over the size or depth limit)
            "attachments": [{"name": a.name, "media_type": a.media_type, "size": a.size}
                            for a in log.attachments()],
            "loss": log.loss.to_json(),
        }


def format_info(info: dict[str, Any]) -> str:
    """The human form of :func:`log_info`'s dict."""
    lines = [
        f"{info['path']}: {info['size_bytes'] / 1e6:.1f} MB, {info['duration_s']:.1f} s, "
        f"{info['message_count']} messages in {info['chunk_count']} chunks",
        f"  time   {info['start_time']} .. {info['end_time']}",
        f"  state  {info['loss']['summary']}",
        f"  {'channel':<14}{'format':<10}{'count':>9}{'rate Hz':>10}{'gaps':>6}{'max dt s':>11}"
        f"{'errors':>8}",
    ]
    for name, ch in info["channels"].items():
        rate = "-" if ch["rate_hz"] is None else f"{ch['rate_hz']:.2f}"
        gap = "-" if ch["max_gap_s"] is None else f"{ch['max_gap_s']:.3f}"
        err = "-" if ch["decode_errors"] is None else str(ch["decode_errors"])
        lines.append(f"  {name:<14}{ch['format'] or ch['encoding']:<10}{ch['count']:>9}{rate:>10}"
                     f"{ch['n_gaps']:>6}{gap:>11}{err:>8}")
    for name, meta in info["metadata"].items():
        keys = ", ".join(sorted(meta))
        lines.append(f"  metadata {name}: {keys}")
    for problem in info.get("metadata_problems", []):
        lines.append(f"  warning: {problem}")
    for att in info["attachments"]:
        lines.append(f"  attachment {att['name']} ({att['media_type']}, {att['size']} bytes)")
    return "\n".join(lines)
