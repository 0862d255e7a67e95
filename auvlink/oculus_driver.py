"""Driver of a Blueprint Oculus sonar: connects to its data port, commands it with SimpleFire, keeps it pinging.

The sonar pings only while a client commands it: the driver sends a SimpleFire message (msg 0x15,
:mod:`auvlink.codecs.oculus`) when the transport opens and again every :attr:`OculusSettings.keepalive_s`
seconds (checked on each read), and reads the SimplePingResult messages the sonar answers with like any
other device (:class:`~auvlink.driver.Driver`: framer, codec, counters, listeners). The data port is TCP
52100 (liboculus ``Constants.h``); a device is declared in the vehicle config as

.. code-block:: toml

    [[devices]]
    name = "sonar"
    format = "oculus"
    url = "tcp://192.168.2.3:52100?reconnect=1"
    options = { range_m = 10.0, gain_percent = 50.0, freq_mode = 2, ping_rate = 2 }

Settings are the SimpleFire fields: range demand (m), gain (%), frequency mode (1 = low, 2 = high),
``PingRateType`` code (0 10 Hz, 1 15 Hz, 2 40 Hz, 3 5 Hz, 4 2 Hz, 5 standby), sample size (8/16 bits
with a V1 fire message; 32 bits asks with a V2 fire message and ``extFlags`` 0x200), a gain per range line.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

from auvlink.codecs.oculus import encode
from auvlink.codecs.oculus_messages import OculusFire, OculusFireCommand, OculusHeader
from auvlink.driver import Driver
from auvlink.errors import ConfigError, TransportOperationError
from auvlink.framing import oculus_defs as d
from auvlink.records import Sample
from auvlink.transports.base import Transport

#: seconds between SimpleFire messages: Oculus.h and liboculus publish no keep-alive interval (the sonar
#: pings while it is commanded); 1 s keeps the command fresh at the slowest ping rate (2 Hz) and costs 89 B/s
KEEPALIVE_S = 1.0
_PING_RATES = range(6)  # PingRateType codes of Oculus.h
_DATA_BITS = (8, 16, 32)


@dataclass(frozen=True)
class OculusSettings:
    """What the driver asks the sonar for (the vehicle config's ``options`` of an ``oculus`` device)."""

    range_m: float = 10.0
    gain_percent: float = 50.0
    freq_mode: int = d.FREQ_MODE_HIGH
    ping_rate: int = 0
    data_bits: int = 8
    send_gain: bool = False
    speed_of_sound_mps: float = 0.0  # 0: the sonar computes it from salinity_ppt
    salinity_ppt: float = 0.0
    keepalive_s: float = KEEPALIVE_S

    def __post_init__(self) -> None:
        for f in fields(self):
            if not isinstance(getattr(self, f.name), int | float):
                raise ConfigError(f"options.{f.name}", f"bad value {getattr(self, f.name)!r}", "a number")
        checks = {
            "range_m": (math.isfinite(self.range_m) and self.range_m > 0, "a range demand > 0 m"),
            "gain_percent": (0 <= self.gain_percent <= 100, "a gain in [0, 100] %"),
            "freq_mode": (self.freq_mode in (d.FREQ_MODE_LOW, d.FREQ_MODE_HIGH), "1 (low) or 2 (high)"),
            "ping_rate": (self.ping_rate in _PING_RATES, "a PingRateType code 0..5"),
            "data_bits": (self.data_bits in _DATA_BITS, "8, 16 or 32"),
            "speed_of_sound_mps": (self.speed_of_sound_mps == 0 or 1400 <= self.speed_of_sound_mps <= 1600,
                                   "0 (the sonar's own) or 1400..1600 m/s"),
            "salinity_ppt": (0 <= self.salinity_ppt <= 50, "0..50 ppt"),
            "keepalive_s": (0 < self.keepalive_s <= 60, "0 < s <= 60"),
        }
        for key, (ok, fix) in checks.items():
            if not ok:
                raise ConfigError(f"options.{key}", f"bad value {getattr(self, key)!r}", fix)

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> OculusSettings:
        """Settings from a device's ``options`` (unknown keys: :class:`ConfigError`)."""
        allowed = {f.name for f in fields(cls)}
        for key in options:
            if key not in allowed:
                raise ConfigError(f"options.{key}", "unknown option of format 'oculus'",
                                  f"allowed here: {', '.join(sorted(allowed))}")
        return cls(**dict(options))

    def fire_command(self) -> OculusFireCommand:
        """The SimpleFire message these settings send (V2 for 32-bit samples, else V1)."""
        flags = d.FLAG_RANGE_AS_METERS | d.FLAG_SIMPLE_RETURN
        flags |= d.FLAG_DATA_16BIT if self.data_bits == 16 else 0
        flags |= d.FLAG_SEND_GAIN if self.send_gain else 0
        fire = OculusFire(master_mode=int(self.freq_mode), ping_rate=int(self.ping_rate), flags=flags,
                          range=float(self.range_m), gain_percent=float(self.gain_percent),
                          speed_of_sound_mps=float(self.speed_of_sound_mps), salinity_ppt=float(self.salinity_ppt),
                          ext_flags=d.EXT_FLAG_DATA_32BIT if self.data_bits == 32 else 0)
        return OculusFireCommand(OculusHeader(msg_version=2 if self.data_bits == 32 else 1), fire)


#: option names an ``oculus`` device accepts in the vehicle config
OPTIONS = frozenset(f.name for f in fields(OculusSettings))


class OculusDriver(Driver):
    """A :class:`Driver` that commands the sonar (SimpleFire on open, then every ``keepalive_s``)."""

    def __init__(self, name: str, transport: str | Transport, settings: OculusSettings | None = None) -> None:
        super().__init__(name, "oculus", transport)
        self.settings = settings or OculusSettings()
        self._fire_bytes = encode(self.settings.fire_command())
        self._next_fire = 0.0
        self.fires_sent = 0

    def open(self) -> OculusDriver:
        super().open()
        self.fire()
        return self

    def __enter__(self) -> OculusDriver:
        return self.open()

    def fire(self) -> None:
        """Send the SimpleFire message now (a connection that went is retried at the next keep-alive)."""
        self._next_fire = time.monotonic() + self.settings.keepalive_s
        try:
            self.transport.write(self._fire_bytes)
        except TransportOperationError:
            return
        self.fires_sent += 1

    def read(self, timeout: float | None = 0.1) -> list[Sample]:
        """Re-send SimpleFire when the keep-alive is due, then read as every driver does."""
        if time.monotonic() >= self._next_fire:
            self.fire()
        if timeout is not None:
            timeout = max(0.0, min(timeout, self._next_fire - time.monotonic()))
        return super().read(timeout)

    def describe(self) -> dict[str, Any]:
        return {**super().describe(), "fires_sent": self.fires_sent}


def driver_for_device(name: str, fmt: str, url: str, options: Mapping[str, Any] | None = None) -> Driver:
    """The driver of one configured device: an :class:`OculusDriver` for ``oculus`` (it must command the
    sonar to get pings, with ``options`` as :class:`OculusSettings`), a plain :class:`Driver` otherwise."""
    if fmt == "oculus":
        return OculusDriver(name, url, OculusSettings.from_options(options or {}))
    return Driver(name, fmt, url)
