"""TCP transports: a client (``tcp://host:port``) and a one-client server (``tcp-listen://host:port``).

Imaging sonars (DIDSON / ARIS class) stream frames over TCP; the simulator plays the sonar with
the server end. Both ends set ``TCP_NODELAY`` (frames leave at once) and wait with ``select`` so
``read(timeout)`` returns within ``timeout``.

A URL always names its host: an empty host (``tcp-listen://:5000``) is an error, because a
server would listen on every interface without anyone having said so. Write
``tcp-listen://0.0.0.0:PORT`` to mean every interface, ``tcp-listen://127.0.0.1:PORT`` for this
machine only. An unknown query key is an error naming the keys allowed.

Client query keys: ``timeout`` (connect timeout, s, default 5), ``reconnect`` (0/1, default 0:
when 1, a dropped connection is retried inside later reads, which return ``b""`` meanwhile,
instead of raising :class:`~auvlink.errors.TransportOperationError`). Retries wait as
:class:`~auvlink.transports.backoff.Backoff` says (0.1 s doubling to 5 s, jittered, reset by a
connection that stayed up 5 s), so a server that accepts and closes at once is not hammered.

Server: binds at open (port 0 picks a free port, see :attr:`TcpServerTransport.address`) and
serves one client, the instrument. A second connection while that client is live is refused
(closed at once) and noted as a ``connection_refused`` port event (see
:meth:`~auvlink.transports.base.Transport.take_events`), so no other peer can slip its bytes in
under the instrument's name. A client whose connection is dead is replaced by the next one: one that
closed is seen at once (a zero-byte peek), one that vanished (power loss, cable) by TCP keepalive
within about half a minute. Query key ``takeover`` (0/1, default 0): when 1, a newer client replaces
the current one (``connection_taken_over`` event). ``client_connected`` and ``client_left`` are
noted too. ``read`` returns ``b""`` while no client is connected, and ``write`` discards (and
counts) bytes nobody receives.
"""

from __future__ import annotations

import contextlib
import select
import socket
import struct
import time
from typing import ClassVar
from urllib.parse import urlsplit

from auvlink.errors import TransportInitError, TransportOperationError
from auvlink.transports.backoff import Backoff
from auvlink.transports.base import Transport, url_query

READ_CHUNK = 1 << 16
_TRUE = ("1", "true", "yes", "on")


#: keepalive of a served client: probes after 10 s of silence, 5 s apart, 3 unanswered = dead
KEEPALIVE = (("TCP_KEEPIDLE", 10), ("TCP_KEEPINTVL", 5), ("TCP_KEEPCNT", 3))


def parse_address(url: str) -> tuple[str, int]:
    """``(host, port)`` of ``tcp://host:port`` or ``tcp-listen://host:port`` (IPv6 as ``[::1]``).

    An empty host is an error (a server would listen on every interface unasked)."""
    try:
        parts = urlsplit(url)
        host, port = parts.hostname, parts.port
    except ValueError as exc:
        raise TransportInitError(f"bad TCP address in {url!r}: {exc}") from exc
    scheme = parts.scheme or "tcp"
    if port is None:
        raise TransportInitError(f"no port in {url!r} (expected {scheme}://HOST:PORT)")
    if not host:
        raise TransportInitError(
            f"no host in {url!r}: write {scheme}://127.0.0.1:{port} for this machine only, or "
            f"{scheme}://0.0.0.0:{port} to mean every interface"
        )
    return host, port


def _options(url: str, allowed: tuple[str, ...]) -> dict[str, str]:
    """The URL's query keys; :class:`TransportInitError` naming an unknown key and the allowed ones."""
    query = url_query(url)
    for key in query:
        if key not in allowed:
            raise TransportInitError(f"unknown option {key!r} in {url!r}; allowed: {', '.join(allowed)}")
    return query


def _flag(url: str, query: dict[str, str], key: str) -> bool:
    value = query.get(key, "0").lower()
    if value not in (*_TRUE, "0", "false", "no", "off"):
        raise TransportInitError(f"option {key!r} in {url!r} must be 0 or 1, not {value!r}")
    return value in _TRUE


def _peer(addr: object) -> str:
    """``host:port`` of a socket address tuple."""
    if isinstance(addr, tuple) and len(addr) >= 2:
        host = str(addr[0])
        return f"[{host}]:{addr[1]}" if ":" in host else f"{host}:{addr[1]}"
    return str(addr)


