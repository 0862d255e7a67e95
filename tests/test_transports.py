"""Transport backends: serial (pyserial URLs, pty slaves), TCP client and server, CAN (python-can)."""

from __future__ import annotations

import os
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import can
import pytest

from auvlink.errors import TransportInitError, TransportOperationError, TransportTimeoutError
from auvlink.transports.base import Transport, open_transport, transport_class
from auvlink.transports.can_bus import CanTransport, parse_can_url
from auvlink.transports.serial_port import SerialTransport, parse_serial_url
from auvlink.transports.tcp import TcpClientTransport, TcpServerTransport
from auvlink.virtual import PtyPair, PtyTransport, VirtualCanChannel, free_tcp_port

pytestmark = pytest.mark.usefixtures("no_leaked_fds", "no_leaked_can_buses")


def read_exactly(read: Callable[..., bytes], n: int, timeout: float = 2.0) -> bytes:
    out = bytearray()
    end = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < end:
        out += read(timeout=0.05)
    return bytes(out)


def elapsed(call: Callable[[], object]) -> float:
    start = time.monotonic()
    call()
    return time.monotonic() - start


# -- registry and URL parsing ----------------------------------------------------------------
@pytest.mark.parametrize(("url", "cls"), [
    ("/dev/ttyUSB0?baudrate=115200", SerialTransport), ("serial:///dev/ttyS1", SerialTransport),
    ("loop://", SerialTransport), ("socket://127.0.0.1:4001", SerialTransport),
    ("rfc2217://10.0.0.2:2217", SerialTransport), ("tcp://127.0.0.1:5000", TcpClientTransport),
    ("tcp-listen://0.0.0.0:5000", TcpServerTransport), ("can://virtual/x", CanTransport),
    ("pty://", PtyTransport),
])
def test_scheme_picks_the_backend(url: str, cls: type[Transport]) -> None:
    assert transport_class(url) is cls


def test_unknown_scheme_names_the_known_ones() -> None:
    with pytest.raises(TransportInitError, match="tcp-listen"):
        transport_class("udp://1.2.3.4:5")


def test_serial_url_forms() -> None:
    assert parse_serial_url("/dev/ttyUSB0?baudrate=115200&bytesize=7&parity=E&stopbits=2") == (
        "/dev/ttyUSB0", {"baudrate": 115200, "bytesize": 7, "parity": "E", "stopbits": 2})
    assert parse_serial_url("serial:///dev/ttyS1?rtscts=1&xonxoff=false") == (
        "/dev/ttyS1", {"rtscts": True, "xonxoff": False})
    assert parse_serial_url("/dev/pts/3?timeout=0.5") == ("/dev/pts/3", {"write_timeout": 0.5})
    assert parse_serial_url("loop://") == ("loop://", {})
    assert parse_serial_url("socket://h:1?logging=debug&baudrate=9600") == (
        "socket://h:1?logging=debug", {"baudrate": 9600})
    assert parse_serial_url("rfc2217://h:2217?ign_set_control&stopbits=1.5")[0] == (
        "rfc2217://h:2217?ign_set_control")


@pytest.mark.parametrize("url", ["/dev/x?baudrate=fast", "/dev/x?bytesize=9", "/dev/x?parity=Q",
                                 "/dev/x?stopbits=3", "/dev/x?rtscts=maybe", "/dev/x?baud=9600",
                                 "serial://"])
def test_bad_serial_urls_raise_init_errors(url: str) -> None:
    with pytest.raises(TransportInitError):
        SerialTransport(url)


def test_can_url_forms() -> None:
    assert parse_can_url("can://virtual/nav0") == ("virtual", "nav0", {})
    assert parse_can_url("can://slcan//dev/pts/3?bitrate=500000&sleep_after_open=0") == (
        "slcan", "/dev/pts/3", {"bitrate": 500000, "sleep_after_open": 0})
    assert parse_can_url("can://slcan/dev/ttyACM0")[1] == "/dev/ttyACM0"  # forgiving for adapters
    assert parse_can_url("can://socketcan/vcan0?receive_own_messages=true&fd=off") == (
        "socketcan", "vcan0", {"receive_own_messages": True, "fd": False})
    assert parse_can_url("can://virtual/")[1] is None
    with pytest.raises(TransportInitError):
        parse_can_url("can:///x")


# -- serial ----------------------------------------------------------------------------------
def test_loop_url_round_trip_and_timeout() -> None:
    with open_transport("loop://?baudrate=115200") as port:
        port.write(b"$PRDID,1.0,2.0\r\n")
        assert read_exactly(port.read, 16) == b"$PRDID,1.0,2.0\r\n"
        assert 0.08 <= elapsed(lambda: port.read(timeout=0.1)) < 1.0
        assert port.read(timeout=0) == b""
        assert (port.bytes_read, port.bytes_written) == (16, 16)


