"""Transport base class and the URL-scheme registry (after python-can's ``BusABC``).

URL forms (the scheme picks the backend module, imported only when used):

==================================  =======================================================
``/dev/ttyUSB0?baudrate=115200``    serial port through pyserial (any path: pty slaves too)
``serial:///dev/ttyS1?baudrate=9600``  the same, explicit
``loop://``, ``socket://h:p``,      any URL pyserial itself accepts (``rfc2217://``, ...)
``tcp://127.0.0.1:5000``            TCP client (sonar frames)
``tcp-listen://127.0.0.1:5000``     TCP server: accepts one client at a time
``can://virtual/chan0``             python-can bus: ``can://INTERFACE/CHANNEL?bitrate=..``
``pty:///tmp/auv/fog``              the instrument's end of a new pty (:mod:`auvlink.virtual_pty`)
==================================  =======================================================

The base class owns policy: open/close, the context manager, byte counters and timeouts.
A backend implements :meth:`_open`, :meth:`_close`, :meth:`_read` and :meth:`_write`.

Events: a backend notes what happened on its port that is not data (a TCP connection refused or
taken over, ...) with :meth:`Transport._note`; whoever reads the port drains them with
:meth:`Transport.take_events` and reports them (the live engine's port readers log them as port
events). At most :data:`MAX_EVENTS` wait; older ones are dropped and counted in ``events_dropped``.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections import deque
from types import TracebackType
from typing import Any, ClassVar, Self
from urllib.parse import parse_qsl, urlsplit

from auvlink.errors import TransportInitError, TransportOperationError

#: events a transport keeps until they are taken (a port nobody drains must not grow without bound)
MAX_EVENTS = 100

_SCHEMES: dict[str, str] = {
    "serial": "auvlink.transports.serial_port:SerialTransport",
    "loop": "auvlink.transports.serial_port:SerialTransport",
    "socket": "auvlink.transports.serial_port:SerialTransport",
    "rfc2217": "auvlink.transports.serial_port:SerialTransport",
    "spy": "auvlink.transports.serial_port:SerialTransport",
    "tcp": "auvlink.transports.tcp:TcpClientTransport",
    "tcp-listen": "auvlink.transports.tcp:TcpServerTransport",
    "can": "auvlink.transports.can_bus:CanTransport",
    "pty": "auvlink.virtual_pty:PtyTransport",
}


class Transport(ABC):
    """A byte pipe named by a URL. Not thread-safe for concurrent reads."""

    #: schemes this class serves (informational)
    schemes: ClassVar[tuple[str, ...]] = ()

    def __init__(self, url: str) -> None:
        self.url = url
        self.bytes_read = 0
        self.bytes_written = 0
        self._is_open = False
        self._events: deque[dict[str, Any]] = deque(maxlen=MAX_EVENTS)
        self.events_dropped = 0

    # -- events ---------------------------------------------------------------------------
    def _note(self, kind: str, **detail: Any) -> None:
        """Record a port event ``{"kind": kind, **detail}`` for :meth:`take_events`."""
        if len(self._events) == MAX_EVENTS:
            self.events_dropped += 1
        self._events.append({"kind": kind, **detail})

    def take_events(self) -> list[dict[str, Any]]:
        """The events noted since the last call, oldest first (each a dict with ``kind``)."""
        out = list(self._events)
        self._events.clear()
        return out

    # -- policy ---------------------------------------------------------------------------
    def open(self) -> Self:
        if not self._is_open:
            try:
                self._open()
            except TransportInitError:
                raise
            except Exception as exc:
                raise TransportInitError(f"cannot open {self.url}: {exc}") from exc
            self._is_open = True
        return self

    def close(self) -> None:
        if self._is_open:
            self._is_open = False
            self._close()

    @property
    def is_open(self) -> bool:
        return self._is_open

    def read(self, timeout: float | None = 0.1) -> bytes:
        """Bytes available within ``timeout`` s (may be ``b""``). Raises on a dead transport."""
        if not self._is_open:
            raise TransportOperationError(f"{self.url}: read on a closed transport")
        try:
            data = self._read(timeout)
        except TransportOperationError:
            raise
        except OSError as exc:
            raise TransportOperationError(f"{self.url}: read failed: {exc}") from exc
        self.bytes_read += len(data)
        return data

    def write(self, data: bytes) -> None:
        if not self._is_open:
            raise TransportOperationError(f"{self.url}: write on a closed transport")
        try:
            self._write(data)
        except TransportOperationError:
            raise
        except OSError as exc:
            raise TransportOperationError(f"{self.url}: write failed: {exc}") from exc
        self.bytes_written += len(data)

    def __enter__(self) -> Self:
        return self.open()

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.url!r}, open={self._is_open})"

    # -- backend --------------------------------------------------------------------------
    @abstractmethod
    def _open(self) -> None: ...

    @abstractmethod
    def _close(self) -> None: ...

    @abstractmethod
    def _read(self, timeout: float | None) -> bytes: ...

    @abstractmethod
    def _write(self, data: bytes) -> None: ...


def register_scheme(scheme: str, target: str) -> None:
    """Register ``"package.module:Class"`` as the backend of ``scheme://`` URLs."""
    _SCHEMES[scheme] = target


def url_query(url: str) -> dict[str, str]:
    """The ``?key=value&...`` part of a URL as a dict."""
    return dict(parse_qsl(urlsplit(url).query))


def transport_class(url: str) -> type[Transport]:
    scheme = urlsplit(url).scheme if "://" in url else "serial"
    target = _SCHEMES.get(scheme)
    if target is None:
        raise TransportInitError(
            f"unknown transport scheme {scheme!r} in {url!r}; known: {', '.join(sorted(_SCHEMES))}"
        )
    module_name, _, cls_name = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise TransportInitError(f"backend for {scheme!r} cannot be imported: {exc}") from exc
    cls: type[Transport] = getattr(module, cls_name)
    return cls


def open_transport(url: str) -> Transport:
    """Create and open the transport named by ``url``."""
    return transport_class(url)(url).open()
