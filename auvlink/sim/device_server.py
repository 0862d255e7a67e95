"""The simulated vehicle live (``auvlink sim --live``): its devices served on virtual ports named by a vehicle
configuration file.

    auvlink sim --scene S.toml --live examples/virtual_ports.toml [--speed X] [--duration S]

The configuration is the one ``auvlink record`` and ``auvlink live`` read, unchanged. Each of its
devices is matched to a simulated instrument by its wire format (``pd0`` DVL, ``dsp1760`` gyro,
``paro`` or ``keller`` pressure, ``can`` navigation bus, ``didson``, ``aris`` or ``oculus`` sonar, ``nmea`` GNSS
receiver: silent when the scene has no ``[gnss]``) and served where its URL points:

- a serial URL (``/tmp/auvlink/dvl?baudrate=115200``): a :class:`~auvlink.virtual.PtyPair` whose
  slave is symlinked at that path (parent folders created). Lossy like a UART: bytes nobody reads
  are dropped once the kernel buffer is full;
- ``can://slcan/<path>``: an :class:`~auvlink.virtual_slcan.SlcanAdapter` (a USB-CAN adapter
  emulated on a pty symlinked at ``<path>``); any other python-can interface (``virtual``,
  ``socketcan``) is opened as a bus and sent to;
- ``tcp://host:port``: a TCP server there (the reader connects as a client).

The configuration also describes the vehicle, so it wins over the scene (:func:`auvlink.sim.vehicle_adapt.adapt`:
mountings, the sonar's geometry and model, the pressure sensor's kind; the site datum is the scene's: it is
where the world is, not the vehicle). An ``oculus`` sonar pings only once its client has sent SimpleFire
(:class:`auvlink.sim.oculus_port.FiredSonarSink`). Frames go out at ``speed`` x real time (an absolute schedule:
no drift) for ``duration`` s (default: the survey); :func:`serve` returns when the run ends or
``stop`` is set, and closes every port (the symlinks are removed). A :class:`PortHook` passed to
:func:`serve` stands between the schedule and the ports (the live-loop tests inject faults with
:class:`auvlink.sim.faults.Injector`).
"""

from __future__ import annotations

import builtins
import queue
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import IO, Any, Protocol

import can

from auvlink.config import DeviceConfig, VehicleConfig
from auvlink.framing.can_frames import frame_to_message
from auvlink.sim.emit import Event, block_events
from auvlink.sim.mission import Run, prepare
from auvlink.sim.noise import NoiseConfig, SimError
from auvlink.sim.oculus_port import FiredSonarSink
from auvlink.sim.scene import Scene
from auvlink.sim.settings import SimSettings, settings_for
from auvlink.sim.sonar_render import SonarRenderer
from auvlink.sim.vehicle_adapt import adapt, match_devices
from auvlink.transports.can_bus import parse_can_url
from auvlink.transports.tcp import TcpServerTransport, parse_address
from auvlink.virtual_pty import PtyPair
from auvlink.virtual_slcan import SlcanAdapter

#: s of mission rendered at a time, ahead of the schedule (a few blocks are kept ready)
BLOCK_S = 1.0
#: s: a frame sent later than its schedule by more than this counts as late (half a 10 Hz sonar's ping interval)
LATE_S = 0.05


@dataclass
class Port:
    """One served device: where the reader finds it, and counters (:meth:`open` serves it, :meth:`send`
    writes one frame, :meth:`close` stops serving; reopened, it keeps its counters)."""

    device: str
    format: str
    role: str
    where: str
    sink: Any = None
    frames: int = 0
    bytes: int = 0
    dropped: int = 0
    config: DeviceConfig | None = field(default=None, repr=False)

    @classmethod
    def serve(cls, role: str, dev: DeviceConfig) -> Port:
        """The device ``dev`` served in the simulated ``role``, open."""
        port = cls(dev.name, dev.format, role, dev.url, config=dev)
        port.open()
        return port

    def open(self) -> None:
        """Serve the device where its URL points (a pty, an slcan adapter, a CAN bus, a TCP server)."""
        dev = self.config
        if dev is None:
            raise SimError(f"port {self.device!r}: no device configuration to serve")
        if self.role == "sonar":
            if not dev.url.startswith("tcp://"):
                raise SimError(f"cannot serve the sonar on {dev.url!r}: use tcp://HOST:PORT")
            host, p = parse_address(dev.url)
            tcp = TcpServerTransport(f"tcp-listen://{host}:{p}").open()
            self.sink = FiredSonarSink(tcp) if self.format == "oculus" else tcp  # an Oculus pings once fired
            self.where = f"tcp://{host}:{p} (listening)"
        elif self.role == "can":
            interface, channel, options = parse_can_url(dev.url)
            if interface == "slcan":
                if not channel:
                    raise SimError(f"cannot serve {dev.url!r}: no slcan channel path")
                self.sink = SlcanAdapter(channel)
                self.where = f"slcan adapter on {channel} -> {self.sink.pty.slave_name}"
            else:
                kw = {k: v for k, v in options.items() if k != "sleep_after_open"}
                self.sink = can.Bus(interface=interface, channel=channel, **kw)
                self.where = f"python-can {interface} channel {channel}"
        else:
            path = _serial_path(dev.url)
            self.sink = PtyPair(path, lossy=True).open()
            self.where = f"{path} -> {self.sink.slave_name}"

    def send(self, raw: builtins.bytes) -> None:  # (the field `bytes` shadows the type here)
        """One frame to the reader; counted as dropped when the line or the bus refuses it."""
        if self.role == "can":
            try:
                self.sink.send(frame_to_message(raw, time.time()))
            except can.CanError:
                self.dropped += 1
                return
        elif self.role == "sonar":
            before = self.sink.bytes_discarded
            self.sink.write(raw)
            if self.sink.bytes_discarded != before:
                self.dropped += 1
                return
        else:
            sent = self.sink.write(raw)
            if sent < len(raw):
                self.dropped += 1
                return
        self.frames += 1
        self.bytes += len(raw)

    def write_raw(self, data: builtins.bytes) -> None:
        """Bytes into the stream as they are (not a frame: not counted)."""
        self.sink.write(data)

    def close(self) -> None:
        sink, self.sink = self.sink, None
        if sink is None:
            return
        if self.role == "can":
            sink.shutdown()
        else:
            sink.close()