def test_serial_on_a_pty_slave() -> None:
    with PtyPair() as pty, SerialTransport(f"{pty.device_path}?baudrate=9600&parity=N") as port:
        assert port.port.baudrate == 9600
        assert 0.08 <= elapsed(lambda: port.read(timeout=0.1)) < 1.0  # select honours the timeout
        pty.write(b"A" * 10_000)
        assert read_exactly(port.read, 10_000) == b"A" * 10_000
        port.write(b"\x00\x01\xff")
        assert read_exactly(pty.read, 3) == b"\x00\x01\xff"


def test_serial_write_timeout_when_nobody_reads() -> None:
    with PtyPair() as pty, SerialTransport(f"{pty.device_path}?write_timeout=0.2") as port:
        with pytest.raises(TransportTimeoutError, match="did not finish"):
            port.write(bytes(1 << 20))


def test_missing_device_and_closed_transport() -> None:
    with pytest.raises(TransportInitError, match="/dev/auvlink-none"):
        open_transport("/dev/auvlink-none?baudrate=9600")
    port = SerialTransport("loop://")
    with pytest.raises(TransportOperationError, match="closed"):
        port.read(0)
    port.open()
    port.close()
    with pytest.raises(TransportOperationError, match="closed"):
        port.write(b"x")


def test_pyserial_socket_url_reaches_a_tcp_server() -> None:
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as server:
        host, port = server.address
        with open_transport(f"socket://{host}:{port}") as client:
            assert server.wait_for_client(2.0)
            server.write(b"x" * 100_000)
            assert read_exactly(client.read, 100_000) == b"x" * 100_000
            client.write(b"ack")
            assert read_exactly(server.read, 3) == b"ack"


# -- TCP -------------------------------------------------------------------------------------
@pytest.fixture
def server() -> Iterator[TcpServerTransport]:
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as srv:
        yield srv


def url_of(server: TcpServerTransport, scheme: str = "tcp", query: str = "") -> str:
    host, port = server.address
    return f"{scheme}://{host}:{port}{query}"


def test_tcp_both_directions_with_nodelay(server: TcpServerTransport) -> None:
    assert server.address[1] > 0 and not server.connected
    with TcpClientTransport(url_of(server)) as client:
        assert server.wait_for_client(2.0) and server.clients == 1
        assert client._sock is not None and server._client is not None
        for sock in (client._sock, server._client):
            assert sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY)
        payload = os.urandom(300_000)
        server.write(payload)
        assert read_exactly(client.read, len(payload)) == payload
        client.write(payload[:1000])
        assert read_exactly(server.read, 1000) == payload[:1000]


def test_tcp_reads_return_within_the_timeout(server: TcpServerTransport) -> None:
    assert 0.08 <= elapsed(lambda: server.read(0.1)) < 1.0  # no client yet
    with TcpClientTransport(url_of(server)) as client:
        assert 0.08 <= elapsed(lambda: client.read(0.1)) < 1.0
        assert 0.08 <= elapsed(lambda: server.read(0.1)) < 1.0  # accepted, but silent


def test_server_discards_while_nobody_listens_and_takes_the_next_client(server: TcpServerTransport) -> None:
    server.write(b"lost")
    assert server.bytes_discarded == 4
    with TcpClientTransport(url_of(server)) as first:
        server.write(b"1st")
        assert read_exactly(first.read, 3) == b"1st"
    assert read_exactly(server.read, 1, timeout=0.3) == b""  # sees the client leave
    assert not server.connected
    with TcpClientTransport(url_of(server)) as second:
        server.write(b"2nd")
        assert read_exactly(second.read, 3) == b"2nd"
        with TcpClientTransport(url_of(server)) as third:  # refused while the second is live
            assert read_exactly(server.read, 1, timeout=0.3) == b""
            server.write(b"more")
            assert read_exactly(second.read, 4) == b"more"
            with pytest.raises(TransportOperationError, match="closed by the peer"):
                read_exactly(third.read, 1, timeout=1.0)
    assert server.clients == 2 and server.refused == 1


def test_client_errors_and_reconnect(server: TcpServerTransport) -> None:
    with pytest.raises(TransportInitError, match="cannot connect"):
        TcpClientTransport(f"tcp://127.0.0.1:{free_tcp_port()}?timeout=1").open()
    with TcpClientTransport(url_of(server)) as client:
        server.wait_for_client(2.0)
        server._drop_client()
        with pytest.raises(TransportOperationError, match="closed by the peer"):
            read_exactly(client.read, 1)
        client.reconnect(attempts=3, delay=0.05)
        assert server.wait_for_client(2.0) and client.reconnects == 1
        server.write(b"again")
        assert read_exactly(client.read, 5) == b"again"


