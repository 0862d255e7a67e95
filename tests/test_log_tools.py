"""Log tools: info (duration, counts, rates, gaps, decode errors, metadata), export (CSV, fan PNG
geometry), import (raw serial capture, python-can log), the config file and the CLI commands."""

from __future__ import annotations

import csv
import itertools
import json
import math
import os
import signal
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from auvlink import formats
from auvlink.atomic import partial_path
from auvlink.cli import main
from auvlink.codecs import dsp1760
from auvlink.config import load_config, loads_config
from auvlink.errors import ConfigError, DecodeError
from auvlink.formats import WireFormat
from auvlink.framing.base import Framer
from auvlink.virtual import PtyPair
from logs_format import MissionLogReader, MissionLogWriter, export_log, import_serial_capture, log_info
from logs_format.fan import fan_grid, render_fan

T0 = 1_700_000_000_000_000_000
ROOT = Path(__file__).resolve().parents[1]


def gyro(i: int) -> bytes:
    return dsp1760.encode(dsp1760.build((1e-4 * i, 0.0, 0.0), (0.0, 0.0, -9.8), sequence=i))


# -- a test-only sonar format: header, geometry, image (range bin x beam) ---------------------
_FAN = struct.Struct("<4sHHfff")  # magic, n_range, n_beam, r0 m, r1 m, half width rad


@dataclass(frozen=True)
class FanFrame:
    image: np.ndarray
    ranges: np.ndarray
    azimuths: np.ndarray


def fan_decode(raw: bytes) -> FanFrame:
    magic, nr, nb, r0, r1, hw = _FAN.unpack_from(raw)
    if magic != b"FAN1" or len(raw) != _FAN.size + nr * nb:
        raise DecodeError("test.fan: bad frame", fmt="test.fan")
    image = np.frombuffer(raw, np.uint8, nr * nb, _FAN.size).reshape(nr, nb)
    return FanFrame(image, np.linspace(r0, r1, nr), np.linspace(-hw, hw, nb))


def fan_encode(image: np.ndarray, r0: float, r1: float, hw: float) -> bytes:
    return _FAN.pack(b"FAN1", image.shape[0], image.shape[1], r0, r1, hw) + image.astype(np.uint8).tobytes()


class FanFramer(Framer):
    format_name = "test.fan"

    def _extract(self, buf: bytearray, final: bool = False) -> list[bytes]:
        out = []
        while len(buf) >= _FAN.size:
            if buf[:4] != b"FAN1":
                self._drop(buf, max(1, buf.find(b"FAN1")) if b"FAN1" in buf else len(buf))
                continue
            _, nr, nb, *_ = _FAN.unpack_from(buf)
            n = _FAN.size + nr * nb
            if len(buf) < n:
                break
            out.append(bytes(buf[:n]))
            del buf[:n]
        return out


@pytest.fixture(scope="module", autouse=True)
def fan_format() -> Iterator[None]:
    """Register the test sonar format for this module only."""
    formats.register(WireFormat("test.fan", "test.fan", "test sonar", fan_decode, lambda r: b"", FanFramer))
    yield
    formats._LOADED.pop("test.fan", None)
    formats._MODULES.pop("test.fan", None)


# -- info ----------------------------------------------------------------------------------------
def test_info_counts_rates_gaps_errors(tmp_path: Path) -> None:
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path, chunk_size=4096) as log:
        log.add_metadata("vehicle_config", {"config": {"vehicle": {"name": "auv1"}}})
        for i in range(500):  # 100 Hz, with 50 frames missing at 2.0 .. 2.5 s
            if not 200 <= i < 250:
                log("fog", "dsp1760", T0 + i * 10_000_000, gyro(i))
        for i in range(26):
            raw = gyro(i)
            if i == 7:
                raw = raw[:-1] + bytes([raw[-1] ^ 1])  # wrong CRC: a decode error
            log("fog2", "dsp1760", T0 + i * 200_000_000, raw)
    info = log_info(path)
    assert info["duration_s"] == pytest.approx(5.0)
    assert info["complete"] and info["loss"]["lossy"] is False
    fog, fog2 = info["channels"]["fog"], info["channels"]["fog2"]
    assert fog["count"] == 450 and fog2["count"] == 26
    assert fog["rate_hz"] == pytest.approx(449 / 4.99)
    assert fog["median_period_s"] == pytest.approx(0.01)
    assert fog["n_gaps"] == 1
    assert fog["gaps"][0]["start_s"] == pytest.approx(1.99)
    assert fog["gaps"][0]["duration_s"] == pytest.approx(0.51)
    assert fog2["rate_hz"] == pytest.approx(5.0) and fog2["n_gaps"] == 0
    assert (fog["decode_errors"], fog2["decode_errors"]) == (0, 1)
    assert "checksum" in fog2["last_error"]
    assert fog["encoding"] == "kvh.dsp1760"
    assert info["metadata"]["vehicle_config"]["config"]["vehicle"]["name"] == "auv1"
    json.dumps(info, allow_nan=False)


