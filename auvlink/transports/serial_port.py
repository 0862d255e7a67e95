"""Serial transport over pyserial: real ports, pty slaves, and every URL pyserial accepts.

URL forms (see pyserial's "URL handlers" documentation, https://pyserial.readthedocs.io/en/latest/url_handlers.html):

=========================================  ===================================================
``/dev/ttyUSB0?baudrate=115200``           a device path (also a pty slave such as /dev/pts/3)
``serial:///dev/ttyS1?baudrate=9600``      the same, explicit (the scheme is stripped)
``loop://``                                pyserial's loop-back (small tests only: 1 byte/put)
``socket://127.0.0.1:4001``                raw TCP through pyserial (a serial server)
``rfc2217://host:port``, ``spy://...``     any other pyserial URL handler
=========================================  ===================================================

Port settings ride in the query: ``baudrate``, ``bytesize`` (5-8), ``parity`` (N E O M S),
``stopbits`` (1, 1.5, 2), ``xonxoff``, ``rtscts``, ``dsrdtr``, ``exclusive`` (0/1, true/false),
``write_timeout`` (s; a write that cannot finish in time raises
:class:`~auvlink.errors.TransportTimeoutError`) and ``timeout`` (s; an alias of ``write_timeout``
kept for pyserial habits: reads are bounded per call by ``read(timeout)``). Other query keys
(``logging=debug``, ``ign_set_control``) are left in the URL for pyserial's own handler.
"""

from __future__ import annotations

import io
import os
import select
from typing import Any, ClassVar

import serial

from auvlink.errors import TransportInitError, TransportOperationError, TransportTimeoutError
from auvlink.transports.base import Transport, url_query

#: the largest chunk one read returns (a pty holds about 4 KiB, a socket buffer more)
READ_CHUNK = 1 << 16

_BOOL = {"1": True, "true": True, "yes": True, "on": True, "0": False, "false": False, "no": False,
         "off": False}
_PARITY = {"N": serial.PARITY_NONE, "E": serial.PARITY_EVEN, "O": serial.PARITY_ODD,
           "M": serial.PARITY_MARK, "S": serial.PARITY_SPACE}
_STOPBITS = {"1": serial.STOPBITS_ONE, "1.5": serial.STOPBITS_ONE_POINT_FIVE, "2": serial.STOPBITS_TWO}
_KEYS = ("baudrate", "bytesize", "parity", "stopbits", "xonxoff", "rtscts", "dsrdtr", "exclusive",
         "timeout", "write_timeout")
#: query keys pyserial's own URL handlers read (serial/urlhandler/protocol_*.py)
HANDLER_KEYS: dict[str, tuple[str, ...]] = {
    "loop": ("logging",), "socket": ("logging",), "rfc2217": ("ign_set_control", "logging", "poll_modem", "timeout"),
    "spy": ("all", "color", "file", "raw"), "hwgrep": ("n", "skip_busy"), "alt": ("class",),
}


def _setting(key: str, value: str) -> Any:
    """One query value converted to what ``serial.Serial`` expects."""
    try:
        if key == "baudrate":
            return int(value)
        if key == "bytesize":
            size = int(value)
            if size not in (5, 6, 7, 8):
                raise ValueError("bytesize must be 5, 6, 7 or 8")
            return size
        if key == "parity":
            return _PARITY[value.upper()[:1]]
        if key == "stopbits":
            return _STOPBITS[value]
        if key in ("timeout", "write_timeout"):
            return None if value.lower() in ("", "none") else float(value)
        return _BOOL[value.lower()]
    except (KeyError, ValueError, IndexError) as exc:
        raise TransportInitError(f"bad serial setting {key}={value!r}: {exc}") from exc


