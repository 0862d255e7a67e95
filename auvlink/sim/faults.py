"""Faults injected into ``auvlink sim --live`` serving (:func:`auvlink.sim.device_server.serve`,
``hook=Injector(...)``): what the live-loop tests need to check that ``auvlink live`` survives a port that goes and
comes back, garbage in a stream and a stalled socket. The injector is a :class:`~auvlink.sim.device_server.PortHook`:
it acts on the ports only through their public methods."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from auvlink.sim.device_server import Port


@dataclass(frozen=True)
class Fault:
    """A fault injected at ``at_s`` of mission time on the device named (for the live-loop tests):
    ``close`` closes its port for ``duration_s`` (frames meanwhile are lost) and serves it again at the
    same place; ``garbage`` writes ``data`` raw into its stream; ``stall`` holds its frames for
    ``duration_s``, then sends them at once."""

    device: str
    at_s: float
    kind: str  # "close" | "garbage" | "stall"
    duration_s: float = 1.0
    data: bytes = b""


class Injector:
    """Applies the faults as mission time passes (a :class:`~auvlink.sim.device_server.PortHook`)."""

    def __init__(self, faults: Iterable[Fault]) -> None:
        self.todo = sorted(faults, key=lambda f: f.at_s)
        self.active: list[Fault] = []
        self.ports: dict[str, Port] = {}  # device name -> its port
        self.down: set[str] = set()
        self.held: dict[str, list[bytes]] = {}

    def start(self, ports: Mapping[str, Port]) -> None:
        self.ports = {p.device: p for p in ports.values()}

    def tick(self, t: float) -> None:
        while self.todo and self.todo[0].at_s <= t:
            f = self.todo.pop(0)
            port = self.ports[f.device]
            if f.kind == "close":
                port.close()
                self.down.add(f.device)
            elif f.kind == "garbage":
                port.write_raw(f.data)
            elif f.kind == "stall":
                self.held[f.device] = []
            self.active.append(f)
        for f in [f for f in self.active if f.at_s + f.duration_s <= t]:
            self.active.remove(f)
            port = self.ports[f.device]
            if f.kind == "close":
                self.down.discard(f.device)
                port.open()
            elif f.kind == "stall":
                for raw in self.held.pop(f.device, []):
                    port.send(raw)

    def send(self, t_s: float, port: Port, raw: bytes) -> None:
        self.tick(t_s)
        if port.device in self.down:
            port.dropped += 1
        elif port.device in self.held:
            self.held[port.device].append(raw)
        else:
            port.send(raw)
