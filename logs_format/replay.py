"""Replay a mission log: a timed iterator over its raw frames, fed through the live path.

Each device channel gets a :class:`~auvlink.driver.Driver` whose transport is the log itself
(:class:`LogTransport`); every raw frame goes through that driver's framer and codec exactly as
bytes from a port would (``driver.process(driver.framer.feed(raw), t_host_ns)``), so replay and
live produce the same :class:`~auvlink.records.Sample` objects, with ``t_host_ns`` = the recorded
receive time. Pacing: ``speed=None`` as fast as possible, ``1.0`` real time, ``N`` N times real
time (an absolute schedule, so sleeping errors do not accumulate). The order of frames is the
reader's time-ordered merge: the same log always replays the same sequence.

    for sample in replay_samples("mission.mcap", speed=10.0):
        ...
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from types import TracebackType
from typing import Any

from auvlink import formats
from auvlink.driver import Driver, SampleListener
from auvlink.errors import AuvlinkError, TransportOperationError
from auvlink.records import Sample
from auvlink.transports.base import Transport
from logs_format.chunks import LogMessage
from logs_format.reader import MissionLogReader
from logs_format.scan import LossReport


class LogTransport(Transport):
    """The stand-in port of a replayed device: frames come from the log, not from ``read``."""

    schemes = ("log",)

    def _open(self) -> None:
        pass

    def _close(self) -> None:
        pass

    def _read(self, timeout: float | None) -> bytes:
        raise TransportOperationError(f"{self.url}: a replayed device is fed by the log, not read")

    def _write(self, data: bytes) -> None:
        raise TransportOperationError(f"{self.url}: a replayed device cannot be written to")


def paced(
    messages: Iterable[LogMessage],
    speed: float | None = None,
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> Iterator[LogMessage]:
    """Yield ``messages`` no earlier than their log time allows at ``speed`` x real time."""
    if speed is None or speed <= 0 or math.isinf(speed):
        yield from messages
        return
    t0_log: int | None = None
    t0_wall = 0.0
    for msg in messages:
        if t0_log is None:
            t0_log, t0_wall = msg.log_time_ns, clock()
        due = t0_wall + (msg.log_time_ns - t0_log) * 1e-9 / speed
        delay = due - clock()
        if delay > 0:
            sleep(delay)
        yield msg


class Replay:
    """A log opened for replay (a context manager). Drivers are made per channel on first use."""

    def __init__(
        self,
        path: str | Path,
        *,
        speed: float | None = None,
        channels: Iterable[str] | None = None,
        start_ns: int | None = None,
        end_ns: int | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.path = Path(path)
        self.speed = speed
        self.reader = MissionLogReader(self.path)
        self._filters: dict[str, Any] = {"channels": channels, "start_ns": start_ns, "end_ns": end_ns}
        self._clock, self._sleep = clock, sleep
        self.drivers: dict[str, Driver] = {}
        self.skipped: dict[str, int] = {}  # channel -> frames of a format this install cannot decode
        self._listeners: list[SampleListener] = []
        self._last_t: dict[str, int] = {}

    @property
    def loss(self) -> LossReport:
        return self.reader.loss

    def add_listener(self, listener: SampleListener) -> None:
        """Call ``listener(sample)`` for every decoded sample of every device (as on live drivers)."""
        self._listeners.append(listener)
        for drv in self.drivers.values():
            drv.add_listener(listener)

    def frames(self) -> Iterator[LogMessage]:
        """Raw messages of the log, time ordered and paced."""
        if self.speed is None or self.speed <= 0 or math.isinf(self.speed):
            return self.reader.messages(**self._filters)  # as fast as possible: no pacing layer
        return paced(self.reader.messages(**self._filters), self.speed, self._clock, self._sleep)

    def driver(self, msg: LogMessage) -> Driver | None:
        """The driver of ``msg``'s channel (None for a JSON channel or an unknown format)."""
        drv = self.drivers.get(msg.channel)
        if drv is not None:
            return drv
        if msg.format is None:
            return None
        if msg.channel in self.skipped:
            self.skipped[msg.channel] += 1
            return None
        try:
            formats.get(msg.format)
        except (AuvlinkError, ImportError):
            self.skipped[msg.channel] = 1
            return None
        device = self.reader.channels[msg.channel].device
        drv = Driver(device, msg.format, LogTransport(f"log://{self.path}#{msg.channel}"))
        for listener in self._listeners:
            drv.add_listener(listener)
        self.drivers[msg.channel] = drv
        return drv

    def samples(self) -> Iterator[Sample]:
        """Decoded samples, through each device's framer and codec, paced like :meth:`frames`."""
        # per channel: the bound feed and process of its driver (looked up once, not per frame)
        routes: dict[str, tuple[Callable[[bytes], list[bytes]], Callable[[list[bytes], int], list[Sample]]]] = {}
        last_t = self._last_t
        for msg in self.frames():
            route = routes.get(msg.channel)
            if route is None:
                drv = self.driver(msg)
                if drv is None:
                    continue
                route = routes[msg.channel] = (drv.framer.feed, drv.process)
            frames = route[0](msg.data)
            if frames:
                yield from route[1](frames, msg.log_time_ns)
            else:  # the framer waits for more bytes: its frame, if any, is stamped with this time
                last_t[msg.channel] = msg.log_time_ns
        for channel, drv in self.drivers.items():  # a framer that waits for more bytes
            rest = drv.framer.flush()
            if rest:
                yield from drv.process(rest, self._last_t.get(channel, 0))

    def __iter__(self) -> Iterator[Sample]:
        return self.samples()

    def stats(self) -> dict[str, dict[str, Any]]:
        """Per device: samples, decode errors and framer counters (as on live drivers)."""
        return {name: drv.describe() for name, drv in self.drivers.items()}

    def close(self) -> None:
        self.reader.close()

    def __enter__(self) -> Replay:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


def replay_frames(path: str | Path, speed: float | None = None, **filters: Any) -> Iterator[LogMessage]:
    """Raw frames of a log, paced (``speed=None``: as fast as possible)."""
    with Replay(path, speed=speed, **filters) as rep:
        yield from rep.frames()


def replay_samples(path: str | Path, speed: float | None = None, **filters: Any) -> Iterator[Sample]:
    """Decoded samples of a log through the live framers and codecs (see :class:`Replay`)."""
    with Replay(path, speed=speed, **filters) as rep:
        yield from rep.samples()