def _tune(sock: socket.socket) -> socket.socket:
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


class TcpClientTransport(Transport):
    """Connects to a TCP server (a sonar, a serial server, the simulator)."""

    schemes: ClassVar[tuple[str, ...]] = ("tcp",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self.address = parse_address(url)
        query = _options(url, ("timeout", "reconnect"))
        try:
            self.connect_timeout = float(query.get("timeout", "5"))
        except ValueError as exc:
            raise TransportInitError(f"bad timeout in {url!r}") from exc
        self.auto_reconnect = _flag(url, query, "reconnect")
        self.reconnects = 0
        self.backoff = Backoff()  # the waits between retries with ``reconnect=1``
        self._retry_at = 0.0  # monotonic time of the next retry allowed
        self._connected_at = 0.0  # monotonic time the current connection was made
        self._sock: socket.socket | None = None

    def _connect(self, timeout: float) -> socket.socket:
        sock = socket.create_connection(self.address, timeout=timeout)
        sock.settimeout(None)
        self._connected_at = time.monotonic()
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
        """One connection attempt when the backoff allows it, else wait (within ``timeout``) for that time."""
        start = time.monotonic()
        budget = self.connect_timeout if timeout is None else max(timeout, 1e-3)
        if start < self._retry_at:
            time.sleep(min(budget, self._retry_at - start))
            return
        try:
            self._sock = self._connect(budget)
            self.reconnects += 1
        except OSError:
            self._retry_at = time.monotonic() + self.backoff.next_wait()
            time.sleep(max(0.0, min(budget - (time.monotonic() - start), self._retry_at - time.monotonic())))

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
            self.backoff.connection_lasted(time.monotonic() - self._connected_at)
            self._retry_at = time.monotonic() + self.backoff.next_wait()
            return b""
        raise TransportOperationError(f"{self.url}: connection closed by the peer") from error

    def _write(self, data: bytes) -> None:
        if self._sock is None:
            raise TransportOperationError(f"{self.url}: not connected")
        self._sock.sendall(data)


class TcpServerTransport(Transport):
    """Listens on ``host:port`` and exchanges bytes with one client (see the module docstring)."""

    schemes: ClassVar[tuple[str, ...]] = ("tcp-listen",)

    def __init__(self, url: str) -> None:
        super().__init__(url)
        self._bind = parse_address(url)
        self.takeover = _flag(url, _options(url, ("takeover",)), "takeover")
        self._listener: socket.socket | None = None
        self._client: socket.socket | None = None
        self.peer = ""  # host:port of the client served now ("" when none)
        self.clients = 0  # connections served so far
        self.refused = 0  # connections refused because a client was live
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
        self.peer = ""
        if client is not None:
            with contextlib.suppress(OSError):
                client.shutdown(socket.SHUT_RDWR)
            client.close()

    def _client_alive(self) -> bool:
        """Whether the served client's connection still stands (readable with 0 bytes = it closed)."""
        client = self._client
        if client is None:
            return False
        try:
            ready, _, _ = select.select([client], [], [], 0)
            return not ready or bool(client.recv(1, socket.MSG_PEEK))
        except OSError:
            return False

    def _accept(self) -> None:
        assert self._listener is not None
        client, addr = self._listener.accept()
        peer = _peer(addr)
        if self._client is not None:
            if self._client_alive() and not self.takeover:
                with contextlib.suppress(OSError):  # reset at once: no lingering half-open socket
                    client.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                client.close()
                self.refused += 1
                self._note("connection_refused", peer=peer, serving=self.peer,
                           reason="a client is connected already (takeover=1 in the URL lets a new one replace it)")
                return
            if self._client_alive():
                self._note("connection_taken_over", peer=peer, previous=self.peer)
            else:
                self._note("client_left", peer=self.peer)
            self._drop_client()
        self._client = _tune(client)
        self._client.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
        for name, value in KEEPALIVE:
            if hasattr(socket, name):
                with contextlib.suppress(OSError):
                    self._client.setsockopt(socket.IPPROTO_TCP, getattr(socket, name), value)
        self.peer = peer
        self.clients += 1
        self._note("client_connected", peer=peer)

    def wait_for_client(self, timeout: float | None = None) -> bool:
        """Block until a client is connected (True) or ``timeout`` s passed (False).

        A connection waiting while a client is live is refused (or, with ``takeover``, replaces it).
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
                self._note("client_left", peer=self.peer)
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
