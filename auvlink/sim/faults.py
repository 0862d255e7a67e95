"""Faults injected into ``auvlink sim --live`` serving (:func:`auvlink.sim.live.serve`, ``faults=``):
what the live-loop tests need to check that ``auvlink live`` survives a port that goes and comes
back, garbage in a stream and a stalled socket."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from auvlink.config import DeviceConfig
from auvlink.sim.live import Port, _close, _open, _send


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
    """Applies the faults as mission time passes; frames go through :meth:`send`."""

    def __init__(self, faults: Any, devices: dict[str, DeviceConfig], ports: dict[str, Port]) -> None:
        self.todo = sorted(faults, key=lambda f: f.at_s)
        self.active: list[Fault] = []
        self.roles = {dev.name: role for role, dev in devices.items()}
        self.devices, self.ports = devices, ports
        self.down: set[str] = set()
        self.held: dict[str, list[bytes]] = {}

    def tick(self, t: float) -> None:
        while self.todo and self.todo[0].at_s <= t:
            f = self.todo.pop(0)
            role = self.roles[f.device]
            if f.kind == "close":
                _close(self.ports[role])
                self.down.add(role)
            elif f.kind == "garbage":
                self.ports[role].sink.write(f.data)
            elif f.kind == "stall":
                self.held[role] = []
            self.active.append(f)
        for f in [f for f in self.active if f.at_s + f.duration_s <= t]:
            self.active.remove(f)
            role = self.roles[f.device]
            if f.kind == "close":
                self.down.discard(role)
                self.ports[role] = _open(role, self.devices[role])
            elif f.kind == "stall":
                for raw in self.held.pop(role, []):
                    _send(self.ports[role], raw)

    def send(self, role: str, raw: bytes) -> None:
        if role in self.down:
            self.ports[role].dropped += 1
        elif role in self.held:
            self.held[role].append(raw)
        else:
            _send(self.ports[role], raw)