class PortHook(Protocol):
    """Stands between the serving schedule and the ports: :meth:`start` sees every port once they are
    open, :meth:`send` every frame at its mission time ``t_s`` (s) instead of ``port.send(raw)``."""

    def start(self, ports: Mapping[str, Port]) -> None: ...

    def send(self, t_s: float, port: Port, raw: bytes) -> None: ...


@dataclass
class LiveResult:
    """What a live run served: its wall-clock ``seconds``, the ports with their counters, and how well it kept
    its schedule: ``late_frames`` sent more than :data:`LATE_S` after their time, ``behind_s`` the most any frame
    was (s). A simulator behind its schedule stamps its frames late on the receiver's clock, except where a frame
    carries the sensor's own time (a sonar's), so a reader then sees its navigation late against its sonar."""

    seconds: float
    ports: list[Port] = field(default_factory=list)
    late_frames: int = 0
    behind_s: float = 0.0


def _serial_path(url: str) -> str:
    path = url[len("serial://"):] if url.startswith("serial://") else url
    if "://" in path:
        raise SimError(f"cannot serve {url!r}: a serial device needs a path (e.g. /tmp/auvlink/dvl)")
    return path.partition("?")[0]


def _producer(run: Run, blocks: queue.Queue[list[Event] | None], stop: threading.Event,
              halt: threading.Event, errors: list[BaseException], with_sonar: bool) -> None:
    try:
        renderer = SonarRenderer(run.scene) if with_sonar else None
        last = run.duration + run.settings.sensors.keller_latency_s
        b = 0
        while not (stop.is_set() or halt.is_set()) and b * BLOCK_S <= last:
            events = block_events(run.measurements, b * BLOCK_S, (b + 1) * BLOCK_S, renderer)
            b += 1
            while not (stop.is_set() or halt.is_set()):
                try:
                    blocks.put(events, timeout=0.1)
                    break
                except queue.Full:
                    continue
    except BaseException as exc:  # handed to the sender, which raises it
        errors.append(exc)
    finally:
        while not halt.is_set():  # the end mark must arrive, or the sender would wait for ever
            try:
                blocks.put(None, timeout=0.1)
                break
            except queue.Full:
                continue


def serve(scene: Scene, config: VehicleConfig, *, speed: float = 1.0, duration: float | None = None,
          seed: int | None = None, noise: bool | NoiseConfig | None = None, settings: SimSettings | None = None,
          stop: threading.Event | None = None, ready: threading.Event | None = None,
          out: IO[str] | None = None, hook: PortHook | None = None) -> LiveResult:
    """Serve the simulated devices of ``config`` until the run ends or ``stop`` is set (every frame through
    ``hook`` when given)."""
    if not speed > 0:
        raise SimError(f"the speed must be > 0, got {speed}")
    stop = stop or threading.Event()
    scene, settings = adapt(scene, settings_for(scene) if settings is None else settings, config)
    run = prepare(scene, seed, duration, settings=settings, noise=noise)
    devices = match_devices(config)
    ports: dict[str, Port] = {}
    blocks: queue.Queue[list[Event] | None] = queue.Queue(maxsize=3)
    errors: list[BaseException] = []
    halt = threading.Event()
    thread = threading.Thread(target=_producer, args=(run, blocks, stop, halt, errors, "sonar" in devices),
                              name="auvlink-sim-producer", daemon=True)
    t_start = time.monotonic()
    late, behind = 0, 0.0  # frames sent late, and the most behind (s)
    try:
        for role, dev in devices.items():
            ports[role] = Port.serve(role, dev)
        if out is not None:
            print(f"auvlink sim: {scene.source or 'scene'} (seed {run.scene.seed}) live at {speed:g}x real "
                  f"time for {run.duration:.1f} s; Ctrl-C stops", file=out)
            for p in ports.values():
                print(f"  {p.device:<10} {p.format:<8} {p.where}", file=out)
            out.flush()
        if ready is not None:
            ready.set()
        thread.start()
        start_ns = run.settings.sensors.start_ns
        t0 = time.monotonic()
        if hook is not None:
            hook.start(ports)
        while not stop.is_set():
            try:
                events = blocks.get(timeout=0.1)
            except queue.Empty:
                continue
            if events is None:
                break
            for t_ns, _, _, role, raw, _ in events:
                delay = t0 + (t_ns - start_ns) * 1e-9 / speed - time.monotonic()
                if delay > 0 and stop.wait(delay):
                    break
                if delay < -LATE_S:
                    late, behind = late + 1, max(behind, -delay)
                if role not in ports:
                    continue
                if hook is None:
                    ports[role].send(raw)
                else:
                    hook.send((t_ns - start_ns) * 1e-9, ports[role], raw)
        if errors:
            raise SimError(f"the simulation failed: {errors[0]}") from errors[0]
    except OSError as exc:
        raise SimError(f"cannot serve the virtual ports: {exc}") from exc
    finally:
        halt.set()
        if thread.is_alive():
            thread.join(timeout=5.0)
        for port in ports.values():
            port.close()
    return LiveResult(time.monotonic() - t_start, list(ports.values()), late, behind)
