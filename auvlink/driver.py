"""A driver = transport + framer + codec. It yields timestamped :class:`~auvlink.records.Sample`.

Every raw frame goes to the driver's raw listeners (the mission-log writer is one) whether or not
it decodes, so a frame that fails to decode is still recorded; a listener added with
``sensor_time=True`` also gets the frame's sensor time (``t_sensor_ns=``, None when unknown).
A frame that fails to decode is counted and skipped; the next good frame is kept.

    with Driver("dvl", "pd0", "/dev/ttyUSB0?baudrate=115200") as dvl:
        for sample in dvl.samples(duration=10.0):
            print(sample.t_host, sample.record.bt_velocity)
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any

from auvlink import formats
from auvlink.clock import now_ns
from auvlink.errors import AuvlinkError, DecodeError
from auvlink.records import Sample
from auvlink.transports.base import Transport, transport_class

#: a listener receives every raw frame as it arrives (device, format, t_host_ns, raw bytes)
RawListener = Callable[[str, str, int, bytes], None]
SampleListener = Callable[[Sample], None]


@dataclass
class DriverStats:
    """Counters of one driver (frames decoded, decode errors, and the framer's own counters)."""

    samples: int = 0
    decode_errors: int = 0
    last_error: str = ""
    framer: dict[str, int] = field(default_factory=dict)


class Driver:
    """Reads one device. ``transport`` is a URL or an already-built :class:`Transport`."""

    def __init__(self, name: str, fmt: str, transport: str | Transport) -> None:
        self.name = name
        self.format = formats.get(fmt)
        self.transport = transport_class(transport)(transport) if isinstance(transport, str) else transport
        self.framer = self.format.framer()
        self.stats = DriverStats()
        self._raw_listeners: list[tuple[Callable[..., None], bool]] = []
        self._sample_listeners: list[SampleListener] = []

    # -- listeners ------------------------------------------------------------------------
    def add_raw_listener(self, listener: Callable[..., None], sensor_time: bool = False) -> None:
        """``listener(device, format, t_host_ns, raw)`` (+ ``t_sensor_ns=`` with ``sensor_time``)."""
        self._raw_listeners.append((listener, sensor_time))

    def add_listener(self, listener: SampleListener) -> None:
        self._sample_listeners.append(listener)

    # -- life cycle -----------------------------------------------------------------------
    def open(self) -> Driver:
        self.transport.open()
        return self

    def close(self) -> None:
        self.transport.close()

    def __enter__(self) -> Driver:
        return self.open()

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # -- reading --------------------------------------------------------------------------
    def read(self, timeout: float | None = 0.1) -> list[Sample]:
        """Read what the transport has within ``timeout`` and return the whole frames decoded."""
        data = self.transport.read(timeout)
        t_host = now_ns()
        return self.process(self.framer.feed(data), t_host) if data else []

    def process(self, frames: list[bytes], t_host_ns: int) -> list[Sample]:
        """Hand raw frames to listeners, decode them, and return the good samples."""
        out: list[Sample] = []
        for raw in frames:
            sample = self.decode_frame(raw, t_host_ns)
            if self._raw_listeners:
                t_sensor = None if sample is None or sample.t_sensor is None else sample.t_sensor
                t_sensor_ns = None if t_sensor is None else round(t_sensor * 1e9)
                for raw_listener, with_time in self._raw_listeners:
                    if with_time:
                        raw_listener(self.name, self.format.name, t_host_ns, raw, t_sensor_ns=t_sensor_ns)
                    else:
                        raw_listener(self.name, self.format.name, t_host_ns, raw)
            if sample is not None:
                out.append(sample)
                for listener in self._sample_listeners:
                    listener(sample)
        self.stats.framer = self.framer.stats.as_dict()
        return out

    def decode_frame(self, raw: bytes, t_host_ns: int) -> Sample | None:
        """Decode one raw frame into a :class:`Sample`; count and skip it when it is bad."""
        try:
            record = self.format.decode(raw)
        except (DecodeError, AuvlinkError, ValueError) as exc:
            self.stats.decode_errors += 1
            self.stats.last_error = str(exc)
            return None
        except Exception as exc:  # a codec bug on hostile bytes must not stop the port: count it
            self.stats.decode_errors += 1
            self.stats.last_error = f"{type(exc).__name__}: {exc}"
            return None
        self.stats.samples += 1
        return Sample(
            device=self.name,
            format=self.format.name,
            t_host_ns=t_host_ns,
            raw=raw,
            record=record,
            t_sensor=self.format.sensor_time(record),
        )

    def samples(self, duration: float | None = None, timeout: float = 0.1) -> Iterator[Sample]:
        """Iterate samples for ``duration`` s (forever when None)."""
        end = None if duration is None else time.monotonic() + duration
        while end is None or time.monotonic() < end:
            yield from self.read(timeout)

    def __iter__(self) -> Iterator[Sample]:
        return self.samples()

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "format": self.format.name,
            "url": self.transport.url,
            "samples": self.stats.samples,
            "decode_errors": self.stats.decode_errors,
            **{f"framer_{k}": v for k, v in self.framer.stats.as_dict().items()},
        }
