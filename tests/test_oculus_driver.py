"""Oculus driver against a fake sonar on 127.0.0.1: SimpleFire in, pings built by the encoder out."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pytest

from auvlink.codecs import oculus
from auvlink.codecs.oculus_messages import OculusFireCommand, OculusHeader
from auvlink.config import loads_config
from auvlink.driver import Driver
from auvlink.errors import ConfigError
from auvlink.framing.oculus import OculusFramer
from auvlink.framing.oculus_defs import FLAG_SEND_GAIN
from auvlink.oculus_driver import OculusDriver, OculusSettings, driver_for_device


def _ping_for(cmd: OculusFireCommand, ping_id: int) -> bytes:
    """What a sonar answers: a ping obeying the fire message (range lines from the range demand)."""
    fire = cmd.fire
    bits = 32 if fire.ext_flags & 0x200 else 16 if fire.flags & 0x02 else 8
    rows, beams = max(1, round(fire.range / 0.05)), 32
    image = (np.arange(rows * beams) % 251).astype(f"u{bits // 8}").reshape(rows, beams)
    gain = np.full(rows, 1.5, np.float32) if fire.flags & FLAG_SEND_GAIN else None
    return oculus.encode(oculus.OculusPing(
        header=OculusHeader(7892, 0, cmd.header.msg_version, 0), fire=fire, ping_id=ping_id, status=0,
        frequency_hz=2.1e6 if fire.master_mode == 2 else 1.2e6, temperature_c=10.0, pressure_bar=1.0,
        speed_of_sound_mps=1500.0, ping_start_time=0.0, range_resolution_m=0.05,
        bearings_rad=np.radians(np.linspace(-65.0, 65.0, beams)), image=image, row_gain=gain))


@contextmanager
def fake_sonar() -> Iterator[tuple[int, list[OculusFireCommand]]]:
    """A TCP server that answers each SimpleFire with one ping; yields (port, fire messages received)."""
    server = socket.create_server(("127.0.0.1", 0))
    fires: list[OculusFireCommand] = []
    stop = threading.Event()

    def serve() -> None:
        conn, _ = server.accept()
        framer = OculusFramer()
        with conn:
            conn.settimeout(0.05)
            while not stop.is_set():
                try:
                    data = conn.recv(4096)
                except TimeoutError:
                    continue
                if not data:
                    return
                for raw in framer.feed(data):
                    cmd = oculus.decode(raw)
                    if isinstance(cmd, OculusFireCommand):
                        fires.append(cmd)
                        conn.sendall(_ping_for(cmd, len(fires)))

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1], fires
    finally:
        stop.set()
        thread.join(5.0)
        server.close()


@pytest.mark.live
@pytest.mark.parametrize("bits", [8, 16, 32])
def test_driver_fires_keeps_alive_and_reports_pings(bits: int) -> None:
    settings = OculusSettings(range_m=3.0, gain_percent=40.0, freq_mode=1, ping_rate=2, data_bits=bits,
                              send_gain=bits == 16, keepalive_s=0.2)
    with fake_sonar() as (port, fires), OculusDriver("sonar", f"tcp://127.0.0.1:{port}", settings) as drv:
        pings = [s.record for s in drv.samples(duration=0.75, timeout=0.05)]
    assert 3 <= len(fires) <= 6  # on open, then every 0.2 s (the last may be in flight at the end)
    assert drv.fires_sent - len(fires) in (0, 1)
    first = fires[0].fire
    assert (first.range, first.gain_percent, first.master_mode, first.ping_rate) == (3.0, 40.0, 1, 2)
    assert fires[0].header.msg_version == (2 if bits == 32 else 1)
    assert [p.ping_id for p in pings] == list(range(1, len(pings) + 1)) and len(pings) >= len(fires) - 1
    assert all(p.image.shape == (60, 32) and p.image.dtype.itemsize * 8 == bits for p in pings)
    assert (pings[0].row_gain is not None) == (bits == 16)
    assert drv.describe()["fires_sent"] == drv.fires_sent


def test_settings_are_checked_and_come_from_the_vehicle_config() -> None:
    with pytest.raises(ConfigError, match="freq_mode"):
        OculusSettings(freq_mode=3)
    with pytest.raises(ConfigError, match=r"range_m.*a number"):
        OculusSettings.from_options({"range_m": "far"})
    with pytest.raises(ConfigError, match="rnage_m"):
        OculusSettings.from_options({"rnage_m": 5.0})
    config = loads_config('[[devices]]\nname = "sonar"\nformat = "oculus"\nurl = "tcp://127.0.0.1:52100"\n'
                          'options = { range_m = 5.0, freq_mode = 1 }\n')
    with pytest.raises(ConfigError, match=r"devices\[0\]\.options\.gain_percent"):
        loads_config('[[devices]]\nname = "sonar"\nformat = "oculus"\nurl = "tcp://127.0.0.1:52100"\n'
                     'options = { gain_percent = 150 }\n')
    settings = OculusSettings.from_options(config.device("sonar").options)
    assert settings.range_m == 5.0 and settings.freq_mode == 1
    cmd = settings.fire_command()
    assert oculus.decode(oculus.encode(cmd)) == cmd


@pytest.mark.live
def test_fire_is_resent_on_read_when_due() -> None:
    with fake_sonar() as (port, _fires), OculusDriver("sonar", f"tcp://127.0.0.1:{port}",
                                                      OculusSettings(keepalive_s=0.05)) as drv:
        time.sleep(0.06)
        drv.read(0.0)
        assert drv.fires_sent == 2


def test_a_configured_oculus_device_gets_the_commanding_driver() -> None:
    drv = driver_for_device("sonar", "oculus", "tcp://127.0.0.1:52100", {"range_m": 4.0, "data_bits": 16})
    assert isinstance(drv, OculusDriver) and drv.settings.range_m == 4.0 and drv.settings.data_bits == 16
    plain = driver_for_device("dvl", "pd0", "loop://")
    assert type(plain) is Driver and plain.format.name == "pd0"
