"""Virtual ports: pty pairs, virtual CAN channels, the slcan adapter emulator, free TCP ports."""

from __future__ import annotations

import os
import socket
import time
from pathlib import Path

import can
import pytest
from can.interfaces.slcan import slcanBus
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.errors import DecodeError, TransportInitError, TransportOperationError, TransportTimeoutError
from auvlink.transports.base import open_transport
from auvlink.transports.serial_port import SerialTransport
from auvlink.virtual import PtyPair, PtyTransport, VirtualCanChannel, free_tcp_port
from auvlink.virtual_slcan import SlcanAdapter, decode_slcan, encode_slcan

pytestmark = pytest.mark.usefixtures("no_leaked_fds", "no_leaked_can_buses")

ALL_BYTES = bytes(range(256)) + b"\r\n\r\x03\x04\x11\x13\x1a\x7f"  # CR/LF, ^C ^D ^Q ^S ^Z DEL


def read_exactly(read: object, n: int, timeout: float = 2.0) -> bytes:
    """Call ``read(timeout=...)`` until ``n`` bytes came or ``timeout`` passed."""
    out = bytearray()
    end = time.monotonic() + timeout
    while len(out) < n and time.monotonic() < end:
        out += read(timeout=0.05)  # type: ignore[operator]
    return bytes(out)


# -- PtyPair ---------------------------------------------------------------------------------
def test_pty_pair_is_raw_both_ways() -> None:
    with PtyPair() as pty, SerialTransport(pty.device_path) as port:
        assert os.path.realpath(pty.device_path).startswith("/dev/pts/")
        pty.write(ALL_BYTES)
        assert read_exactly(port.read, len(ALL_BYTES)) == ALL_BYTES  # no CR/LF translation
        port.write(ALL_BYTES[::-1])
        assert read_exactly(pty.read, len(ALL_BYTES)) == ALL_BYTES[::-1]
        assert pty.read(timeout=0.05) == b""  # and no echo of what the master wrote
        assert pty.in_waiting == 0


def test_pty_pair_link_names_the_slave(tmp_path: Path) -> None:
    link = tmp_path / "dev" / "fog"
    with PtyPair(link) as pty:
        assert pty.device_path == str(link)
        assert os.path.realpath(link) == pty.slave_name
        with SerialTransport(f"serial://{link}?baudrate=115200") as port:
            pty.write(b"$PING\r\n")
            assert read_exactly(port.read, 7) == b"$PING\r\n"
    assert not link.exists() and not link.is_symlink()


def test_pty_pair_refuses_to_replace_a_file(tmp_path: Path) -> None:
    path = tmp_path / "precious"
    path.write_text("keep me")
    with pytest.raises(TransportInitError, match="not a symlink"):
        PtyPair(path).open()
    assert path.read_text() == "keep me"


def test_driver_survives_reopen_and_sees_device_gone() -> None:
    with PtyPair() as pty:
        with SerialTransport(pty.device_path) as port:
            pty.write(b"one")
            assert read_exactly(port.read, 3) == b"one"
        with SerialTransport(pty.device_path) as port:  # reopened: the line is still there
            pty.write(b"two")
            assert read_exactly(port.read, 3) == b"two"
            pty.close()  # the instrument is unplugged
            with pytest.raises(TransportOperationError):
                for _ in range(20):
                    port.read(timeout=0.05)


def test_pty_write_timeout_and_lossy_mode() -> None:
    with PtyPair(write_timeout=0.2) as pty:  # nobody reads the slave
        start = time.monotonic()
        with pytest.raises(TransportTimeoutError, match="nobody read"):
            pty.write(bytes(1 << 20))
        assert time.monotonic() - start < 2.0
    with PtyPair(lossy=True) as pty:
        delivered = pty.write(bytes(1 << 20))
        assert 0 < delivered < 1 << 20
        assert pty.bytes_discarded == (1 << 20) - delivered


