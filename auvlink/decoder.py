"""The byte decoder of one device: the format's framer, then its codec, and the counters of both.

Pure: no I/O and no clock. The caller says when the bytes arrived (``t_host_ns``, the host receive
time stamped on every :class:`~auvlink.records.Sample` they give), so the same bytes give the same
samples however they are cut into chunks (a frame is stamped with the time of the chunk that
completed it). A live device feeds it from its transport (:class:`auvlink.driver.Driver`), replay
from the log's messages (:class:`logs_format.Replay`): both run the same framer -> codec -> record.

    dec = Decoder("dvl", "pd0")
    for sample in dec.feed(data, t_host_ns):
        print(sample.record.bt_velocity_mps)

A frame that fails to decode is counted (``stats.decode_errors``, ``stats.last_error``) and skipped;
the next good frame is kept. :meth:`Decoder.cut` and :meth:`Decoder.decode` are the two halves of
:meth:`Decoder.feed`, for a caller that wants every raw frame, good or not (the mission log does).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from auvlink import formats
from auvlink.errors import AuvlinkError, DecodeError
from auvlink.formats import WireFormat
from auvlink.framing.base import FramerStats
from auvlink.records import Sample


@dataclass
class DecoderStats:
    """Counters of one decoder: samples decoded, decode errors, and the framer's own counters."""

    samples: int = 0
    decode_errors: int = 0
    last_error: str = ""
    framer_stats: FramerStats = field(default_factory=FramerStats, repr=False)

    @property
    def framer(self) -> dict[str, int]:
        """The framer's counters now (frames, bytes_in, dropped_bytes, bad_checksums, truncated)."""
        return self.framer_stats.as_dict()


class Decoder:
    """Bytes of device ``name`` in wire format ``fmt`` (a name or a :class:`WireFormat`) -> samples."""

    def __init__(self, name: str, fmt: str | WireFormat) -> None:
        self.name = name
        self.format = formats.get(fmt) if isinstance(fmt, str) else fmt
        self.framer = self.format.framer()
        self.stats = DecoderStats(framer_stats=self.framer.stats)

    def feed(self, data: bytes, t_host_ns: int) -> list[Sample]:
        """The samples of every frame ``data`` completes (bytes received at ``t_host_ns``), in order."""
        out = []
        for raw in self.framer.feed(data):
            sample = self.decode(raw, t_host_ns)
            if sample is not None:
                out.append(sample)
        return out

    def flush(self, t_host_ns: int) -> list[Sample]:
        """End of stream: the samples of what is still whole (a partial frame counts as truncated)."""
        return [s for raw in self.framer.flush() if (s := self.decode(raw, t_host_ns)) is not None]

    def reset(self) -> None:
        """Forget buffered bytes (the stream was broken, e.g. a port reopened); counters are kept."""
        self.framer.reset()

    def cut(self, data: bytes) -> list[bytes]:
        """The framer alone: the raw frames ``data`` completes."""
        return self.framer.feed(data)

    def decode(self, raw: bytes, t_host_ns: int) -> Sample | None:
        """The codec alone: one raw frame -> :class:`Sample`, or None (counted) when it does not decode."""
        fmt = self.format
        try:
            record = fmt.decode(raw)
        except (DecodeError, AuvlinkError, ValueError) as exc:
            self.stats.decode_errors += 1
            self.stats.last_error = str(exc)
            return None
        except Exception as exc:  # a codec bug on hostile bytes must not stop the device: count it
            self.stats.decode_errors += 1
            self.stats.last_error = f"{type(exc).__name__}: {exc}"
            return None
        self.stats.samples += 1
        return Sample(device=self.name, format=fmt.name, t_host_ns=t_host_ns, raw=raw, record=record,
                      t_sensor=fmt.sensor_time(record))

    def describe(self) -> dict[str, Any]:
        """Name, format and counters (``framer_*`` for the framer's), JSON-ready."""
        return {"name": self.name, "format": self.format.name, "samples": self.stats.samples,
                "decode_errors": self.stats.decode_errors,
                **{f"framer_{k}": v for k, v in self.framer.stats.as_dict().items()}}
