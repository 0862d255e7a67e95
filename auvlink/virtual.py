"""Virtual ports: the far end of a serial line, a private CAN channel, a free TCP port.

A driver cannot tell these from hardware: it opens the slave path of a
:class:`~auvlink.virtual_pty.PtyPair` with the ordinary serial transport, a ``can://virtual/...`` URL
from :class:`VirtualCanChannel`, or a ``can://slcan//dev/pts/N`` URL served by
:class:`~auvlink.virtual_slcan.SlcanAdapter` (an adapter emulated on a pty). The pty itself lives in
one module, :mod:`auvlink.virtual_pty` (re-exported here).
"""

from __future__ import annotations

import socket
import uuid
from types import TracebackType
from typing import Any

import can

from auvlink.virtual_pty import PtyPair, PtyTransport

__all__ = ["PtyPair", "PtyTransport", "VirtualCanChannel", "free_tcp_port"]


class VirtualCanChannel:
    """A private channel of python-can's ``virtual`` interface; shuts down the buses it made."""

    def __init__(self, prefix: str = "auvlink") -> None:
        self.name = f"{prefix}-{uuid.uuid4().hex[:12]}"
        self._buses: list[Any] = []

    def url(self, **options: object) -> str:
        """``can://virtual/<name>`` with ``options`` as the query (e.g. ``receive_own_messages=1``)."""
        query = "&".join(f"{key}={value}" for key, value in options.items())
        return f"can://virtual/{self.name}" + (f"?{query}" if query else "")

    def bus(self, **kwargs: Any) -> Any:
        """A ``can.BusABC`` on this channel (another node); shut down by :meth:`close`."""
        bus = can.Bus(interface="virtual", channel=self.name, **kwargs)
        self._buses.append(bus)
        return bus

    def close(self) -> None:
        while self._buses:
            self._buses.pop().shutdown()

    def __enter__(self) -> VirtualCanChannel:
        return self

    def __exit__(self, et: type[BaseException] | None, ev: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def free_tcp_port(host: str = "127.0.0.1") -> int:
    """A TCP port free right now on ``host`` (racy by nature: prefer ``tcp-listen://host:0``)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])
