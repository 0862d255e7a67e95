"""Supervised port readers: one thread per device, reopened with exponential backoff when it goes.

A :class:`PortReader` reads its :class:`~auvlink.driver.Driver` and hands each decoded sample to
``deliver`` (never blocking: the receiver drops what it cannot take). Before every read it
publishes a *watermark*, the host time before which every sample of this device has been handed
over (samples are stamped after the read returns), so a consumer knows when the devices together
are complete up to a time. A port that fails (closed, unplugged, the peer gone) is closed, reported
through ``on_event`` (``port_lost``), and reopened after a wait that grows: 0.1, 0.2, 0.4 ... up to
``backoff_max`` s, each drawn from ``[step/2, step]`` (:class:`~auvlink.transports.backoff.Backoff`:
jitter, a bounded rate), the step reset only by a connection that stayed up ``backoff_max`` s, so a
device that accepts and drops every connection at once is retried at most once per ``backoff_max / 2``
s (``port_reopened`` with the gap's length). A reader whose port is closed (waiting to reopen it, or
inside a slow ``open``) has nothing in hand, so it holds nobody up meanwhile:
:meth:`PortReader.holds_from` gives the consumer's own clock reading then. A port that stays open
but silent for ``silence_s`` (a stalled socket, a sensor that stopped talking) gives ``port_silent``,
and ``port_resumed`` when bytes come again. What the transport itself noted (a TCP connection
refused while the instrument is connected, a takeover, a client that connected or left) is passed
on as events of the same kind (:meth:`~auvlink.transports.base.Transport.take_events`). Errors are
never printed: they are events.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from auvlink.clock import now_ns
from auvlink.driver import Driver
from auvlink.errors import AuvlinkError, TransportError
from auvlink.records import Sample
from auvlink.transports.backoff import INITIAL_S, Backoff

EventSink = Callable[[dict[str, Any]], None]

#: the mission log's channel of port events (JSON; ``auvlink live`` and ``auvlink record`` write it)
EVENT_TOPIC = "events"
EVENT_SCHEMA_NAME = "auvlink.Event"
EVENT_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema", "title": EVENT_SCHEMA_NAME,
    "description": "A port event: lost or reopened (a gap), silent or resumed, a frame dropped, an error",
    "type": "object", "required": ["t_ns", "device", "kind"],
    "properties": {"t_ns": {"type": "integer"}, "device": {"type": "string"}, "kind": {"type": "string"}},
}


class PortReader:
    """Reads one driver on its own thread until ``stop`` is set (see the module docstring)."""

    def __init__(self, driver: Driver, deliver: Callable[[Sample], None], stop: threading.Event, *,
                 on_event: EventSink | None = None, read_timeout: float = 0.05, backoff_initial: float = INITIAL_S,
                 backoff_max: float = 5.0, opened: bool = False, silence_s: float = 1.0) -> None:
        self.driver = driver
        self.deliver = deliver
        self.stop = stop
        self.on_event = on_event
        self.read_timeout = read_timeout
        self.backoff = Backoff(backoff_initial, backoff_max)
        self.watermark_ns = now_ns()
        self.is_open = opened
        self._idle = not opened  # port closed: nothing in hand, no sample before its next open returns
        self.reopens = 0
        self.failures = 0
        self.gaps: list[tuple[int, int]] = []  # (lost at, reopened at) host ns
        self.fatal = ""
        self.silence_s = silence_s
        self.silences = 0
        self.thread = threading.Thread(target=self._run, name=f"auvlink-port-{driver.name}")

    def start(self) -> PortReader:
        self.thread.start()
        return self

    def join(self, timeout: float | None = None) -> None:
        self.thread.join(timeout)

    def _event(self, kind: str, **detail: Any) -> None:
        if self.on_event is not None:
            self.on_event({"t_ns": now_ns(), "device": self.driver.name, "kind": kind, **detail})

    def _wait(self) -> None:
        """Idle until the next reopening attempt (the backoff's next wait) or ``stop``."""
        self.watermark_ns = now_ns()
        self.stop.wait(self.backoff.next_wait())

    def _run(self) -> None:
        lost_at: int | None = None
        opened_at = time.monotonic()
        last_data, last_bytes = now_ns(), -1
        silent = False
        try:
            while not self.stop.is_set():
                if not self.is_open:
                    self.watermark_ns = now_ns()
                    try:
                        self.driver.open()  # a fresh byte stream: bytes before the gap belong to no frame
                    except TransportError as exc:
                        if lost_at is None:  # never opened: a start-up failure is a gap too
                            lost_at = now_ns()
                            self._event("open_failed", error=str(exc))
                        self._wait()
                        continue
                    self.watermark_ns = now_ns()  # before leaving idle: samples come after this
                    self._idle = False
                    self.is_open = True
                    opened_at = time.monotonic()
                    last_data, silent = now_ns(), False
                    if lost_at is not None:
                        back = now_ns()
                        self.gaps.append((lost_at, back))
                        self.reopens += 1
                        self._event("port_reopened", gap_s=round((back - lost_at) * 1e-9, 3))
                        lost_at = None
                self.watermark_ns = now_ns()
                try:
                    samples = self.driver.read(self.read_timeout)
                except TransportError as exc:
                    self._transport_events()
                    self.failures += 1
                    lost_at = now_ns()
                    self._event("port_lost", error=str(exc))
                    self._close()
                    self.backoff.connection_lasted(time.monotonic() - opened_at)
                    self._wait()  # even when the device takes the next connection at once
                    continue
                self._transport_events()
                t, got = now_ns(), self.driver.transport.bytes_read
                if got != last_bytes:
                    if silent:
                        self._event("port_resumed", silent_s=round((t - last_data) * 1e-9, 3))
                        silent = False
                    last_data, last_bytes = t, got
                elif not silent and t - last_data > self.silence_s * 1e9:
                    silent = True
                    self.silences += 1
                    self._event("port_silent", silent_s=round((t - last_data) * 1e-9, 3))
                for s in samples:
                    self.deliver(s)
        except AuvlinkError as exc:  # e.g. the log writer failed inside a raw listener
            self.fatal = str(exc)
            self._event("reader_stopped", error=str(exc))
        finally:
            self._close()
            self.watermark_ns = 2**63 - 1  # a stopped reader holds nobody up

    def _transport_events(self) -> None:
        """Pass on what the transport noted since the last read (each as a port event)."""
        for ev in self.driver.transport.take_events():
            kind = str(ev.pop("kind", "transport_event"))
            self._event(kind, **ev)

    def holds_from(self, now: int) -> int:
        """The time before which this device has handed everything over, for a consumer who read the clock
        (``now``, ns) just before asking. While the port is closed (backoff, a slow open) nothing is in
        hand and the next sample is stamped after the open returns, so ``now`` is safe; otherwise the
        watermark published before the current read."""
        wm = self.watermark_ns
        return max(wm, now) if self._idle else wm

    def _close(self) -> None:
        self._idle = True  # (the failed read delivered nothing; the samples before it are handed over)
        if self.is_open:
            self.is_open = False
            try:
                self.driver.close()
            except Exception as exc:  # a backend failing to close a dead port (python-can: CanOperationError)
                self._event("close_failed", error=f"{type(exc).__name__}: {exc}")

    def describe(self) -> dict[str, Any]:
        return {**self.driver.describe(), "reopens": self.reopens, "port_failures": self.failures,
                "gaps_s": [round((b - a) * 1e-9, 3) for a, b in self.gaps], "silences": self.silences,
                "fatal": self.fatal}
