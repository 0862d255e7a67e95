"""Drivers end to end: bytes written on the far end of a real port come out as exact raw frames
(at the listener) and decoded records, over a pty pair, loop://, TCP (both directions), pyserial's
socket://, a python-can virtual bus and slcan on a pty (the adapter emulator on one end).

A tiny test-only wire format (``test.xfix``: header + counter + value + 16-bit sum) keeps these
tests independent of the real codecs; the real formats run too where their codecs exist.
"""

from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from auvlink import formats
from auvlink.driver import Driver
from auvlink.errors import ChecksumError, DecodeError
from auvlink.formats import WireFormat
from auvlink.framing.base import Framer
from auvlink.records import Sample
from auvlink.transports.base import open_transport
from auvlink.transports.tcp import TcpServerTransport
from auvlink.virtual import PtyPair

pytestmark = pytest.mark.usefixtures("no_leaked_fds", "no_leaked_can_buses")

# -- the test format -------------------------------------------------------------------------
HEADER = b"\xa5\x5a"
BODY = struct.Struct("<2sHi")  # header, counter u16, value i32
SIZE = BODY.size + 2  # + sum16 of the body, little endian


@dataclass(frozen=True)
class XRecord:
    counter: int
    value: int


def x_encode(rec: XRecord) -> bytes:
    body = BODY.pack(HEADER, rec.counter, rec.value)
    return body + (sum(body) & 0xFFFF).to_bytes(2, "little")


def x_decode(raw: bytes) -> XRecord:
    if len(raw) != SIZE or raw[:2] != HEADER:
        raise DecodeError("test.xfix: not a frame", fmt="test.xfix")
    expected, actual = int.from_bytes(raw[-2:], "little"), sum(raw[:-2]) & 0xFFFF
    if expected != actual:
        raise ChecksumError("test.xfix", expected, actual)
    _, counter, value = BODY.unpack(raw[:-2])
    return XRecord(counter, value)


class XFramer(Framer):
    format_name = "test.xfix"

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        frames: list[bytes] = []
        while True:
            start = buf.find(HEADER)
            if start < 0:
                keep = 1 if buf[-1:] == HEADER[:1] and not final else 0
                self._drop(buf, len(buf) - keep)
                return frames
            self._drop(buf, start)
            if len(buf) < SIZE:
                return frames
            if sum(buf[:SIZE - 2]) & 0xFFFF == int.from_bytes(buf[SIZE - 2:SIZE], "little"):
                frames.append(bytes(buf[:SIZE]))
                del buf[:SIZE]
            else:
                self.stats.bad_checksums += 1
                self._drop(buf, 1)


formats.register(WireFormat("test.xfix", "test.xfix", "test-only fixed frames", x_decode, x_encode, XFramer))


# -- helpers ---------------------------------------------------------------------------------
def make_frames(n: int, seed: int = 1) -> tuple[list[XRecord], list[bytes]]:
    rng = np.random.default_rng(seed)
    records = [XRecord(i % 65536, int(v)) for i, v in enumerate(rng.integers(-2**31, 2**31, n))]
    return records, [x_encode(r) for r in records]


def odd_chunks(data: bytes, seed: int = 2, most: int = 97) -> Iterator[bytes]:
    """``data`` cut at random places (1..most bytes a piece)."""
    rng = np.random.default_rng(seed)
    pos = 0
    while pos < len(data):
        step = int(rng.integers(1, most + 1))
        yield data[pos:pos + step]
        pos += step


def garbage(rng: np.random.Generator, n: int) -> bytes:
    """Random bytes that cannot start a frame (no 0xA5)."""
    return bytes(b for b in rng.integers(0, 256, n, dtype=np.uint8).tobytes() if b != 0xA5)


class Tap:
    """A raw listener keeping what it is given."""

    def __init__(self) -> None:
        self.frames: list[bytes] = []
        self.calls: list[tuple[str, str, int]] = []

    def __call__(self, device: str, fmt: str, t_host_ns: int, raw: bytes) -> None:
        self.calls.append((device, fmt, t_host_ns))
        self.frames.append(raw)


def collect(driver: Driver, n: int, timeout: float = 10.0) -> list[Sample]:
    out: list[Sample] = []
    end = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < end:
        out += driver.read(0.05)
    return out


@contextmanager
def writing(write: Callable[[bytes], object], chunks: Iterator[bytes] | list[bytes]) -> Iterator[None]:
    """Write ``chunks`` from a thread (the instrument) while the body reads (the driver)."""
    error: list[BaseException] = []

    def run() -> None:
        try:
            for chunk in chunks:
                write(chunk)
        except BaseException as exc:  # surfaced in the test thread below
            error.append(exc)

    thread = threading.Thread(target=run, name="instrument")
    thread.start()
    try:
        yield
    finally:
        thread.join(timeout=10.0)
    assert not error, error