def test_cli_log_info(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "m.mcap"
    with MissionLogWriter(path) as log:
        for i in range(11):
            log("fog", "dsp1760", T0 + i * 100_000_000, gyro(i))
    assert main(["log", "info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["duration_s"] == pytest.approx(1.0)
    assert info["channels"]["fog"]["count"] == 11
    assert main(["log", "info", str(path)]) == 0
    text = capsys.readouterr().out
    assert "fog" in text and "dsp1760" in text and "complete" in text
    assert main(["log", "info", str(tmp_path / "missing.mcap")]) == 1
    assert "cannot open log" in capsys.readouterr().err


# -- export --------------------------------------------------------------------------------------
def test_fan_geometry_places_cells_at_their_range_and_azimuth() -> None:
    nr, nb, r0, r1, hw = 64, 24, 1.0, 11.0, math.radians(14.5)
    ranges, az = np.linspace(r0, r1, nr), np.linspace(-hw, hw, nb)
    assert fan_grid(ranges, az).px_per_m == pytest.approx((nr - 1) / (r1 - r0))  # ~1 px per range bin
    grid = fan_grid(ranges, az, px_per_m=60.0)  # fine enough that every beam gets pixels at 1.8 m
    assert grid.x_max == pytest.approx(r1 * math.sin(hw)) and grid.y_max == pytest.approx(r1)
    assert grid.y_min == pytest.approx(r0 * math.cos(hw))
    for m, n in [(10, 3), (40, 12), (60, 20), (5, 23)]:
        image = np.zeros((nr, nb), np.uint8)
        image[m, n] = 255
        pic = render_fan(image, grid).filled(0)
        ii, jj = np.nonzero(pic)
        assert ii.size > 0
        x = grid.x_min + (jj + 0.5) / grid.px_per_m
        y = grid.y_max - (ii + 0.5) / grid.px_per_m
        dr = (r1 - r0) / (nr - 1)
        da = 2 * hw / (nb - 1)
        assert np.all(np.abs(np.hypot(x, y) - ranges[m]) <= dr)
        assert np.all(np.abs(np.arctan2(x, y) - az[n]) <= da)


def test_export_csv_and_fan_png(tmp_path: Path) -> None:
    import matplotlib.image

    path = tmp_path / "m.mcap"
    rng = np.random.default_rng(3)
    with MissionLogWriter(path) as log:
        for i in range(20):
            log("fog", "dsp1760", T0 + i * 10_000_000, gyro(i))
        for i in range(3):
            img = rng.integers(0, 255, (32, 16), dtype=np.uint8)
            log("sonar", "test.fan", T0 + i * 100_000_000 + 1, fan_encode(img, 1.0, 9.0, 0.25))
    out = tmp_path / "export"
    assert main(["log", "export", str(path), "--out", str(out), "--every", "1"]) == 0
    with open(out / "fog.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 20
    assert float(rows[5]["t_host_s"]) == pytest.approx((T0 + 50_000_000) * 1e-9)
    assert float(rows[5]["gyro_0"]) == pytest.approx(5e-4, rel=1e-6)
    assert rows[5]["sequence"] == "5" and rows[0]["t_sensor_s"] == ""
    pngs = sorted((out / "sonar").glob("frame_*.png"))
    assert [p.name for p in pngs] == ["frame_000000.png", "frame_000001.png", "frame_000002.png"]
    pic = matplotlib.image.imread(pngs[0])
    with open(out / "sonar" / "frames.csv") as f:
        meta = list(csv.DictReader(f))
    px = float(meta[0]["px_per_m"])
    assert pic.shape[0] == math.ceil((9.0 - 1.0 * math.cos(0.25)) * px)
    assert pic.shape[1] == math.ceil(2 * 9.0 * math.sin(0.25) * px)
    res = export_log(path, tmp_path / "e2", sonar_every=2, max_sonar_frames=1)
    assert res.png_frames == {"sonar": 1} and res.csv_rows == {"fog": 20}


# -- import --------------------------------------------------------------------------------------
def test_import_serial_capture_pd0(tmp_path: Path, shared_data: Path) -> None:
    src = shared_data / "rdi" / "RDI_withBT.000"
    out = tmp_path / "dvl.mcap"
    res = import_serial_capture(src, "pd0", out, device="dvl", rate_hz=5.0)
    assert res.frames == 1721  # the README's count of whole ensembles
    with MissionLogReader(out) as log:
        msgs = list(log.messages())
        assert log.metadata(decode_json=True)["import"]["framer"]["frames"] == 1721
    assert b"".join(m.data for m in msgs) == b"".join(formats.get("pd0").framer().feed(src.read_bytes()))
    assert msgs[10].log_time_ns == 2_000_000_000
    # without a rate: the ensembles' own clock
    assert main(["log", "import", str(src), "--format", "pd0", "--out", str(tmp_path / "b.mcap")]) == 0
    first = next(iter(MissionLogReader(tmp_path / "b.mcap").messages()))
    pd0 = formats.get("pd0")
    t_sensor = pd0.sensor_time(pd0.decode(first.data))
    assert t_sensor is not None and first.log_time_ns == round(t_sensor * 1e9)


def test_import_python_can_log(tmp_path: Path) -> None:
    can = pytest.importorskip("can")
    from auvlink.framing.can_frames import unpack_frame

    src = tmp_path / "bus.asc"
    sent = [can.Message(timestamp=10.0 + 0.01 * i, arbitration_id=0x100 + i % 3, data=bytes([i, i + 1]),
                        is_extended_id=False) for i in range(30)]
    with can.ASCWriter(str(src)) as w:
        for m in sent:
            w.on_message_received(m)
    out = tmp_path / "can.mcap"
    assert main(["log", "import", str(src), "--out", str(out)]) == 0
    with MissionLogReader(out) as log:
        msgs = list(log.messages())
        assert log.channels["can"].format == "can"
    assert len(msgs) == 30
    frames = [unpack_frame(m.data) for m in msgs]
    assert [(f.arbitration_id, f.data) for f in frames] == [(m.arbitration_id, bytes(m.data)) for m in sent]
    # ASC stores times relative to its start: spacing is kept
    assert msgs[5].log_time_ns - msgs[0].log_time_ns == pytest.approx(50_000_000, abs=1000)


# -- config --------------------------------------------------------------------------------------
GOOD = """
[vehicle]
name = "auv1"
[[devices]]
name = "dvl"
format = "pd0"
url = "/dev/ttyUSB0?baudrate=115200"
mounting = { xyz = [0.5, 0.0, 0.2], rpy_deg = [0.0, 0.0, 45.0] }
[[devices]]
name = "fog"
format = "dsp1760"
url = "socket://127.0.0.1:5001"
[sonar]
device = "dvl"
tilt_deg = 30.0
spread_deg = 14.0
window_start = 1.0
window_length = 10.0
[can]
dbc = "auvlink_nav.dbc"
"""


def test_config_loads() -> None:
    cfg = loads_config(GOOD)
    assert cfg.name == "auv1" and [d.name for d in cfg.devices] == ["dvl", "fog"]
    assert cfg.device("dvl").mounting.rpy[2] == pytest.approx(math.pi / 4)
    assert cfg.device("fog").options == {}  # no format reads options: any key is an error (test_config_model)
    assert cfg.sonar is not None and cfg.sonar.tilt == pytest.approx(math.radians(30))
    assert cfg.can is not None and cfg.can.dbc == "auvlink_nav.dbc"
    assert cfg.to_dict()["devices"][0]["mounting"]["xyz"] == [0.5, 0.0, 0.2]


@pytest.mark.parametrize(
    ("change", "key"),
    [
        (("[vehicle]", "[vehicle]\ncolour = 1"), "vehicle.colour"),
        (('url = "/dev/ttyUSB0?baudrate=115200"\n', ""), "devices[0].url"),
        (('format = "pd0"', 'format = "pd9"'), "devices[0].format"),
        (("xyz = [0.5, 0.0, 0.2]", "xyz = [0.5, 0.0]"), "devices[0].mounting.xyz"),
        (('name = "fog"', 'name = "dvl"'), "devices[1].name"),
        (("tilt_deg = 30.0", "tilt_deg = \"30\""), "sonar.tilt_deg"),
        (('device = "dvl"', 'device = "sonar"'), "sonar.device"),
        (("[can]", "[cann]"), "cann"),
        (("name = \"auv1\"", "name = "), "<string>"),
    ],
)
def test_config_errors_name_the_key(change: tuple[str, str], key: str) -> None:
    with pytest.raises(ConfigError) as err:
        loads_config(GOOD.replace(*change, 1))
    assert err.value.key == key
    assert key in str(err.value)


def test_config_file_missing(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        load_config(tmp_path / "nope.toml")


# -- record --------------------------------------------------------------------------------------
def _config(tmp_path: Path, fog: PtyPair, fog2: PtyPair) -> Path:
    cfg = tmp_path / "vehicle.toml"
    cfg.write_text(
        f'[vehicle]\nname = "test"\n'
        f'[[devices]]\nname = "fog"\nformat = "dsp1760"\nurl = "{fog.device_path}"\n'
        f'[[devices]]\nname = "fog2"\nformat = "dsp1760"\nurl = "{fog2.device_path}"\n'
    )
    return cfg


def test_cli_record_duration(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Two ports recorded for 1.5 s: every frame sent while recording is in the log, in order.
    (pyserial discards what arrived before the port was opened, as hardware does.)"""
    out = tmp_path / "rec.mcap"
    with PtyPair() as fog, PtyPair() as fog2:
        cfg = _config(tmp_path, fog, fog2)
        stop = threading.Event()

        def instrument() -> None:
            i = 0
            while not stop.is_set() and i < 5000:
                fog.write(gyro(i))
                if i % 3 == 0:
                    fog2.write(gyro(i))
                i += 1
                time.sleep(0.002)

        t = threading.Thread(target=instrument)
        t.start()
        try:
            assert main(["record", str(cfg), "--out", str(out), "--duration", "1.5"]) == 0
        finally:
            stop.set()
            t.join()
    text = capsys.readouterr().out
    assert "fog " in text and "frames" in text
    with MissionLogReader(out) as log:
        assert log.complete
        got: dict[str, list[bytes]] = {"fog": [], "fog2": []}
        for m in log.messages():
            got[m.channel].append(m.data)
        assert log.metadata(decode_json=True)["vehicle_config"]["config"]["vehicle"]["name"] == "test"
    assert len(got["fog"]) > 100 and len(got["fog2"]) > 30
    k = dsp1760.decode(got["fog"][0]).sequence
    first = next(i for i in range(k, 5000, 128) if gyro(i) == got["fog"][0])
    assert got["fog"] == [gyro(i) for i in range(first, first + len(got["fog"]))]
    seq2 = [dsp1760.decode(r).sequence for r in got["fog2"]]
    assert all((b - a) % 128 == 3 for a, b in itertools.pairwise(seq2))


@pytest.mark.slow
def test_cli_record_stops_cleanly_on_sigint(tmp_path: Path) -> None:
    out = tmp_path / "rec.mcap"
    with PtyPair() as fog, PtyPair() as fog2:
        cfg = _config(tmp_path, fog, fog2)
        proc = subprocess.Popen([sys.executable, "-m", "auvlink", "record", str(cfg), "--out", str(out)],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env={**os.environ, "PYTHONPATH": str(ROOT)})
        try:
            deadline = time.monotonic() + 30
            while not partial_path(out).exists() and time.monotonic() < deadline:  # the log is open
                time.sleep(0.05)
            time.sleep(0.5)  # drivers open
            for i in range(100):
                fog.write(gyro(i))
                time.sleep(0.002)
            time.sleep(0.3)
            proc.send_signal(signal.SIGINT)
            stdout, stderr = proc.communicate(timeout=20)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
    assert proc.returncode == 0, stderr
    assert "fog" in stdout
    with MissionLogReader(out) as log:
        assert log.complete
        assert sum(1 for m in log.messages() if m.channel == "fog") == 100


def test_real_aris_capture_import_and_fan_export(tmp_path: Path, shared_data: Path) -> None:
    """The ARIS sample file: imported as a raw capture (the framer skips the file header), then
    exported as fan images whose extent follows the frames' own window and beam-angle table."""
    import matplotlib.image

    from auvlink.codecs import aris

    src = shared_data / "aris" / "sample.aris"
    log_path = tmp_path / "aris.mcap"
    assert import_serial_capture(src, "aris", log_path, device="sonar", rate_hz=10.0).frames == 6
    frames = aris.read_file(src.read_bytes()).frames
    res = export_log(log_path, tmp_path / "out", max_sonar_frames=2)
    assert res.png_frames == {"sonar": 2} and res.decode_errors == {"sonar": 0}
    with open(tmp_path / "out" / "sonar" / "frames.csv") as f:
        meta = list(csv.DictReader(f))
    ranges, az = frames[0].ranges_m, frames[0].azimuths_rad
    assert float(meta[0]["y_max_m"]) == pytest.approx(ranges[-1])
    assert float(meta[0]["x_max_m"]) == pytest.approx(ranges[-1] * math.sin(az.max()))
    assert float(meta[0]["x_min_m"]) == pytest.approx(ranges[-1] * math.sin(az.min()))
    pic = matplotlib.image.imread(tmp_path / "out" / "sonar" / "frame_000000.png")
    px = float(meta[0]["px_per_m"])
    assert pic.shape[:2] == (math.ceil((ranges[-1] - ranges[0] * math.cos(az.max())) * px),
                             math.ceil((ranges[-1] * (math.sin(az.max()) - math.sin(az.min()))) * px))