def test_client_auto_reconnect(server: TcpServerTransport) -> None:
    with TcpClientTransport(url_of(server, query="?reconnect=1&timeout=1")) as client:
        server.wait_for_client(2.0)
        server._drop_client()
        assert read_exactly(client.read, 1, timeout=0.3) == b""  # no exception: it retries
        assert server.wait_for_client(2.0)
        server.write(b"back")
        assert read_exactly(client.read, 4) == b"back"
        assert client.reconnects >= 1


def test_server_port_in_use() -> None:
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as first:
        busy = TcpServerTransport(url_of(first, "tcp-listen"))
        with pytest.raises(TransportInitError, match="cannot listen"):
            busy.open()


def test_writer_thread_and_reader(server: TcpServerTransport) -> None:
    """A writer thread (the sonar) and a reader (the driver) at once: nothing lost or reordered."""
    blocks = [bytes([i]) * 4096 for i in range(64)]
    with TcpClientTransport(url_of(server)) as client:
        server.wait_for_client(2.0)

        def send_all() -> None:
            for block in blocks:
                server.write(block)

        writer = threading.Thread(target=send_all)
        writer.start()
        got = read_exactly(client.read, 64 * 4096, timeout=5.0)
        writer.join()
    assert got == b"".join(blocks)


# -- CAN -------------------------------------------------------------------------------------
def can_frames() -> Any:
    return pytest.importorskip("auvlink.framing.can_frames", reason="can_frames not written yet")


def test_can_virtual_read_gives_concatenated_frames() -> None:
    cf = can_frames()
    with VirtualCanChannel() as chan, CanTransport(chan.url()) as port:
        node = chan.bus()
        sent = [can.Message(arbitration_id=0x100 + i, is_extended_id=i % 3 == 0, data=bytes(range(i % 9)))
                for i in range(40)]
        for msg in sent:
            node.send(msg)
        stream = read_exactly(port.read, 40 * cf.FRAME_SIZE)
        frames = [stream[i:i + cf.FRAME_SIZE] for i in range(0, len(stream), cf.FRAME_SIZE)]
        assert len(frames) == 40 and port.messages_read == 40
        for raw, msg in zip(frames, sent, strict=True):
            back = cf.frame_to_message(raw)
            assert (back.arbitration_id, back.is_extended_id, bytes(back.data)) == (
                msg.arbitration_id, msg.is_extended_id, bytes(msg.data))


def test_can_virtual_write_in_odd_chunks() -> None:
    cf = can_frames()
    with VirtualCanChannel() as chan, CanTransport(chan.url()) as port:
        node = chan.bus()
        sent = [can.Message(arbitration_id=0x200 + i, is_extended_id=False, data=bytes([i, 255 - i]))
                for i in range(10)]
        stream = b"".join(cf.message_to_frame(m) for m in sent)
        for cut in range(0, len(stream), 7):  # 7-byte writes: frames straddle the writes
            port.write(stream[cut:cut + 7])
        got = [node.recv(1.0) for _ in sent]
        assert [(g.arbitration_id, bytes(g.data)) for g in got if g] == [
            (m.arbitration_id, bytes(m.data)) for m in sent]
        assert port.messages_written == 10 and port.bytes_written == len(stream)


def test_can_errors() -> None:
    with pytest.raises(TransportInitError, match="no_such_interface"):
        CanTransport("can://no_such_interface/x").open()
    with pytest.raises(TransportInitError):
        CanTransport("can://socketcan/auvlink_none0").open()


def vcan_available() -> str:
    """'' when SocketCAN's vcan0 is usable here, else the reason it is not."""
    if not hasattr(socket, "AF_CAN"):
        return "this Python has no AF_CAN sockets"
    if not os.path.exists("/sys/class/net/vcan0"):
        return ("no vcan0 interface: the kernel lacks the vcan module or nobody ran "
                "`ip link add dev vcan0 type vcan && ip link set up vcan0`")
    return ""


@pytest.mark.skipif(bool(vcan_available()), reason=vcan_available() or "vcan0 present")
def test_socketcan_vcan0_round_trip() -> None:
    cf = can_frames()
    with CanTransport("can://socketcan/vcan0") as port:
        other = can.Bus(interface="socketcan", channel="vcan0")
        try:
            other.send(can.Message(arbitration_id=0x321, is_extended_id=False, data=b"\x01\x02"))
            raw = read_exactly(port.read, cf.FRAME_SIZE)
            assert cf.frame_to_message(raw).arbitration_id == 0x321
        finally:
            other.shutdown()
