"""TCP transports: a client (``tcp://host:port``) and a one-client server (``tcp-listen://host:port``).

Imaging sonars (DIDSON / ARIS class) stream frames over TCP; the simulator plays the sonar with
the server end. Both ends set ``TCP_NODELAY`` (frames leave at once) and wait with ``select`` so
``read(timeout)`` returns within ``timeout``.

Client query keys: ``timeout`` (connect timeout, s, default 5), ``reconnect`` (0/1, default 0:
when 1, a dropped connection is retried inside later reads, which return ``b""`` meanwhile,
instead of raising :class:`~auvlink.errors.TransportOperationError`).

Server: binds at open (port 0 picks a free port, see :attr:`TcpServerTransport.address`) and
serves one client at a time; a newer client replaces the current one (a client that reconnected
after a network fault is not locked out by its own half-dead connection). ``read`` returns
``b""`` while no client is connected, and ``write`` discards (and counts) bytes nobody receives.
"""

from __future__ import annotations

import contextlib
import select
import socket
import time
from typing import ClassVar
from urllib.parse import urlsplit

from auvlink.errors import TransportInitError, TransportOperationError
from auvlink.transports.base import Transport, url_query

READ_CHUNK = 1 << 16
_TRUE = ("1", "true", "yes", "on")


def parse_address(url: str) -> tuple[str, int]:
    """``(host, port)`` of ``tcp://host:port`` or ``tcp-listen://host:port`` (IPv6 as ``[::1]``)."""
    try:
        parts = urlsplit(url)
        host, port = parts.hostname, parts.port
    except ValueError as exc:
        raise TransportInitError(f"bad TCP address in {url!r}: {exc}") from exc
    if port is None:
        raise TransportInitError(f"no port in {url!r} (expected {parts.scheme}://HOST:PORT)")
    return host or "0.0.0.0", port


def _tune(sock: socket.socket) -> socket.socket:
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


class TcpClientTransport(Transport):
    """Connects to a TCP server (a sonar, a serial server, the simulator)."""

    schemes: ClassVar[tuple[str, ...]] = ("tcp",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.address = parse_address(url)
        query = url_query(url)
        try:
            self.connect_timeout = float(query.get("timeout", "5"))
        except ValueError as exc:
            raise TransportInitError(f"bad timeout in {url!r}") from exc
        self.auto_reconnect = query.get("reconnect", "0").lower() in _TRUE
        self.reconnects = 0
        self._sock: socket.socket | None = None

    def _connect(self, timeout: float) -> socket.socket:
        sock = socket.create_connection(self.address, timeout=timeout)
        sock.settimeout(None)
        return _tune(sock)

    def _open(self) -> None:
        try:
            self._sock = self._connect(self.connect_timeout)
        except OSError as exc:
            raise TransportInitError(
                f"cannot connect to {self.address[0]}:{self.address[1]} within "
                f"{self.connect_timeout} s: {exc}"
            ) from exc

    def _close(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()

    def reconnect(self, attempts: int = 3, delay: float = 0.5) -> None:
        """Close and connect again, ``attempts`` times ``delay`` s apart; raise if all fail."""
        self._close()
        error: OSError | None = None
        for attempt in range(attempts):
            if attempt:
                time.sleep(delay)
            try:
                self._sock = self._connect(self.connect_timeout)
            except OSError as exc:
                error = exc
                continue
            self._is_open = True
            self.reconnects += 1
            return
        raise TransportOperationError(
            f"{self.url}: reconnect failed after {attempts} attempts: {error}"
        ) from error

    def _retry(self, timeout: float | None) -> None:
        start = time.monotonic()
        budget = self.connect_timeout if timeout is None else max(timeout, 1e-3)
        try:
            self._sock = self._connect(budget)
            self.reconnects += 1
        except OSError:
            time.sleep(max(0.0, budget - (time.monotonic() - start)))  # refused at once: don't spin

    def _read(self, timeout: float | None) -> bytes:
        if self._sock is None:
            if not self.auto_reconnect:
                raise TransportOperationError(f"{self.url}: not connected")
            self._retry(timeout)
            return b""
        ready, _, _ = select.select([self._sock], [], [], timeout)
        if not ready:
            return b""
        error: OSError | None = None
        try:
            data = self._sock.recv(READ_CHUNK)
        except OSError as exc:
            data, error = b"", exc
        if data:
            return data
        self._close()
        self._is_open = True  # the transport stays open; only the connection went
        if self.auto_reconnect:
            return b""
        raise TransportOperationError(f"{self.url}: connection closed by the peer") from error

    def _write(self, data: bytes) -> None:
        if self._sock is None:
            raise TransportOperationError(f"{self.url}: not connected")
        self._sock.sendall(data)


class TcpServerTransport(Transport):
    """Listens on ``host:port`` and exchanges bytes with one client at a time."""

    schemes: ClassVar[tuple[str, ...]] = ("tcp-listen",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self._bind = parse_address(url)
        self._listener: socket.socket | None = None
        self._client: socket.socket | None = None
        self.clients = 0  # connections accepted so far
        self.bytes_discarded = 0  # written while no client was connected

    @property
    def address(self) -> tuple[str, int]:
        """The bound ``(host, port)`` (the real port when the URL said 0)."""
        if self._listener is None:
            return self._bind
        host, port = self._listener.getsockname()[:2]
        return str(host), int(port)

    @property
    def connected(self) -> bool:
        return self._client is not None

    def _open(self) -> None:
        family = socket.AF_INET6 if ":" in self._bind[0] else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_STREAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind(self._bind)
            sock.listen(2)
        except OSError as exc:
            sock.close()
            raise TransportInitError(f"cannot listen on {self._bind[0]}:{self._bind[1]}: {exc}") from exc
        self._listener = sock

    def _close(self) -> None:
        self._drop_client()
        listener, self._listener = self._listener, None
        if listener is not None:
            listener.close()

    def _drop_client(self) -> None:
        client, self._client = self._client, None
        if client is not None:
            with contextlib.suppress(OSError):
                client.shutdown(socket.SHUT_RDWR)
            client.close()

    def _accept(self) -> None:
        assert self._listener is not None
        client, _ = self._listener.accept()
        self._drop_client()
        self._client = _tune(client)
        self.clients += 1

    def wait_for_client(self, timeout: float | None = None) -> bool:
        """Block until a client is connected (True) or ``timeout`` s passed (False).

        A client waiting to connect is accepted even when one is connected (it replaces it).
        """
        if self._listener is None:
            raise TransportOperationError(f"{self.url}: not listening")
        ready, _, _ = select.select([self._listener], [], [], 0 if self._client else timeout)
        if ready:
            self._accept()
        return self._client is not None

    def _read(self, timeout: float | None) -> bytes:
        assert self._listener is not None
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            waiting = [self._listener] if self._client is None else [self._listener, self._client]
            ready, _, _ = select.select(waiting, [], [], left)
            if self._listener in ready:
                self._accept()
            elif self._client is not None and self._client in ready:
                try:
                    data = self._client.recv(READ_CHUNK)
                except OSError:
                    data = b""
                if data:
                    return data
                self._drop_client()  # the client left: wait for the next one
            if deadline is not None and time.monotonic() >= deadline:
                return b""

    def _write(self, data: bytes) -> None:
        self.wait_for_client(0)  # a write-only server (a sonar) must still see newer clients
        if self._client is None:
            self.bytes_discarded += len(data)
            return
        try:
            self._client.sendall(data)
        except OSError:  # the client went away mid-write; the next one gets the next frame
            self._drop_client()
            self.bytes_discarded += len(data)