def check(samples: list[Sample], tap: Tap, records: list[XRecord], raws: list[bytes], name: str) -> None:
    assert [s.record for s in samples] == records
    assert tap.frames == raws and [s.raw for s in samples] == raws
    assert {(d, f) for d, f, _ in tap.calls} == {(name, "test.xfix")}
    stamps = [s.t_host_ns for s in samples]
    assert stamps == sorted(stamps) and all(s.format == "test.xfix" and s.device == name for s in samples)


# -- serial ----------------------------------------------------------------------------------
def test_pty_pair_odd_chunks_with_garbage_and_damage() -> None:
    rng = np.random.default_rng(5)
    records, raws = make_frames(3000)
    stream, junk, damaged = bytearray(), 0, set()
    for i, raw in enumerate(raws):
        if i % 50 == 7:
            lump = garbage(rng, int(rng.integers(1, 40)))
            stream += lump
            junk += len(lump)
        if i % 97 == 13:  # one flipped bit in the counter/value: the checksum catches it
            bad = bytearray(raw)
            bad[2 + int(rng.integers(0, 6))] ^= 1 << int(rng.integers(0, 8))
            stream += bad
            damaged.add(i)
        else:
            stream += raw
    good = [i for i in range(len(raws)) if i not in damaged]
    tap = Tap()
    with PtyPair() as pty, Driver("gyro", "test.xfix", f"{pty.device_path}?baudrate=115200") as drv:
        drv.add_raw_listener(tap)
        with writing(pty.write, odd_chunks(bytes(stream))):
            samples = collect(drv, len(good))
    check(samples, tap, [records[i] for i in good], [raws[i] for i in good], "gyro")
    stats = drv.framer.stats
    assert stats.frames == len(good) and stats.bad_checksums >= len(damaged)
    assert stats.bytes_in == len(stream)
    assert stats.dropped_bytes == junk + SIZE * len(damaged)
    assert drv.stats.samples == len(good) and drv.stats.decode_errors == 0
    assert drv.stats.framer["frames"] == len(good)


def test_driver_writes_back_through_the_pty() -> None:
    """Commands the driver sends reach the instrument; replies come back decoded."""
    records, raws = make_frames(5, seed=9)
    with PtyPair() as pty, Driver("dev", "test.xfix", pty.device_path) as drv:
        drv.transport.write(b"POLL\r")
        got = bytearray()
        while len(got) < 5:
            got += pty.read(timeout=1.0)
        assert bytes(got) == b"POLL\r"
        pty.write(b"".join(raws))
        assert [s.record for s in collect(drv, 5)] == records


def test_loop_url_small() -> None:
    records, raws = make_frames(40, seed=3)
    tap = Tap()
    with Driver("loop", "test.xfix", "loop://") as drv:
        drv.add_raw_listener(tap)
        for chunk in odd_chunks(b"".join(raws), most=13):
            drv.transport.write(chunk)  # loop:// hands the bytes straight back
        samples = collect(drv, 40)
    check(samples, tap, records, raws, "loop")


def test_driver_accepts_a_built_transport_and_reports() -> None:
    _, raws = make_frames(3, seed=4)
    transport = open_transport("loop://")
    with Driver("x", "test.xfix", transport) as drv:
        transport.write(b"".join(raws) + raws[0][:4])
        assert len(collect(drv, 3)) == 3
        info = drv.describe()
    assert info["samples"] == 3 and info["url"] == "loop://" and info["framer_frames"] == 3
    assert not transport.is_open


# -- TCP -------------------------------------------------------------------------------------
def test_tcp_device_is_the_server() -> None:
    """A sonar listens; the driver connects as a client."""
    records, raws = make_frames(5000, seed=6)
    tap = Tap()
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as sonar:
        host, port = sonar.address
        with Driver("sonar", "test.xfix", f"tcp://{host}:{port}") as drv:
            drv.add_raw_listener(tap)
            assert sonar.wait_for_client(2.0)
            with writing(sonar.write, odd_chunks(b"".join(raws), most=3000)):
                samples = collect(drv, len(raws))
    check(samples, tap, records, raws, "sonar")


def test_tcp_driver_is_the_server() -> None:
    """The vehicle listens; the instrument connects and pushes frames."""
    records, raws = make_frames(2000, seed=7)
    tap = Tap()
    with Driver("pushed", "test.xfix", "tcp-listen://127.0.0.1:0") as drv:
        drv.add_raw_listener(tap)
        assert isinstance(drv.transport, TcpServerTransport)
        host, port = drv.transport.address
        with open_transport(f"tcp://{host}:{port}") as device:
            with writing(device.write, odd_chunks(b"".join(raws), most=500)):
                samples = collect(drv, len(raws))
    check(samples, tap, records, raws, "pushed")


