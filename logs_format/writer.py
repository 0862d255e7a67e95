"""Write a mission log: a listener on the drivers' raw frames (one MCAP channel per device).

    with MissionLogWriter("mission.mcap") as log:
        log.add_vehicle_config(config)
        dvl.add_raw_listener(log)          # Driver.add_raw_listener: (device, format, t_host_ns, raw)
        ...

Chunks are compressed (zstd by default, lz4 or none), closed when they reach ``chunk_size`` bytes
*and* at least every ``flush_interval`` seconds (a background thread closes an idle chunk), then
written and optionally fsync'ed: a crash (kill -9, power loss) loses at most the last interval.
Thread-safe: drivers on several threads may share one writer.

The log is written as ``LOG.mcap.partial`` and renamed to ``LOG.mcap`` by :meth:`close`, so an
existing ``LOG.mcap`` (replaced only when the command line said ``--force``) keeps its content until
the new log is complete, and a run cut off by kill -9 or a power loss leaves ``LOG.mcap.partial``,
readable up to its last complete chunk. A write that fails (disk full, device gone) raises
:class:`~logs_format.profile.LogError` once; the file is then closed without its summary section
(readable up to its last complete chunk) and, with ``keep_failed`` (a recording: the only copy of
the data), renamed to ``LOG.mcap`` all the same; without it (a log derived from files that are still
there: ``sim``, ``log import``) it is removed and ``LOG.mcap`` keeps what it had.
"""

from __future__ import annotations

import os
import platform
import struct
import threading
import time
from collections.abc import Mapping
from contextlib import suppress
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

from mcap.writer import LIBRARY_IDENTIFIER, Writer

from auvlink import formats
from auvlink.atomic import partial_path, write_target
from auvlink.clock import now_ns
from auvlink.errors import UnknownFormatError
from auvlink.jsonutil import dumps
from auvlink.version import __version__
from logs_format.profile import (
    JSON_MESSAGE_ENCODING,
    JSON_SCHEMA_ENCODING,
    MESH_MEDIA_TYPES,
    META_GROUND_TRUTH,
    META_SOFTWARE,
    META_VEHICLE_CONFIG,
    PROFILE,
    LogError,
    compression_type,
    metadata_strings,
    wire_channel,
)
from logs_format.selfcontained import repeat_definitions
from logs_format.specs import schema_record

if TYPE_CHECKING:
    from auvlink.config import VehicleConfig

DEFAULT_CHUNK_SIZE = 4 * 1024 * 1024
DEFAULT_FLUSH_INTERVAL = 1.0
_U64 = 1 << 64


@dataclass
class ChannelStats:
    id: int
    format: str | None  # wire-format name; None for JSON channels
    frames: int = 0
    bytes: int = 0


def software_info() -> dict[str, str]:
    """The ``software`` metadata record: what wrote the log."""
    try:
        mcap_version = version("mcap")
    except PackageNotFoundError:  # pragma: no cover
        mcap_version = "unknown"
    return {"name": "auvlink", "version": __version__, "python": platform.python_version(),
            "mcap": mcap_version, "platform": platform.platform()}


