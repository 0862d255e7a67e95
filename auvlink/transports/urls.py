"""Check a transport URL without opening it (what the vehicle configuration does for every device).

Serial URLs (device paths and pyserial handlers such as ``loop://``) and ``can://`` URLs are parsed by
their transports' own parsers, so a key nothing reads (``loop://?frob=1``) or a rate that is not a
number (``?bitrate=fast``) is a :class:`~auvlink.errors.ConfigError` naming the key, at load time.
TCP URLs name a host and a port in 1-65535 (``tcp-listen`` may ask for port 0: any free port), and a
serial ``baudrate`` lies in 1 to :data:`MAX_BAUDRATE`.
"""

from __future__ import annotations

from urllib.parse import urlsplit

from auvlink.errors import ConfigError, TransportInitError
from auvlink.transports.base import transport_class
from auvlink.transports.can_bus import parse_can_url
from auvlink.transports.serial_port import parse_serial_url
from auvlink.transports.tcp import parse_address

_SERIAL = ("serial", "loop", "socket", "rfc2217", "spy", "hwgrep", "alt")
#: fastest UART rate a vehicle port could run: 12 Mbaud (FTDI FT232H data sheet, the fastest common USB UART)
MAX_BAUDRATE = 12_000_000
#: TCP port numbers (RFC 793: 16 bits; 0 only for a server, meaning any free port)
MAX_PORT = 65_535


def check_url(url: str) -> None:
    """Raise :class:`ConfigError` (key ``url``) when ``url``'s scheme or query keys are wrong."""
    try:
        scheme = urlsplit(url).scheme if "://" in url else "serial"
        if scheme in _SERIAL:
            _check_baudrate(url, parse_serial_url(url)[1].get("baudrate"))
        elif scheme == "can":
            parse_can_url(url)
        else:
            transport_class(url)
            if scheme in ("tcp", "tcp-listen"):
                _check_port(url, scheme, parse_address(url)[1])
    except ValueError as exc:  # urlsplit: an unclosed IPv6 bracket
        raise ConfigError("url", f"cannot parse {url!r}: {exc}", "write SCHEME://HOST:PORT or a device path") from exc
    except TransportInitError as exc:
        raise ConfigError("url", str(exc), "see the transport's URL forms in the README") from exc


def _check_baudrate(url: str, baudrate: int | None) -> None:
    if baudrate is not None and not 1 <= baudrate <= MAX_BAUDRATE:
        raise TransportInitError(f"baudrate {baudrate} in {url!r} is out of range (use 1 to {MAX_BAUDRATE} baud)")


def _check_port(url: str, scheme: str, port: int) -> None:
    low = 0 if scheme == "tcp-listen" else 1
    if not low <= port <= MAX_PORT:
        raise TransportInitError(f"port {port} in {url!r} is out of range (use {low} to {MAX_PORT})")
