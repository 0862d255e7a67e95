"""Replay a mission log: a timed iterator over its raw frames, fed through the live path.

Each device channel gets a :class:`~auvlink.decoder.Decoder`, the byte decoder of a live driver
without its transport: every message's bytes go through that decoder's framer and codec exactly as
bytes from a port would (``decoder.feed(msg.data, msg.log_time_ns)``), so replay and live produce
the same :class:`~auvlink.records.Sample` objects, with ``t_host_ns`` = the recorded receive time.
``formats`` names the wire formats a consumer takes (the pipeline: those its stages consume); the
messages of other channels are counted (:attr:`Replay.not_decoded`) but neither framed nor decoded.
Pacing: ``speed=None`` as fast as possible, ``1.0`` real time, ``N`` N times real time (an absolute
schedule, so sleeping errors do not accumulate). The order of frames is the reader's time-ordered
merge: the same log always replays the same sequence.

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

from auvlink import formats as wire_formats
from auvlink.decoder import Decoder
from auvlink.errors import AuvlinkError
from auvlink.records import Sample
from logs_format.chunks import LogMessage
from logs_format.reader import MissionLogReader
from logs_format.scan import LossReport

SampleListener = Callable[[Sample], None]


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
    """A log opened for replay (a context manager). Decoders are made per channel on first use.

    ``formats``: decode only the channels of these wire formats (None: every channel).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        speed: float | None = None,
        channels: Iterable[str] | None = None,
        start_ns: int | None = None,
        end_ns: int | None = None,
        formats: Iterable[str] | None = None,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self.path = Path(path)
        self.speed = speed
        self.reader = MissionLogReader(self.path)
        self._filters: dict[str, Any] = {"channels": channels, "start_ns": start_ns, "end_ns": end_ns}
        self.formats = None if formats is None else frozenset(formats)
        self._clock, self._sleep = clock, sleep
        self.decoders: dict[str, Decoder] = {}  # channel -> its decoder
        self.skipped: dict[str, int] = {}  # channel -> frames of a format this install cannot decode
        self.not_decoded: dict[str, int] = {}  # channel -> frames of a format outside ``formats``
        self._listeners: list[SampleListener] = []

    @property
    def loss(self) -> LossReport:
        return self.reader.loss

    def add_listener(self, listener: SampleListener) -> None:
        """Call ``listener(sample)`` for every decoded sample of every device (as on live drivers)."""
        self._listeners.append(listener)

    def frames(self) -> Iterator[LogMessage]:
        """Raw messages of the log, time ordered and paced."""
        if self.speed is None or self.speed <= 0 or math.isinf(self.speed):
            return self.reader.messages(**self._filters)  # as fast as possible: no pacing layer
        return paced(self.reader.messages(**self._filters), self.speed, self._clock, self._sleep)

    def decoder(self, msg: LogMessage) -> Decoder | None:
        """The decoder of ``msg``'s channel (None for a JSON channel, an unknown format, or a format
        outside ``formats``; the last two are counted in :attr:`skipped` and :attr:`not_decoded`)."""
        dec = self.decoders.get(msg.channel)
        if dec is not None:
            return dec
        if msg.format is None:
            return None
        for counts in (self.skipped, self.not_decoded):
            if msg.channel in counts:
                counts[msg.channel] += 1
                return None
        if self.formats is not None and msg.format not in self.formats:
            self.not_decoded[msg.channel] = 1
            return None
        try:
            wire = wire_formats.get(msg.format)
        except (AuvlinkError, ImportError):
            self.skipped[msg.channel] = 1
            return None
        dec = self.decoders[msg.channel] = Decoder(self.reader.channels[msg.channel].device, wire)
        return dec

    def samples(self) -> Iterator[Sample]:
        """Decoded samples, through each device's framer and codec, paced like :meth:`frames`."""
        feeds: dict[str, Callable[[bytes, int], list[Sample]]] = {}  # per channel: its decoder's feed
        ignored: set[str] = set()  # channels without a decoder (JSON, unknown format, not in ``formats``)
        last_t: dict[str, int] = {}  # per channel: time of the last message that completed no frame
        listeners = self._listeners
        for msg in self.frames():
            channel = msg.channel
            feed = feeds.get(channel)
            if feed is None:
                if channel in ignored:
                    if msg.format is not None:
                        self.decoder(msg)  # counts it
                    continue
                dec = self.decoder(msg)
                if dec is None:
                    ignored.add(channel)
                    continue
                feed = feeds[channel] = dec.feed
            out = feed(msg.data, msg.log_time_ns)
            if not out:  # the framer waits for more bytes: its frame, if any, is stamped with this time
                last_t[channel] = msg.log_time_ns
                continue
            for sample in out:
                for listener in listeners:
                    listener(sample)
            yield from out
        for channel, dec in self.decoders.items():  # a framer that waits for more bytes
            rest = dec.flush(last_t.get(channel, 0))
            for sample in rest:
                for listener in listeners:
                    listener(sample)
            yield from rest

    def __iter__(self) -> Iterator[Sample]:
        return self.samples()

    def stats(self) -> dict[str, dict[str, Any]]:
        """Per device: samples, decode errors and framer counters (as on live drivers); with ``formats``,
        ``not_decoded`` = the frames of a channel no consumer takes (0 for the decoded ones)."""
        out = {dec.name: dec.describe() for dec in self.decoders.values()}
        if self.formats is not None:
            for info in out.values():
                info["not_decoded"] = 0
            for channel, n in self.not_decoded.items():
                ch = self.reader.channels[channel]
                out[ch.device] = {"name": ch.device, "format": ch.format, "samples": 0, "decode_errors": 0,
                                  "not_decoded": n}
        return out

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