def test_pty_transport_by_url(tmp_path: Path) -> None:
    link = tmp_path / "dvl"
    with open_transport(f"pty://{link}?lossy=1") as device:
        assert isinstance(device, PtyTransport)
        assert device.device_path == str(link)
        with open_transport(str(link)) as port:
            device.write(b"\x7f\x7fensemble")
            assert read_exactly(port.read, 10) == b"\x7f\x7fensemble"
            port.write(b"CS\r")
            assert read_exactly(device.read, 3) == b"CS\r"
    assert not link.is_symlink()
    with PtyPair() as pty:  # a borrowed pair stays open when its transport closes
        with pty.transport() as device:
            device.write(b"x")
        assert pty.is_open and pty.read(timeout=0.01) == b""


# -- virtual CAN, free ports -----------------------------------------------------------------
def test_virtual_can_channel_is_private_and_closes_its_buses() -> None:
    with VirtualCanChannel() as one, VirtualCanChannel() as two:
        assert one.name != two.name
        assert one.url() == f"can://virtual/{one.name}"
        assert one.url(receive_own_messages=1).endswith("?receive_own_messages=1")
        a, b, c = one.bus(), one.bus(), two.bus()
        a.send(can.Message(arbitration_id=0x10, data=b"\x01"))
        got = b.recv(1.0)
        assert got is not None and bytes(got.data) == b"\x01"
        assert c.recv(0.05) is None
    assert a._is_shutdown and b._is_shutdown and c._is_shutdown


def test_free_tcp_port_is_bindable() -> None:
    port = free_tcp_port()
    assert 1024 <= port <= 65535
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", port))


# -- slcan lines -----------------------------------------------------------------------------
def test_slcan_lines_match_the_lawicel_examples() -> None:
    std = can.Message(arbitration_id=0x123, is_extended_id=False, data=b"\x11\x22\x33")
    assert encode_slcan(std) == b"t1233112233\r"
    ext = can.Message(arbitration_id=0x12ABCDEF, is_extended_id=True, data=b"\xaa\x55")
    assert encode_slcan(ext) == b"T12ABCDEF2AA55\r"
    rtr = can.Message(arbitration_id=0x7FF, is_extended_id=False, is_remote_frame=True, dlc=4)
    assert encode_slcan(rtr) == b"r7FF4\r"
    assert encode_slcan(std, timestamp_ms=61_234) == b"t123311223304D2\r"  # wraps at 60 s
    back = decode_slcan("T12ABCDEF2AA55")
    assert (back.arbitration_id, back.is_extended_id, bytes(back.data)) == (0x12ABCDEF, True, b"\xaa\x55")


@pytest.mark.parametrize("line", ["t12", "t1239", "t1232AA", "t8001AA", "T2000000010", "x", "tGGG0"])
def test_slcan_bad_lines_raise(line: str) -> None:
    with pytest.raises(DecodeError):
        decode_slcan(line)


@st.composite
def messages(draw: st.DrawFn) -> can.Message:
    extended = draw(st.booleans())
    ident = draw(st.integers(0, (1 << (29 if extended else 11)) - 1))
    kind = draw(st.sampled_from(["data", "remote", "fd", "fd_brs"]))
    if kind == "remote":
        return can.Message(arbitration_id=ident, is_extended_id=extended, is_remote_frame=True,
                           dlc=draw(st.integers(0, 8)))
    sizes = [0, 1, 2, 3, 4, 5, 6, 7, 8] + ([12, 16, 20, 24, 32, 48, 64] if kind != "data" else [])
    size = draw(st.sampled_from(sizes))
    data = draw(st.binary(min_size=size, max_size=size))
    return can.Message(arbitration_id=ident, is_extended_id=extended, data=data,
                       is_fd=kind != "data", bitrate_switch=kind == "fd_brs")


@given(messages())
@settings(max_examples=300, deadline=None)
def test_slcan_round_trip(msg: can.Message) -> None:
    line = encode_slcan(msg)
    assert line.endswith(b"\r") and line.count(b"\r") == 1
    back = decode_slcan(line[:-1].decode())
    assert back.equals(msg, timestamp_delta=None)


