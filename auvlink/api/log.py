"""Mission logs: :func:`open_log` -> :class:`MissionLog` (channels, metadata, loss report, decoded records)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

from auvlink.errors import AuvlinkError
from logs_format import ChannelInfo, LossReport, MissionLogReader, Replay
from logs_format.bounded_json import loads_bounded


@dataclass(frozen=True)
class LogRecord:
    """One decoded message of a mission log.

    ``record`` is the codec's record for a raw device channel (e.g. a ``Pd0Ensemble``) or the
    parsed JSON object of a JSON channel; ``t_ns`` is the log (receive) time, ns since the epoch.
    """

    channel: str
    device: str
    format: str | None
    t_ns: int
    record: Any


class MissionLog:
    """A mission log opened for reading (:func:`open_log`; a context manager).

    The log is indexed on opening (a cut-off or damaged log opens too: :attr:`loss` says what is
    missing); :meth:`records` streams and decodes, so memory does not grow with the log.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise AuvlinkError(f"{self.path}: no such log")
        self._reader = MissionLogReader(self.path)

    @property
    def channels(self) -> dict[str, ChannelInfo]:
        """Channels by topic (``.format`` is the wire format of a raw device channel, None for JSON)."""
        return self._reader.discover_channels()

    @property
    def metadata(self) -> dict[str, dict[str, Any]]:
        """The log's metadata records by name, JSON values decoded (vehicle config, truth, ...); a value over
        the JSON limits of :mod:`logs_format.bounded_json` is None (:attr:`metadata_problems` says why)."""
        return self._reader.metadata(decode_json=True)

    @property
    def metadata_problems(self) -> list[str]:
        """One line per metadata value refused (JSON too large or too deeply nested), key and limit."""
        self._reader.metadata(decode_json=True)
        return list(self._reader.metadata_problems)

    @property
    def loss(self) -> LossReport:
        """What a cut-off or damaged log lost (``loss.describe()``: one line; ``complete`` when whole)."""
        return self._reader.loss

    @property
    def duration_s(self) -> float:
        """Log time from the first to the last message, s."""
        return self._reader.duration_s

    def records(self, channels: Iterable[str] | None = None, start_ns: int | None = None,
                end_ns: int | None = None) -> Iterator[LogRecord]:
        """Decoded messages in log-time order, optionally of some channels (topic or device names) and
        ``start_ns <= t < end_ns``: raw frames through the live framers and codecs (as replay), JSON
        channels parsed. Frames of a format this install does not know, undecodable frames and damaged
        JSON messages are skipped (the drivers count them: ``auvlink log info`` lists them)."""
        with Replay(self.path, channels=channels, start_ns=start_ns, end_ns=end_ns) as rep:
            yield from self._decoded(rep)

    @staticmethod
    def _decoded(rep: Replay) -> Iterator[LogRecord]:
        pending: dict[str, int] = {}
        for msg in rep.frames():
            info = rep.reader.channels.get(msg.channel)
            if msg.format is None:
                if info is not None and info.message_encoding == "json":
                    try:
                        value = loads_bounded(msg.data)
                    except ValueError:  # damaged or over the JSON limits: skipped, as an undecodable frame is
                        continue
                    yield LogRecord(msg.channel, info.device, None, msg.log_time_ns, value)
                continue
            dec = rep.decoder(msg)
            if dec is None:
                continue
            out = dec.feed(msg.data, msg.log_time_ns)
            if not out:  # the framer waits for more bytes: its frame is stamped with this time
                pending[msg.channel] = msg.log_time_ns
            for s in out:
                yield LogRecord(msg.channel, s.device, s.format, s.t_host_ns, s.record)
        for channel, dec in rep.decoders.items():
            for s in dec.flush(pending.get(channel, 0)):
                yield LogRecord(channel, s.device, s.format, s.t_host_ns, s.record)

    def close(self) -> None:
        self._reader.close()

    def __enter__(self) -> MissionLog:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def open_log(path: str | Path) -> MissionLog:
    """Open a mission log (``.mcap`` written by ``auvlink record``, ``live``, ``sim`` or ``log import``)."""
    return MissionLog(path)
