"""A driver reads one device: a transport feeding a :class:`~auvlink.decoder.Decoder`, with listeners.

The decoder (framer + codec + counters) is pure; the driver owns the I/O: it reads the transport,
stamps each chunk with the host receive time (:func:`auvlink.clock.now_ns`), and hands the chunk to
the decoder. Every raw frame goes to the driver's raw listeners (the mission-log writer is one)
whether or not it decodes, so a frame that fails to decode is still recorded; a listener added with
``sensor_time=True`` also gets the frame's sensor time (``t_sensor_ns=``, None when unknown). A frame
that fails to decode is counted and skipped; the next good frame is kept. Opening (or reopening,
after the port went) starts a fresh byte stream: bytes buffered before belong to no frame.

    with Driver("dvl", "pd0", "/dev/ttyUSB0?baudrate=115200") as dvl:
        for sample in dvl.samples(duration=10.0):
            print(sample.t_host, sample.record.bt_velocity)
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from types import TracebackType
from typing import Any

from auvlink.clock import now_ns
from auvlink.decoder import Decoder, DecoderStats
from auvlink.framing.base import Framer
from auvlink.records import Sample
from auvlink.transports.base import Transport, transport_class

#: a listener receives every raw frame as it arrives (device, format, t_host_ns, raw bytes)
RawListener = Callable[[str, str, int, bytes], None]
SampleListener = Callable[[Sample], None]


class Driver:
    """Reads one device. ``transport`` is a URL or an already-built :class:`Transport`."""

    def __init__(self, name: str, fmt: str, transport: str | Transport) -> None:
        self.decoder = Decoder(name, fmt)
        self.name, self.format = name, self.decoder.format  # (the decoder's, as plain attributes: per frame)
        self.transport = transport_class(transport)(transport) if isinstance(transport, str) else transport
        self._raw_listeners: list[tuple[Callable[..., None], bool]] = []
        self._sample_listeners: list[SampleListener] = []

    @property
    def framer(self) -> Framer:
        return self.decoder.framer

    @property
    def stats(self) -> DecoderStats:
        return self.decoder.stats

    # -- listeners ------------------------------------------------------------------------
    def add_raw_listener(self, listener: Callable[..., None], sensor_time: bool = False) -> None:
        """``listener(device, format, t_host_ns, raw)`` (+ ``t_sensor_ns=`` with ``sensor_time``)."""
        self._raw_listeners.append((listener, sensor_time))

    def add_listener(self, listener: SampleListener) -> None:
        self._sample_listeners.append(listener)

    # -- life cycle -----------------------------------------------------------------------
    def open(self) -> Driver:
        """Open the transport; the decoder forgets bytes of a previous opening (a partial frame)."""
        self.transport.open()
        self.decoder.reset()
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
        if not data:
            return []
        t_host_ns = now_ns()
        dec = self.decoder
        if not (self._raw_listeners or self._sample_listeners):
            return dec.feed(data, t_host_ns)
        out: list[Sample] = []
        for raw in dec.cut(data):
            sample = dec.decode(raw, t_host_ns)
            if self._raw_listeners:
                self._tap(raw, t_host_ns, sample)
            if sample is not None:
                out.append(sample)
                for listener in self._sample_listeners:
                    listener(sample)
        return out

    def _tap(self, raw: bytes, t_host_ns: int, sample: Sample | None) -> None:
        t_sensor = None if sample is None else sample.t_sensor
        t_sensor_ns = None if t_sensor is None else round(t_sensor * 1e9)
        for raw_listener, with_time in self._raw_listeners:
            if with_time:
                raw_listener(self.name, self.format.name, t_host_ns, raw, t_sensor_ns=t_sensor_ns)
            else:
                raw_listener(self.name, self.format.name, t_host_ns, raw)

    def samples(self, duration: float | None = None, timeout: float = 0.1) -> Iterator[Sample]:
        """Iterate samples for ``duration`` s (forever when None)."""
        end = None if duration is None else time.monotonic() + duration
        while end is None or time.monotonic() < end:
            yield from self.read(timeout)

    def __iter__(self) -> Iterator[Sample]:
        return self.samples()

    def describe(self) -> dict[str, Any]:
        """Name, format, transport URL and the decoder's counters, JSON-ready."""
        d = self.decoder.describe()
        return {"name": d.pop("name"), "format": d.pop("format"), "url": self.transport.url, **d}