def test_pyserial_socket_url_as_a_serial_server() -> None:
    """A serial-to-Ethernet server (raw TCP) read through pyserial's socket:// URL."""
    records, raws = make_frames(500, seed=8)
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as server:
        host, port = server.address
        with Driver("nport", "test.xfix", f"socket://{host}:{port}") as drv:
            assert server.wait_for_client(2.0)
            with writing(server.write, odd_chunks(b"".join(raws))):
                samples = collect(drv, len(raws))
    assert [s.record for s in samples] == records


# -- real formats (each runs once its codec exists) -----------------------------------------
def codec(name: str) -> Any:
    return pytest.importorskip(f"auvlink.codecs.{name}", reason=f"codec {name} not written yet")


def run_format(fmt: str, url_of: Callable[[PtyPair], str], wire: list[bytes], junk: bytes = b"") -> tuple[
        list[Sample], Tap, Driver]:
    tap = Tap()
    stream = junk.join(wire) if junk else b"".join(wire)
    with PtyPair() as pty, Driver(fmt, fmt, url_of(pty)) as drv:
        drv.add_raw_listener(tap)
        with writing(pty.write, odd_chunks(stream, seed=11)):
            samples = collect(drv, len(wire))
    return samples, tap, drv


def test_dsp1760_over_a_pty_pair() -> None:
    dsp = codec("dsp1760")
    rng = np.random.default_rng(17)
    msgs = [dsp.build(rng.normal(0, 0.3, 3), rng.normal(0, 2, 3) + np.array([0, 0, 9.81]), sequence=i,
                      temperature_c=21.0) for i in range(1000)]
    wire = [dsp.encode(m) for m in msgs]
    samples, tap, drv = run_format("dsp1760", lambda p: f"{p.device_path}?baudrate=921600", wire,
                                   junk=b"\x00\xfe\x81")  # junk with a partial header between messages
    assert [s.record for s in samples] == msgs and tap.frames == wire
    assert drv.framer.stats.dropped_bytes == 3 * (len(wire) - 1)


def test_dsp3000_lines_over_a_pty_pair() -> None:
    dsp = codec("dsp3000")
    rng = np.random.default_rng(18)
    readings = [dsp.build(float(v)) for v in rng.normal(0, 0.01, 500)]
    wire = [dsp.encode(r) for r in readings]
    samples, tap, _ = run_format("dsp3000", lambda p: p.device_path, wire)
    assert [s.record for s in samples] == readings and tap.frames == wire


def test_paro_lines_over_a_pty_pair() -> None:
    paro = codec("paro")
    readings = [paro.build_reading(101_325.0 + 1000.0 * i) for i in range(300)]
    wire = [paro.encode(r) for r in readings]
    samples, tap, _ = run_format("paro", lambda p: p.device_path, wire)
    assert [s.record for s in samples] == readings and tap.frames == wire
    assert samples[10].record.pressure_pa == pytest.approx(111_325.0, abs=0.07)  # 1e-5 psi on the wire


def test_keller_request_and_response_over_a_pty_pair() -> None:
    keller = codec("keller")
    records = [rec for i in range(200) for rec in (
        keller.KellerReadRequest(1, 1), keller.build_pressure_response(1, 200_000.0 + 10.0 * i))]
    wire = [keller.encode(r) for r in records]
    samples, tap, _ = run_format("keller", lambda p: p.device_path, wire)
    assert [s.record for s in samples] == records and tap.frames == wire
    readings = list(keller.iter_readings(s.record for s in samples))
    assert len(readings) == 200 and readings[-1].value == pytest.approx(2.0199, abs=1e-6)  # bar



def test_didson_frames_over_tcp() -> None:
    didson = codec("didson")
    rng = np.random.default_rng(19)
    frames = [didson.build(rng.integers(0, 256, (512, 96), dtype=np.uint8), 1.0, 10.0, frame_index=i,
                           time=1.7e9 + 0.1 * i) for i in range(40)]
    wire = [didson.encode(f) for f in frames]
    tap = Tap()
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as sonar:
        host, port = sonar.address
        with Driver("sonar", "didson", f"tcp://{host}:{port}") as drv:
            drv.add_raw_listener(tap)
            assert sonar.wait_for_client(2.0)
            with writing(sonar.write, odd_chunks(b"".join(wire), seed=12, most=7000)):
                samples = collect(drv, len(wire))
    assert tap.frames == wire and [s.record for s in samples] == frames
    assert [s.t_sensor for s in samples] == pytest.approx([1.7e9 + 0.1 * i for i in range(40)], abs=1e-6)
    assert drv.framer.stats.dropped_bytes == 0


