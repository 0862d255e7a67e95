"""The simulated Oculus' data port: a TCP server that pings only while its client commands it.

A real Oculus is silent until a client sends SimpleFire (msg 0x15) on its data port and stops at ping rate
``standby`` (Blueprint's protocol facts, :mod:`auvlink.codecs.oculus`). :class:`FiredSonarSink` stands in
front of the port's :class:`~auvlink.transports.tcp.TcpServerTransport` with the same ``write`` /
``bytes_discarded`` / ``close`` face: before each ping it reads what the client sent (through the real
:class:`~auvlink.framing.oculus.OculusFramer` and decoder), and it writes the ping only when the connected
client has fired and not asked for standby. Pings held back are counted (:attr:`FiredSonarSink.unfired`) and
added to ``bytes_discarded``, so the serving port counts them as dropped. The pings keep the scene's window:
a fire's range, gain and mode are recorded (:attr:`FiredSonarSink.last_fire`) but not re-rendered.
"""

from __future__ import annotations

from auvlink.codecs import oculus
from auvlink.codecs.oculus_messages import OculusFireCommand
from auvlink.errors import DecodeError
from auvlink.framing.oculus import OculusFramer
from auvlink.transports.tcp import TcpServerTransport

#: the PingRateType code of standby (Oculus.h facts, auvlink.codecs.oculus_messages.OculusFire)
PING_RATE_STANDBY = 5


class FiredSonarSink:
    """A sonar data port that sends pings only to a client that has fired it (module docstring)."""

    def __init__(self, transport: TcpServerTransport) -> None:
        self.transport = transport
        self.framer = OculusFramer()
        self.last_fire: OculusFireCommand | None = None
        self.fires = 0  # SimpleFire messages received
        self.unfired = 0  # pings held back: no client, or its client has not fired, or asked for standby
        self._unfired_bytes = 0
        self._fired_client = -1  # the transport's client count when the last fire came

    @property
    def bytes_discarded(self) -> int:
        return self.transport.bytes_discarded + self._unfired_bytes

    def poll(self) -> None:
        """Read what the client sent so far and take its SimpleFire messages (other messages are ignored)."""
        while data := self.transport.read(timeout=0):
            for raw in self.framer.feed(data):
                try:
                    msg = oculus.decode(raw)
                except DecodeError:
                    continue
                if isinstance(msg, OculusFireCommand):
                    self.last_fire, self._fired_client = msg, self.transport.clients
                    self.fires += 1

    @property
    def pinging(self) -> bool:
        """Whether the connected client has fired the sonar and not asked for standby."""
        fire = self.last_fire
        return (fire is not None and self.transport.connected and self._fired_client == self.transport.clients
                and fire.fire.ping_rate != PING_RATE_STANDBY)

    def write(self, raw: bytes) -> None:
        """Send one ping if the sonar is pinging, else hold it back (counted)."""
        self.poll()
        if self.pinging:
            self.transport.write(raw)
        else:
            self.unfired += 1
            self._unfired_bytes += len(raw)

    def close(self) -> None:
        self.transport.close()