def parse_serial_url(url: str) -> tuple[str, dict[str, Any]]:
    """Split ``url`` into what to give ``serial.serial_for_url`` and the port keyword arguments.

    >>> parse_serial_url("serial:///dev/ttyS1?baudrate=9600&parity=E")
    ('/dev/ttyS1', {'baudrate': 9600, 'parity': 'E'})
    >>> parse_serial_url("socket://127.0.0.1:4001?logging=debug&baudrate=115200")
    ('socket://127.0.0.1:4001?logging=debug', {'baudrate': 115200})
    """
    base, _, query = url.partition("?")
    ours = url_query(url)
    kwargs = {key: _setting(key, ours[key]) for key in _KEYS if key in ours}
    if "timeout" in kwargs:
        kwargs.setdefault("write_timeout", kwargs["timeout"])
        del kwargs["timeout"]
    rest = [item for item in query.split("&") if item and item.partition("=")[0] not in _KEYS]
    scheme = base.partition("://")[0] if "://" in base else "serial"
    handler = HANDLER_KEYS.get(scheme, ()) if scheme != "serial" else ()
    for item in rest:
        key = item.partition("=")[0]
        if key not in handler and (scheme == "serial" or scheme in HANDLER_KEYS):
            raise TransportInitError(f"unknown URL key {key!r} in {url!r} (allowed for {scheme}: "
                                     f"{', '.join(sorted(_KEYS + handler))})")
    if "://" not in base or base.startswith("serial://"):
        path = base.removeprefix("serial://")
        if not path:
            raise TransportInitError(f"no device path in {url!r}")
        return path, kwargs
    return (base + "?" + "&".join(rest)) if rest else base, kwargs


class SerialTransport(Transport):
    """A pyserial port named by a device path or a pyserial URL."""

    schemes: ClassVar[tuple[str, ...]] = ("serial", "loop", "socket", "rfc2217", "spy")

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.port_url, self.settings = parse_serial_url(url)
        self._port: serial.SerialBase | None = None
        self._fd: int | None = None
        self._direct = False  # a plain POSIX port: os.read on its descriptor (2x faster than pyserial's read)
        self._timeout: float | None = -1.0  # the timeout last given to the port (-1: none yet)

    @property
    def port(self) -> serial.SerialBase:
        """The open pyserial port (for modem lines, break, baud-rate changes)."""
        if self._port is None:
            raise TransportOperationError(f"{self.url}: port not open")
        return self._port

    def _open(self) -> None:
        try:
            port = serial.serial_for_url(self.port_url, **self.settings)
        except (serial.SerialException, ValueError) as exc:
            raise TransportInitError(f"cannot open serial port {self.url!r}: {exc}") from exc
        try:
            self._fd = port.fileno()
        except (AttributeError, OSError, ValueError, NotImplementedError):
            self._fd = None  # loop://, rfc2217://: poll through pyserial's own timeout instead
        if self._fd is not None:
            port.timeout = 0  # we select() on the descriptor; pyserial then reads without blocking
        self._direct = self._fd is not None and type(port).read is serial.Serial.read
        self._timeout = 0.0 if self._fd is not None else -1.0
        self._port = port

    def _close(self) -> None:
        port, self._port, self._fd = self._port, None, None
        if port is not None:
            port.close()

    def _read(self, timeout: float | None) -> bytes:
        port = self.port
        data: bytes
        if self._fd is not None:
            ready, _, _ = select.select([self._fd], [], [], timeout)
            if not ready:
                return b""
            if not self._direct:
                return bytes(port.read(READ_CHUNK))
            try:
                data = os.read(self._fd, READ_CHUNK)
            except BlockingIOError:
                return b""
            if not data:
                raise TransportOperationError(f"{self.url}: device readable but returned no data (gone?)")
            return data
        if timeout != self._timeout:
            port.timeout = timeout
            self._timeout = timeout
        waiting = port.in_waiting
        data = port.read(waiting if waiting else 1)
        if data and not waiting:
            more = port.in_waiting
            if more:
                data += port.read(more)
        return data

    def _write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except serial.SerialTimeoutException as exc:
            raise TransportTimeoutError(
                f"{self.url}: write of {len(data)} bytes did not finish within "
                f"{self.port.write_timeout} s"
            ) from exc

    def flush(self) -> None:
        """Wait until everything written has left the port."""
        try:
            self.port.flush()
        except io.UnsupportedOperation:  # some URL handlers cannot
            pass
