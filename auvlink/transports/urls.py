"""Check a transport URL without opening it (what the vehicle configuration does for every device).

Serial URLs (device paths and pyserial handlers such as ``loop://``) and ``can://`` URLs are parsed by
their transports' own parsers, so a key nothing reads (``loop://?frob=1``) or a rate that is not a
number (``?bitrate=fast``) is a :class:`~auvlink.errors.ConfigError` naming the key, at load time.
"""

from __future__ import annotations

from urllib.parse import urlsplit

from auvlink.errors import ConfigError, TransportInitError
from auvlink.transports.base import transport_class
from auvlink.transports.can_bus import parse_can_url
from auvlink.transports.serial_port import parse_serial_url

_SERIAL = ("serial", "loop", "socket", "rfc2217", "spy", "hwgrep", "alt")


def check_url(url: str) -> None:
    """Raise :class:`ConfigError` (key ``url``) when ``url``'s scheme or query keys are wrong."""
    scheme = urlsplit(url).scheme if "://" in url else "serial"
    try:
        if scheme in _SERIAL:
            parse_serial_url(url)
        elif scheme == "can":
            parse_can_url(url)
        else:
            transport_class(url)
    except TransportInitError as exc:
        raise ConfigError("url", str(exc), "see the transport's URL forms in the README") from exc