# -- the adapter, seen by python-can's own slcan interface ---------------------------------
def test_python_can_slcan_host_talks_to_the_adapter() -> None:
    with SlcanAdapter(serial_number="AUV42") as adapter:
        host = slcanBus(channel=adapter.device_path, bitrate=125_000, sleep_after_open=0)
        try:
            assert host.get_version(1.0) == (10, 13)
            assert host.get_serial_number(1.0) == "AUV42"
            adapter.wait_open(1.0)
            assert adapter.bitrate == 125_000 and not adapter.listen_only
            sent = [can.Message(arbitration_id=0x100 + i, is_extended_id=i % 2 == 1,
                                data=bytes([i] * (i % 9))) for i in range(20)]
            for msg in sent:
                adapter.send(msg)
            got = [host.recv(1.0) for _ in sent]
            pairs = zip(got, sent, strict=True)
            assert all(g is not None and g.equals(m, timestamp_delta=None) for g, m in pairs)
            out = can.Message(arbitration_id=0x1ABCDE, is_extended_id=True, data=b"\x01\x02\x03\x04\x05")
            host.send(out)
            back = adapter.recv(1.0)
            assert back is not None and back.equals(out, timestamp_delta=None)
            assert encode_slcan(out)[:-1].decode() in adapter.commands  # python-can wrote our line
        finally:
            host.shutdown()
        deadline = time.monotonic() + 1.0
        while adapter.is_open and time.monotonic() < deadline:
            time.sleep(0.01)
        assert not adapter.is_open  # shutdown sent "C"
        assert adapter.commands[:4] == ["C", "S4", "", "O"]
        assert (adapter.to_host, adapter.from_host) == (20, 1)


def test_adapter_conversation_byte_by_byte() -> None:
    """The Lawicel replies, checked on the raw serial line: CR for ok, BEL for error."""
    script = [
        (b"t1232AABB", b"\a"),  # transmit while closed
        (b"S9", b"\r"), (b"S42", b"\a"), (b"O", b"\r"), (b"O", b"\a"), (b"S6", b"\a"),
        (b"t1232AABB", b"z\r"), (b"T000001232AABB", b"Z\r"), (b"r1230", b"z\r"),
        (b"t1232AA", b"\a"), (b"F", b"F00\r"), (b"V", b"V1013\r"), (b"N", b"NA001\r"),
        (b"Q", b"\a"), (b"C", b"\r"), (b"C", b"\a"), (b"L", b"\r"), (b"t1230", b"\a"), (b"", b"\r"),
    ]
    with SlcanAdapter() as adapter, SerialTransport(adapter.device_path) as line:
        for command, reply in script:
            line.write(command + b"\r")
            assert read_exactly(line.read, len(reply), timeout=1.0) == reply, command
        assert adapter.bitrate == 83_300 and adapter.listen_only and adapter.from_host == 3
        assert adapter.errors == sum(reply == b"\a" for _, reply in script)
        got = [adapter.recv(0.1) for _ in range(3)]
        assert [m.arbitration_id for m in got if m is not None] == [0x123, 0x123, 0x123]


def test_adapter_drops_frames_until_opened_and_stamps_time() -> None:
    with SlcanAdapter() as adapter, SerialTransport(adapter.device_path) as line:
        adapter.send(can.Message(arbitration_id=0x1, is_extended_id=False))
        assert adapter.dropped == 1
        line.write(b"Z1\rO\r")
        assert read_exactly(line.read, 2, timeout=1.0) == b"\r\r"
        adapter.wait_open(1.0)
        adapter.send(can.Message(arbitration_id=0x2, is_extended_id=False, data=b"\x09"))
        reply = read_exactly(line.read, 12, timeout=1.0)
        assert reply[:7] == b"t002109" and reply[-1:] == b"\r" and len(reply) == 12
        int(reply[7:11], 16)  # four hex digits of milliseconds
    with SlcanAdapter() as adapter, pytest.raises(TransportTimeoutError):
        adapter.wait_open(0.05)