def test_pd0_capture_through_a_pty_pair(shared_data: Path) -> None:
    """A real DVL capture played on a pty: the driver cuts exactly the frames a one-shot framer cuts."""
    codec("pd0")
    capture = (shared_data / "rdi" / "RDI_withBT.000").read_bytes()[:200_000]
    fmt = formats.get("pd0")
    expected = fmt.framer().feed(capture)
    tap = Tap()
    with PtyPair() as pty, Driver("dvl", "pd0", f"{pty.device_path}?baudrate=115200") as drv:
        drv.add_raw_listener(tap)
        with writing(pty.write, odd_chunks(capture, seed=13, most=1500)):
            samples = collect(drv, len(expected))
    assert tap.frames == expected and len(samples) == len(expected) > 100
    assert drv.stats.decode_errors == 0
    assert all(fmt.encode(s.record) == s.raw for s in samples[:20])


# -- CAN -------------------------------------------------------------------------------------
def can_frames() -> Any:
    return pytest.importorskip("auvlink.framing.can_frames", reason="can_frames not written yet")


def nav_messages(nav: Any, n: int) -> list[Any]:
    """``n`` navigation records cycling through DVL velocity, gyro rate and depth."""
    out = []
    for i in range(n):
        kind = i % 3
        if kind == 0:
            out.append(nav.build("DVL_BT_VELOCITY", vx=1.0 + 0.001 * i, vy=-0.2, vz=0.01, counter=i % 256))
        elif kind == 1:
            out.append(nav.build("GYRO_RATE", rate_z=0.0123 - 1e-6 * i, counter=i % 256))
        else:
            out.append(nav.build("DEPTH", depth=20.0 + 0.01 * i, counter=i % 256))
    return out


def test_can_virtual_bus_to_driver_and_back() -> None:
    cf = can_frames()
    nav = codec("can_nav")
    import can

    from auvlink.virtual import VirtualCanChannel

    records = nav_messages(nav, 300)
    wire = [nav.encode(r) for r in records]
    tap = Tap()
    with VirtualCanChannel() as chan, Driver("nav", "can", chan.url()) as drv:
        node = chan.bus()
        drv.add_raw_listener(tap)
        node.send(can.Message(arbitration_id=0x7E0, is_extended_id=False, data=b"\x01"))  # not in the DBC
        node.send(can.Message(arbitration_id=0x7E1, is_fd=True, data=bytes(64)))  # cannot be carried
        for raw in wire:
            node.send(cf.frame_to_message(raw))
        samples = collect(drv, len(wire))
        assert drv.transport.messages_skipped == 1  # type: ignore[attr-defined]
        assert drv.stats.decode_errors == 1 and "unknown arbitration id" in drv.stats.last_error
        for cut in range(0, 64, 5):  # the driver commands a node: frames written in odd pieces
            drv.transport.write(b"".join(wire[:4])[cut:cut + 5])
        got = [node.recv(1.0) for _ in range(4)]
    assert [s.record for s in samples] == records and tap.frames[1:] == wire
    assert [cf.message_to_frame(m) for m in got if m is not None] == wire[:4]
    depth = [s.record.signals["depth"] for s in samples if s.record.name == "DEPTH"]
    assert depth[:2] == pytest.approx([20.02, 20.05])


def test_can_over_slcan_on_a_pty_pair() -> None:
    """The adapter emulator is the CAN node; the driver opens can://slcan/<pty> like a USB adapter."""
    cf = can_frames()
    nav = codec("can_nav")
    from auvlink.virtual_slcan import SlcanAdapter

    records = nav_messages(nav, 120)
    wire = [nav.encode(r) for r in records]
    tap = Tap()
    with SlcanAdapter() as adapter, Driver("nav", "can", adapter.url(bitrate=500_000)) as drv:
        drv.add_raw_listener(tap)
        adapter.wait_open(2.0)
        assert adapter.bitrate == 500_000
        for raw in wire:
            adapter.send(cf.frame_to_message(raw))
        samples = collect(drv, len(wire))
        drv.transport.write(wire[0] + wire[1])
        back = [adapter.recv(1.0) for _ in range(2)]
    assert tap.frames == wire and [s.record for s in samples] == records
    assert [cf.message_to_frame(m) for m in back if m is not None] == wire[:2]
    assert adapter.to_host == len(wire) and adapter.from_host == 2
    assert adapter.commands[:5] == ["C", "S6", "", "O", "O"]  # python-can's open sequence
    assert adapter.errors == 2  # BEL for "C" while closed and for the second "O", as a real adapter
