"""The Python API: read captures, open mission logs, replay a log through the pipeline.

Reached from the root package (``auvlink.read``, ``auvlink.open_log``, ``auvlink.replay``; loaded on
first use, PEP 562, so ``import auvlink`` stays light):

* :func:`read` - the records of a raw capture of one wire format (or of a mission log), streamed.
* :func:`open_log` - a mission log: channels, metadata, the loss report, decoded records.
* :func:`replay` - a log through the streaming pipeline: detections as they are made, then the result.

Times are ns (log/receive time, UNIX epoch) unless a name says ``_s``; positions are world NED, m.
"""

from __future__ import annotations

import json
import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast, overload

from auvlink import formats
from auvlink.decode_file import CHUNK, DecodeResult
from auvlink.errors import AuvlinkError
from logs_format import ChannelInfo, LossReport, MissionLogReader, Replay

if TYPE_CHECKING:
    from auvlink.pipeline.results import Detection, MissionResult

__all__ = ["LogRecord", "MissionLog", "Records", "ReplayRun", "open_log", "read", "replay"]

_MCAP_MAGIC = b"\x89MCAP"


def _is_mcap(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(5) == _MCAP_MAGIC
    except OSError as exc:
        raise AuvlinkError(f"{path}: cannot read: {exc.strerror or exc}") from exc


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


class Records(Iterator[Any]):
    """The records of a raw capture, decoded frame by frame while iterating (the file is read in
    1 MiB blocks; a file format with a header, such as ARIS, is read whole). Bad frames are skipped and
    counted: :attr:`stats` (a :class:`auvlink.decode_file.DecodeResult`) is complete once exhausted."""

    def __init__(self, path: Path, fmt: formats.WireFormat) -> None:
        self.path, self.format = path, fmt
        self.stats = DecodeResult(format=fmt.name)
        self._it = self._records()

    def __next__(self) -> Any:
        return next(self._it)

    def _take(self, record: Any) -> Any:
        self.stats.records += 1
        t = self.format.sensor_time(record)
        if t is not None:
            lo, hi = self.stats.t_first, self.stats.t_last
            self.stats.t_first = t if lo is None else min(lo, t)
            self.stats.t_last = t if hi is None else max(hi, t)
        return record

    def _records(self) -> Iterator[Any]:
        fmt, st = self.format, self.stats
        try:
            f = open(self.path, "rb")
        except OSError as exc:
            raise AuvlinkError(f"{self.path}: cannot read: {exc.strerror or exc}") from exc
        with f:
            if fmt.read_file is not None:
                data = f.read()
                st.file_bytes = len(data)
                parsed = fmt.read_file(data)
                st.problems.extend(getattr(parsed, "problems", []))
                st.framer = dict(getattr(parsed, "stats", {}) or {})
                for record in getattr(parsed, "frames", []):
                    yield self._take(record)
                return
            framer = fmt.framer()
            index = 0
            while True:
                block = f.read(CHUNK)
                st.file_bytes += len(block)
                raws = framer.feed(block) if block else framer.flush()
                for raw in raws:
                    try:
                        record = fmt.decode(raw)
                    except (AuvlinkError, ValueError) as exc:
                        st.decode_errors += 1
                        st.problems.append(f"frame {index}: {exc}")
                    else:
                        yield self._take(record)
                    index += 1
                if not block:
                    break
            st.framer = framer.stats.as_dict()


@overload
def read(path: str | Path, format: str) -> Records: ...


@overload
def read(path: str | Path, format: None = None) -> Iterator[LogRecord]: ...


def read(path: str | Path, format: str | None = None) -> Records | Iterator[LogRecord]:
    """The records of ``path``, in file order, decoded while iterating.

    ``format`` names the wire format of a raw capture (``"pd0"``, ``"didson"``, ``"aris"``, ...;
    ``auvlink.formats.names()`` lists them); every good frame is decoded and bad ones are skipped and
    counted (the iterator's ``stats``). A mission log (``.mcap``, recognized by its magic bytes) needs
    no format: its messages come as :class:`LogRecord` in time order, as :meth:`MissionLog.records`.
    """
    p = Path(path)
    if not p.is_file():
        raise AuvlinkError(f"{p}: no such file")
    if format is None:
        if _is_mcap(p):
            return _log_records(p)
        raise AuvlinkError(f"{p}: not a mission log; name its wire format, e.g. read(path, format='pd0') "
                           f"(one of: {', '.join(formats.names())})")
    return Records(p, formats.get(format))


def _log_records(path: Path) -> Iterator[LogRecord]:
    with MissionLog(path) as log:
        yield from log.records()


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
        """The log's metadata records by name, JSON values decoded (vehicle config, truth, ...)."""
        return self._reader.metadata(decode_json=True)

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
                        value = json.loads(msg.data)
                    except ValueError:  # a damaged message: skipped, as an undecodable frame is
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


class _Stopped(Exception):
    """Raised inside the pipeline thread when the consumer stopped iterating."""


class ReplayRun(Iterator["Detection"]):
    """A replay in progress: iterate for the :class:`~auvlink.pipeline.results.Detection` objects as the
    engine makes them (the engine runs in a thread and waits when the consumer is slower: at most
    ``buffer`` detections are held); :attr:`result` is the whole :class:`MissionResult` after the last.

    Breaking out of the loop (or :meth:`close`) stops the engine.
    """

    def __init__(self, run: Callable[[Callable[[Detection], None]], MissionResult], buffer: int = 16) -> None:
        self._q: queue.Queue[tuple[str, Any]] = queue.Queue(maxsize=buffer)
        self._stop = threading.Event()
        self._result: MissionResult | None = None
        self._run = run
        self._thread = threading.Thread(target=self._work, name="auvlink-replay", daemon=True)
        self._done = False
        self._thread.start()

    def _put(self, item: tuple[str, Any]) -> None:
        while True:
            if self._stop.is_set():
                raise _Stopped
            try:
                self._q.put(item, timeout=0.1)
                return
            except queue.Full:
                continue

    def _work(self) -> None:
        try:
            result = self._run(lambda det: self._put(("det", det)))
        except _Stopped:
            return
        except BaseException as exc:  # handed to the consumer, raised there
            try:
                self._put(("err", exc))
            except _Stopped:
                pass
            return
        try:
            self._put(("end", result))
        except _Stopped:
            pass

    def __next__(self) -> Detection:
        if self._done:
            raise StopIteration
        kind, value = self._q.get()
        if kind == "det":
            return cast("Detection", value)
        self._done = True
        self._thread.join()
        if kind == "err":
            raise value
        self._result = value
        raise StopIteration

    @property
    def result(self) -> MissionResult:
        """The whole run (detections, track, timings, device statistics); iterates to the end first."""
        for _ in self:
            pass
        if self._result is None:
            raise AuvlinkError("the replay was stopped before its end: no result")
        return self._result

    def close(self) -> None:
        """Stop the engine (when still running) and wait for its thread."""
        if not self._done:
            self._done = True
            self._stop.set()
            self._thread.join()

    def __enter__(self) -> ReplayRun:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def __del__(self) -> None:
        self._stop.set()


def replay(log: str | Path | MissionLog, *, classify: bool = True, model: str | Path | None = None,
           speed: float | None = None, progress: bool = False, buffer: int = 16) -> ReplayRun:
    """Replay a mission log through the streaming pipeline (the engine of ``auvlink replay``).

    ``log`` is a path or a :class:`MissionLog`; ``classify=False`` stops after clustering (class
    ``unknown``); ``model`` a classifier checkpoint (default: the shipped one); ``speed`` paces the
    replay at that multiple of real time (None: as fast as possible). Returns a :class:`ReplayRun`:
    iterate it for the detections, then read ``.result``. Write the usual output folder with
    :func:`auvlink.pipeline.outputs.write_outputs` and :func:`auvlink.pipeline.report.write_report`.
    """
    from auvlink.pipeline.process import run_log  # lazy: SciPy, the engine and (when classifying) PyTorch

    path = log.path if isinstance(log, MissionLog) else Path(log)
    if not path.is_file():
        raise AuvlinkError(f"{path}: no such log")
    if speed is not None and speed <= 0:
        raise AuvlinkError(f"speed must be > 0, got {speed}")
    ckpt = Path(model) if model is not None else None
    return ReplayRun(lambda cb: run_log(path, speed=speed, model=ckpt, classify=classify, progress=progress,
                                        on_detection=cb), buffer=buffer)
