"""CAN transport over python-can: ``can://INTERFACE/CHANNEL?key=value&...``.

Everything after the interface name and its slash is the channel, verbatim, so serial-backed
adapters keep their paths:

=================================================  ============================================
``can://virtual/nav0``                             python-can's in-process virtual bus
``can://socketcan/can0``, ``can://socketcan/vcan0``  Linux SocketCAN (needs the kernel module)
``can://slcan//dev/ttyACM0?bitrate=500000``        a USB-CAN adapter speaking slcan (Lawicel)
``can://slcan//dev/pts/3?bitrate=500000&sleep_after_open=0``  the same on a pty (see
                                                   :class:`auvlink.virtual_slcan.SlcanAdapter`)
=================================================  ============================================

For serial-backed interfaces (``slcan``, ``serial``, ``robotell``, ``seeedstudio``) a channel
written without its leading slash (``can://slcan/dev/ttyACM0``) means ``/dev/ttyACM0``.
Query values become keyword arguments of ``can.Bus`` (numbers and ``true``/``false`` converted),
so any option of the interface can be given (``bitrate``, ``receive_own_messages``,
``tty_baudrate``, ``sleep_after_open``, ...). python-can's slcan interface waits 2 s after opening
the port (for adapters that reset on open) unless ``sleep_after_open=0``.

A received message that a raw frame cannot carry (a CAN FD payload over 8 bytes) is skipped and
counted in :attr:`CanTransport.messages_skipped`; the reason of the last one is in ``last_skip``.

A CAN bus carries messages, not bytes: the transport turns each received ``can.Message`` into
one fixed-size raw frame (:func:`auvlink.framing.can_frames.message_to_frame`) so the driver,
framer and mission log see a byte stream like every other device; :meth:`CanTransport.write`
cuts such frames back into messages (:func:`~auvlink.framing.can_frames.frame_to_message`).
"""

from __future__ import annotations

from typing import Any, ClassVar

from auvlink.errors import EncodeError, TransportInitError, TransportOperationError
from auvlink.framing.can_frames import FRAME_SIZE, frame_to_message, message_to_frame
from auvlink.transports.base import Transport, url_query


def _can() -> Any:
    """The python-can module, imported when a bus is used (lazy: python-can and its asyncio load with the first
    bus, not with every configuration that parses a ``can://`` URL)."""
    import can  # lazy: python-can is heavy (asyncio, its io plugins) and only a CAN bus needs it

    return can

#: messages drained per read after the first one arrived (bounds one read's latency)
MAX_BATCH = 512
_SERIAL_BACKED = ("slcan", "serial", "robotell", "seeedstudio")
#: query keys that are rates in bit/s (python-can ignores some of them on some interfaces: check here)
_RATE_KEYS = ("bitrate", "data_bitrate", "tty_baudrate")
_WORDS = {"true": True, "yes": True, "on": True, "false": False, "no": False, "off": False,
          "none": None}


def _value(text: str) -> Any:
    """A query value as a Python value: int, float, bool, None or the string itself."""
    if text.lower() in _WORDS:
        return _WORDS[text.lower()]
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parse_can_url(url: str) -> tuple[str, str | None, dict[str, Any]]:
    """``(interface, channel, bus keyword arguments)`` of a ``can://`` URL.

    >>> parse_can_url("can://slcan//dev/pts/3?bitrate=500000")
    ('slcan', '/dev/pts/3', {'bitrate': 500000})
    """
    if not url.startswith("can://"):
        raise TransportInitError(f"not a CAN URL: {url!r} (expected can://INTERFACE/CHANNEL)")
    body = url[len("can://"):].partition("?")[0]
    interface, _, channel = body.partition("/")
    if not interface:
        raise TransportInitError(f"no interface in {url!r} (expected can://INTERFACE/CHANNEL)")
    if interface in _SERIAL_BACKED and channel.startswith("dev/"):
        channel = "/" + channel
    kwargs = {key: _value(text) for key, text in url_query(url).items()}
    for key in _RATE_KEYS:
        rate = kwargs.get(key)
        if key in kwargs and (isinstance(rate, bool) or not isinstance(rate, int) or rate <= 0):
            raise TransportInitError(f"URL key {key!r} in {url!r}: expected a positive integer (bit/s), "
                                     f"got {url_query(url)[key]!r}")
    return interface, channel or None, kwargs


class CanTransport(Transport):
    """A python-can bus seen as a stream of fixed-size raw CAN frames."""

    schemes: ClassVar[tuple[str, ...]] = ("can",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.interface, self.channel, self.options = parse_can_url(url)
        self._bus: Any = None  # can.BusABC, imported lazily
        self._pending = bytearray()  # a partial frame from the last write
        self.messages_read = 0
        self.messages_written = 0
        self.messages_skipped = 0  # received but not representable as a raw frame
        self.last_skip = ""

    @property
    def bus(self) -> Any:
        """The open ``can.BusABC`` (for filters, periodic sends, state)."""
        if self._bus is None:
            raise TransportOperationError(f"{self.url}: bus not open")
        return self._bus

    def _open(self) -> None:
        can = _can()
        try:
            self._bus = can.Bus(interface=self.interface, channel=self.channel, **self.options)
        except (can.CanError, OSError, ValueError, ImportError, NotImplementedError) as exc:
            raise TransportInitError(
                f"cannot open CAN interface {self.interface!r} channel {self.channel!r}: {exc}"
            ) from exc
        self._pending.clear()

    def _close(self) -> None:
        bus, self._bus = self._bus, None
        if bus is not None:
            bus.shutdown()

    def _read(self, timeout: float | None) -> bytes:
        can = _can()
        bus = self.bus
        frames: list[bytes] = []
        try:
            msg = bus.recv(timeout)
            while msg is not None:
                try:
                    frames.append(message_to_frame(msg))
                except EncodeError as exc:  # e.g. a CAN FD payload over 8 bytes: skip, count
                    self.messages_skipped += 1
                    self.last_skip = str(exc)
                if len(frames) >= MAX_BATCH:
                    break
                msg = bus.recv(0)
        except can.CanOperationError as exc:
            if not frames:
                raise TransportOperationError(f"{self.url}: receive failed: {exc}") from exc
        self.messages_read += len(frames)
        return b"".join(frames)

    def _write(self, data: bytes) -> None:
        can = _can()
        self._pending += data
        whole = len(self._pending) - len(self._pending) % FRAME_SIZE
        chunk = bytes(self._pending[:whole])
        del self._pending[:whole]
        for start in range(0, whole, FRAME_SIZE):
            msg = frame_to_message(chunk[start:start + FRAME_SIZE])
            try:
                self.bus.send(msg)
            except can.CanError as exc:
                raise TransportOperationError(f"{self.url}: send failed: {exc}") from exc
            self.messages_written += 1

    def send(self, msg: Any, timeout: float | None = None) -> None:
        """Send one ``can.Message`` directly (the byte-stream :meth:`write` is the usual path)."""
        can = _can()
        try:
            self.bus.send(msg, timeout)
        except can.CanError as exc:
            raise TransportOperationError(f"{self.url}: send failed: {exc}") from exc
        self.messages_written += 1
