"""Raw captures: :func:`read` -> the records of a file of one wire format (or of a mission log), streamed."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any, overload

from auvlink import formats
from auvlink.api.log import LogRecord, MissionLog
from auvlink.decode_file import CHUNK, DecodeResult
from auvlink.errors import AuvlinkError

_MCAP_MAGIC = b"\x89MCAP"


def _is_mcap(path: Path) -> bool:
    try:
        with open(path, "rb") as f:
            return f.read(5) == _MCAP_MAGIC
    except OSError as exc:
        raise AuvlinkError(f"{path}: cannot read: {exc.strerror or exc}") from exc


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
    if not p.is_file():  # a folder, or a FIFO or device that would block or never end
        raise AuvlinkError(f"{p}: {'not a regular file (a folder, FIFO or device)' if p.exists() else 'no such file'}")
    if format is None:
        if _is_mcap(p):
            return _log_records(p)
        raise AuvlinkError(f"{p}: not a mission log; name its wire format, e.g. read(path, format='pd0') "
                           f"(one of: {', '.join(formats.names())})")
    return Records(p, formats.get(format))


def _log_records(path: Path) -> Iterator[LogRecord]:
    with MissionLog(path) as log:
        yield from log.records()
