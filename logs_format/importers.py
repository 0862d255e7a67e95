"""Turn other recordings into mission logs.

* python-can log files (``.asc``, ``.blf``, ``.csv``, ``.log``, ``.trc``, ``.mf4``, ... whatever
  ``can.LogReader`` reads): every message (remote and error frames too) becomes a raw ``can``
  frame (the CAN transport's own 16-byte frame, :func:`auvlink.framing.can_frames.message_to_frame`)
  on one channel, at the file's timestamps. CAN FD payloads over 8 bytes are skipped and counted.
* raw serial captures: a byte file + a wire-format name. The bytes go through that format's
  framer exactly as a port's bytes would; each whole frame becomes a message. Times: ``rate_hz``
  spaces frames evenly; without it, the sensor's own clock where a frame has one, else 1 s steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auvlink import formats
from auvlink.errors import AuvlinkError, EncodeError
from auvlink.framing.can_frames import message_to_frame
from logs_format.profile import LogError
from logs_format.writer import MissionLogWriter

#: synthetic frame rates of a raw capture: one frame in 1000 s (slowest logged instrument, with room) to 1 MHz
#: (1 us apart, well inside ns times); beyond them frames share a time stamp or the times overflow int64 ns
MIN_RATE_HZ = 1e-3
MAX_RATE_HZ = 1e6

#: suffixes python-can's LogReader understands (``.gz`` variants too)
CAN_LOG_SUFFIXES = (".asc", ".blf", ".csv", ".db", ".log", ".trc", ".mf4")


@dataclass
class ImportResult:
    out: Path
    frames: int = 0
    skipped: int = 0  # CAN FD messages the raw CAN frame cannot carry
    framer: dict[str, int] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "frames": self.frames, "skipped": self.skipped, "framer": self.framer}


def is_can_log(path: str | Path) -> bool:
    suffixes = [s.lower() for s in Path(path).suffixes]
    if suffixes and suffixes[-1] == ".gz":
        suffixes = suffixes[:-1]
    return bool(suffixes) and suffixes[-1] in CAN_LOG_SUFFIXES


def _writer(out: str | Path, compression: str) -> MissionLogWriter:
    # derived from a file that is still there: a failed import leaves ``out`` as it was (keep_failed=False)
    return MissionLogWriter(out, compression=compression, flush_interval=0, fsync=False, keep_failed=False)


def import_can_log(
    src: str | Path, out: str | Path, *, device: str = "can", compression: str = "zstd"
) -> ImportResult:
    """A python-can log file -> a mission log with one ``can`` channel named ``device``."""
    import can  # lazy: python-can (0.2 s) loads only to import a CAN log, not with every logs_format import

    src = Path(src)
    result = ImportResult(Path(out))
    try:
        reader = can.LogReader(str(src))
    except (ValueError, OSError) as exc:
        raise LogError(f"python-can cannot read {src}: {exc}") from exc
    with reader, _writer(out, compression) as log:
        log.add_metadata("import", {"source": src.name, "kind": "python-can", "device": device})
        for msg in reader:
            try:
                raw = message_to_frame(msg)
            except EncodeError:  # a CAN FD payload longer than 8 bytes
                result.skipped += 1
                continue
            log(device, "can", max(0, round(msg.timestamp * 1e9)), raw)
            result.frames += 1
        _no_frames(src, result)
    return result


def _no_frames(src: Path, result: ImportResult) -> None:
    """An import that found nothing writes nothing (inside the writer's block: ``out`` keeps what it had)."""
    if not result.frames:
        raise LogError(f"{src}: no whole frame found (is the format right?)")


def import_serial_capture(
    src: str | Path,
    fmt: str,
    out: str | Path,
    *,
    device: str | None = None,
    rate_hz: float | None = None,
    start_ns: int = 0,
    compression: str = "zstd",
    block_size: int = 1 << 16,
) -> ImportResult:
    """A raw byte capture of one port -> a mission log (see the module docstring for times)."""
    wire = formats.get(fmt)
    if rate_hz is not None and not (math.isfinite(rate_hz) and MIN_RATE_HZ <= rate_hz <= MAX_RATE_HZ):
        raise LogError(f"--rate must be a number of Hz in [{MIN_RATE_HZ:g}, {MAX_RATE_HZ:g}], got {rate_hz}")
    src = Path(src)
    name = device or fmt
    framer = wire.framer()
    result = ImportResult(Path(out))
    t_prev: int | None = None

    def time_of(raw: bytes) -> tuple[int, int | None]:
        nonlocal t_prev
        if rate_hz is not None:
            t = start_ns + round(result.frames * 1e9 / rate_hz)
            t_prev = t
            return t, None
        t_sensor: float | None = None
        try:
            t_sensor = wire.sensor_time(wire.decode(raw))
        except (AuvlinkError, ValueError):
            pass
        if t_sensor is not None and t_sensor >= 0:
            t = round(t_sensor * 1e9)
            t_prev = t
            return t, t
        t = start_ns if t_prev is None else t_prev + 1_000_000_000
        t_prev = t
        return t, None

    try:
        f = open(src, "rb")
    except OSError as exc:
        raise LogError(f"cannot read {src}: {exc.strerror or exc}") from exc
    with f, _writer(out, compression) as log:
        meta: dict[str, Any] = {"source": src.name, "kind": "serial capture", "format": fmt,
                                "device": name, "rate_hz": rate_hz}
        while True:
            block = f.read(block_size)
            frames = framer.feed(block) if block else framer.flush()
            for raw in frames:
                t, t_sensor = time_of(raw)
                log(name, fmt, t, raw, t_sensor)
                result.frames += 1
            if not block:
                break
        result.framer = framer.stats.as_dict()
        _no_frames(src, result)
        log.add_metadata("import", {**meta, "framer": result.framer})
    return result
