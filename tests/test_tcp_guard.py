"""A TCP server port is not a way in: no implicit all-interfaces bind, one client, intruders refused and
logged as port events (real sockets on 127.0.0.1)."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest

from auvlink.driver import Driver
from auvlink.errors import TransportInitError, TransportOperationError
from auvlink.pipeline.ports import PortReader
from auvlink.records import Sample
from auvlink.transports.tcp import TcpClientTransport, TcpServerTransport

PD6_LINE = b":SA,  +2.50,  -1.25, 270.00\r\n"


def _until(cond: Callable[[], bool], timeout: float = 3.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.02)
    return cond()


def _pump(server: TcpServerTransport, seconds: float) -> bytes:
    out = bytearray()
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        out += server.read(0.05)
    return bytes(out)


@pytest.mark.parametrize("url", ["tcp-listen://:5000", "tcp://:5000"])
def test_an_empty_host_is_an_error_that_names_the_fix(url: str) -> None:
    scheme = url.split("://")[0]
    cls = TcpServerTransport if scheme == "tcp-listen" else TcpClientTransport
    with pytest.raises(TransportInitError, match=f"{scheme}://0.0.0.0:5000 to mean every interface"):
        cls(url)


def test_unknown_and_bad_options_are_errors() -> None:
    with pytest.raises(TransportInitError, match=r"'takeovr'.*allowed: takeover"):
        TcpServerTransport("tcp-listen://127.0.0.1:0?takeovr=1")
    with pytest.raises(TransportInitError, match="must be 0 or 1"):
        TcpServerTransport("tcp-listen://127.0.0.1:0?takeover=maybe")
    with pytest.raises(TransportInitError, match="allowed: timeout, reconnect"):
        TcpClientTransport("tcp://127.0.0.1:1?retry=1")


def test_explicit_all_interfaces_still_binds() -> None:
    with TcpServerTransport("tcp-listen://0.0.0.0:0") as server:
        assert server.address[0] == "0.0.0.0"


def test_a_second_client_is_refused_and_noted() -> None:
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as server:
        host, port = server.address
        with socket.create_connection((host, port)) as instrument:
            assert server.wait_for_client(2.0)
            first = server.take_events()
            assert [e["kind"] for e in first] == ["client_connected"]
            assert first[0]["peer"] == _name(instrument)
            with socket.create_connection((host, port)) as intruder:
                intruder.sendall(b"intruder bytes")
                instrument.sendall(b"instrument bytes")
                got = _pump(server, 0.5)
                assert got == b"instrument bytes"  # nothing of the intruder's
                assert _closed_at_once(intruder)
                intruder_peer = _name(intruder)
            events = server.take_events()
            refused = [e for e in events if e["kind"] == "connection_refused"]
            assert len(refused) == 1 and server.refused == 1 and server.clients == 1
            assert refused[0]["peer"] == intruder_peer
            assert refused[0]["serving"] == first[0]["peer"] and "takeover=1" in refused[0]["reason"]
            instrument.sendall(b"still mine")
            assert _pump(server, 0.3) == b"still mine"


def _name(sock: socket.socket) -> str:
    host, port = sock.getsockname()[:2]
    return f"{host}:{port}"


def _closed_at_once(sock: socket.socket) -> bool:
    """Whether the server closed ``sock``: it reads end of stream or a reset."""
    sock.settimeout(2.0)
    try:
        return sock.recv(10) == b""
    except ConnectionResetError:
        return True


def test_takeover_option_lets_a_new_client_replace_the_old() -> None:
    with TcpServerTransport("tcp-listen://127.0.0.1:0?takeover=1") as server:
        host, port = server.address
        with TcpClientTransport(f"tcp://{host}:{port}") as old:
            assert server.wait_for_client(2.0)
            with TcpClientTransport(f"tcp://{host}:{port}") as new:
                assert _pump(server, 0.3) == b""
                server.write(b"to the new one")
                got = bytearray()

                def arrived() -> bool:
                    got.extend(new.read(0.05))
                    return bytes(got) == b"to the new one"

                assert _until(arrived)
                with pytest.raises(TransportOperationError, match="closed by the peer"):
                    _until(lambda: bool(old.read(0.05)), 1.0)
        kinds = [e["kind"] for e in server.take_events()]
        assert "connection_taken_over" in kinds and server.refused == 0 and server.clients == 2


def test_a_client_that_left_is_replaced_without_takeover() -> None:
    with TcpServerTransport("tcp-listen://127.0.0.1:0") as server:
        host, port = server.address
        first = socket.create_connection((host, port))
        assert server.wait_for_client(2.0)
        first.close()  # gone, but the server has not read since
        with socket.create_connection((host, port)) as second:
            second.sendall(b"hello")
            assert _pump(server, 0.4) == b"hello"
        kinds = [e["kind"] for e in server.take_events()]
        assert kinds[:3] == ["client_connected", "client_left", "client_connected"] and server.refused == 0


def test_live_port_reader_logs_the_refusal_as_a_port_event() -> None:
    """End to end: a PD6 device on tcp-listen; an intruder's lines never reach the samples; the refusal
    is an event of that device."""
    events: list[dict[str, Any]] = []
    samples: list[Sample] = []
    stop = threading.Event()
    driver = Driver("dvl", "pd6", "tcp-listen://127.0.0.1:0").open()
    reader = PortReader(driver, samples.append, stop, on_event=events.append, opened=True, silence_s=60).start()
    try:
        assert isinstance(driver.transport, TcpServerTransport)
        host, port = driver.transport.address
        with socket.create_connection((host, port)) as instrument:
            instrument.sendall(PD6_LINE)
            assert _until(lambda: len(samples) == 1)
            with socket.create_connection((host, port)) as intruder:
                assert _until(lambda: any(e["kind"] == "connection_refused" for e in events))
                try:
                    intruder.sendall(b":SA,  +9.99,  +9.99, 999.99\r\n" * 10)
                except OSError:
                    pass
                instrument.sendall(PD6_LINE)
                assert _until(lambda: len(samples) == 2)
                time.sleep(0.2)
    finally:
        stop.set()
        reader.join(2.0)
    assert all(s.raw == PD6_LINE for s in samples) and len(samples) == 2
    refused = [e for e in events if e["kind"] == "connection_refused"]
    assert len(refused) == 1 and refused[0]["device"] == "dvl" and isinstance(refused[0]["t_ns"], int)
    assert [e["kind"] for e in events].count("client_connected") == 1