class MissionLogWriter:
    """An MCAP mission log open for writing (see the module docstring)."""

    def __init__(
        self,
        path: str | Path,
        *,
        compression: str = "zstd",
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        flush_interval: float = DEFAULT_FLUSH_INTERVAL,
        fsync: bool = True,
        software: bool = True,
        atomic: bool = True,
        keep_failed: bool = True,
    ) -> None:
        if flush_interval < 0 or chunk_size <= 0:
            raise LogError("flush_interval must be >= 0 and chunk_size > 0")
        self.path = Path(path)
        self.flush_interval = flush_interval
        self.fsync = fsync
        self.keep_failed = keep_failed
        kind = compression_type(compression)
        self._target = write_target(self.path)
        #: where the bytes go until :meth:`close` renames them to ``path`` (``path`` itself without ``atomic``)
        self.partial = partial_path(self._target) if atomic else self.path
        try:
            self._file = open(self.partial, "xb" if atomic else "wb")
        except FileExistsError as exc:
            raise LogError(f"cannot create log {self.path}: {self.partial} exists (a run cut off, or one "
                           "still writing: rename it to keep it)") from exc
        except OSError as exc:
            raise LogError(f"cannot create log {self.path}: {exc.strerror or exc}") from exc
        self._mcap = Writer(self._file, chunk_size=chunk_size, compression=kind)
        repeat_definitions(self._mcap)  # every chunk names its channels: readable alone after damage
        self._lock = threading.Lock()
        self._channels: dict[str, ChannelStats] = {}
        self._schemas: dict[tuple[str, str, bytes], int] = {}
        self._chunk_t0: float | None = None  # monotonic time of the first message of the open chunk
        self._closed = False
        self._error: BaseException | None = None
        library = f"auvlink/{__version__} {LIBRARY_IDENTIFIER}"
        self._guard(lambda: self._mcap.start(profile=PROFILE, library=library))
        if software:
            self.add_metadata(META_SOFTWARE, software_info())
        self._stop = threading.Event()
        self._flusher: threading.Thread | None = None
        if flush_interval > 0:
            self._flusher = threading.Thread(target=self._flush_loop, name="auvlink-log-flush", daemon=True)
            self._flusher.start()

    # -- internals ------------------------------------------------------------------------
    def _guard(self, fn: Any) -> Any:
        try:
            return fn()
        except OSError as exc:  # disk full, device gone: the log is unusable from here on
            self._error = exc
            raise LogError(f"writing {self.path} failed: {exc.strerror or exc}") from exc
        except (struct.error, OverflowError) as exc:  # a value MCAP cannot hold
            raise LogError(f"{self.path}: value out of range for MCAP: {exc}") from exc

    def _check(self) -> None:
        if self._closed:
            raise LogError(f"log {self.path} is closed")
        if self._error is not None:
            raise LogError(f"log {self.path} failed earlier: {self._error}") from self._error

    def _schema(self, name: str, encoding: str, data: bytes) -> int:
        key = (name, encoding, data)
        if key not in self._schemas:
            self._schemas[key] = self._mcap.register_schema(name=name, encoding=encoding, data=data)
        return self._schemas[key]

    def _wire_channel(self, device: str, fmt: str) -> ChannelStats:
        try:
            encoding = formats.get(fmt).encoding
        except (UnknownFormatError, ImportError):  # a format this install does not know: keep its name
            encoding = fmt
        topic, msg_encoding, meta = wire_channel(device, fmt, encoding)
        schema_id = self._schema(*schema_record(fmt, encoding))
        cid = self._mcap.register_channel(topic=topic, message_encoding=msg_encoding,
                                          schema_id=schema_id, metadata=meta)
        stats = self._channels[device] = ChannelStats(cid, fmt)
        return stats

    def _add(self, ch: ChannelStats, log_time_ns: int, data: bytes, publish_time_ns: int) -> None:
        if not (0 <= log_time_ns < _U64 and 0 <= publish_time_ns < _U64):
            raise LogError(f"times must be u64 ns since the epoch, got {log_time_ns} / {publish_time_ns}")
        self._mcap.add_message(channel_id=ch.id, log_time=log_time_ns, data=data,
                               publish_time=publish_time_ns, sequence=ch.frames & 0xFFFFFFFF)
        ch.frames += 1
        ch.bytes += len(data)
        now = time.monotonic()
        if self._chunk_t0 is None:
            self._chunk_t0 = now
        elif self.flush_interval and now - self._chunk_t0 >= self.flush_interval:
            self._mcap.flush()
            self._chunk_t0 = None

    def _flush_loop(self) -> None:
        half = self.flush_interval / 2
        while not self._stop.wait(half):
            with self._lock:
                if self._closed or self._error is not None:
                    return
                due = self._chunk_t0 is not None and time.monotonic() - self._chunk_t0 >= half
            if due:
                try:
                    self.flush()
                except LogError:
                    return

    # -- the raw-frame listener ----------------------------------------------------------
    def __call__(self, device: str, format: str, t_host_ns: int, raw: bytes,
                 t_sensor_ns: int | None = None) -> None:
        """Record one raw frame of ``device`` (channel created on its first frame)."""
        with self._lock:
            self._check()
            ch = self._channels.get(device)
            if ch is None:
                ch = self._guard(lambda: self._wire_channel(device, format))
            elif ch.format != format:
                raise LogError(f"device {device!r} is logged as {ch.format!r}, got a {format!r} frame")
            pub = t_host_ns if t_sensor_ns is None else t_sensor_ns
            self._guard(lambda: self._add(ch, t_host_ns, bytes(raw), pub))

    write_frame = __call__

    def add_json(self, topic: str, schema_name: str, schema: Mapping[str, Any], log_time_ns: int,
                 message: Any, publish_time_ns: int | None = None) -> None:
        """Record one decoded message as JSON on ``topic`` (jsonschema ``schema``, see schemas.py)."""
        data = dumps(message, separators=(",", ":")).encode()
        with self._lock:
            self._check()
            ch = self._channels.get(topic)
            if ch is None:
                def make() -> ChannelStats:
                    sid = self._schema(schema_name, JSON_SCHEMA_ENCODING, dumps(schema).encode())
                    cid = self._mcap.register_channel(topic=topic, message_encoding=JSON_MESSAGE_ENCODING,
                                                      schema_id=sid, metadata={})
                    stats = self._channels[topic] = ChannelStats(cid, None)
                    return stats
                ch = self._guard(make)
            assert ch is not None
            pub = log_time_ns if publish_time_ns is None else publish_time_ns
            self._guard(lambda: self._add(ch, log_time_ns, data, pub))

    # -- metadata and attachments ---------------------------------------------------------
    def add_metadata(self, name: str, data: Mapping[str, Any]) -> None:
        """A metadata record; non-string values are stored as JSON text."""
        with self._lock:
            self._check()
            self._guard(lambda: self._mcap.add_metadata(name, metadata_strings(data)))

    def add_vehicle_config(self, config: VehicleConfig) -> None:
        """The ``vehicle_config`` record: the configuration as parsed (JSON) and its TOML text."""
        self.add_metadata(META_VEHICLE_CONFIG, {"source": config.source, "toml": config.text,
                                                "config": config.to_dict()})

    def add_ground_truth(self, data: Mapping[str, Any], meshes: Mapping[str, bytes] | None = None) -> None:
        """The ``ground_truth`` record of a simulated mission (scene, objects, ...) and its meshes,
        attached by file name (``"reef_a.stl"``; the suffix gives the media type)."""
        self.add_metadata(META_GROUND_TRUTH, data)
        for name, blob in (meshes or {}).items():
            media = MESH_MEDIA_TYPES.get(Path(name).suffix.lower(), "application/octet-stream")
            self.add_attachment(name, blob, media)

    def add_attachment(self, name: str, data: bytes, media_type: str = "application/octet-stream",
                       log_time_ns: int | None = None, create_time_ns: int = 0) -> None:
        t = now_ns() if log_time_ns is None else log_time_ns
        with self._lock:
            self._check()
            self._guard(lambda: self._mcap.add_attachment(create_time=create_time_ns, log_time=t, name=name,
                                                          media_type=media_type, data=bytes(data)))

    # -- flushing and closing -------------------------------------------------------------
    def flush(self) -> None:
        """Close the open chunk, write it and (with ``fsync``) push it to the disk."""
        with self._lock:
            self._check()
            self._guard(self._mcap.flush)
            self._chunk_t0 = None
        if self.fsync:
            self._guard(lambda: os.fsync(self._file.fileno()))

    def close(self) -> None:
        """Write the last chunk and the summary, close the file and rename it to ``path`` (idempotent).
        A failure raises :class:`LogError` once, never a bare ``OSError`` (see the module docstring)."""
        self._shutdown(finish=True)

    def abort(self) -> None:
        """Close without the summary; the file is removed unless ``keep_failed`` (then as :meth:`close`)."""
        self._shutdown(finish=self.keep_failed)

    def _shutdown(self, finish: bool) -> None:
        self._stop.set()
        if self._flusher is not None and self._flusher is not threading.current_thread():
            self._flusher.join()
        with self._lock:
            if self._closed:
                return
            self._closed = True
            failed_before = self._error is not None
            error: LogError | None = None
            try:
                if finish and not failed_before:
                    self._guard(self._mcap.finish)
                    self._guard(self._file.flush)
                    if self.fsync:
                        self._guard(lambda: os.fsync(self._file.fileno()))
            except LogError as exc:
                error = exc
            try:
                self._file.close()  # flushes the buffer: fails on a full disk; the descriptor is closed anyway
            except OSError as exc:
                self._error = self._error or exc
                if finish and error is None and not failed_before:
                    error = LogError(f"writing {self.path} failed: {exc.strerror or exc}")
            self._commit(finish and (self._error is None or self.keep_failed))
        if error is not None:
            raise error

    def _commit(self, keep: bool) -> None:
        if self.partial == self.path:
            return
        if not keep:
            with suppress(OSError):
                os.unlink(self.partial)
            return
        try:
            os.replace(self.partial, self._target)
        except OSError as exc:
            raise LogError(f"cannot rename {self.partial} to {self.path}: {exc.strerror or exc} "
                           f"(the log is in {self.partial})") from exc

    @property
    def closed(self) -> bool:
        return self._closed

    def counts(self) -> dict[str, int]:
        """Frames (messages) written per channel."""
        with self._lock:
            return {name: ch.frames for name, ch in self._channels.items()}

    def stats(self) -> dict[str, ChannelStats]:
        with self._lock:
            return {name: ChannelStats(ch.id, ch.format, ch.frames, ch.bytes)
                    for name, ch in self._channels.items()}

    def __enter__(self) -> MissionLogWriter:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        if et is None:
            self.close()
        elif self.keep_failed:  # a recording: keep what it holds, closed cleanly where the disk allows
            with suppress(LogError):
                self.close()
        else:
            self.abort()
