"""``auvlink sim --live``: the simulated devices on pty, slcan and TCP ports that ``auvlink record`` reads."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from auvlink.cli.record import record
from auvlink.config import load_config, loads_config
from auvlink.sim.device_server import adapt, match_devices, serve
from auvlink.sim.noise import SimError
from auvlink.sim.scene import load_default_scene
from auvlink.sim.settings import SimSettings
from auvlink.virtual import free_tcp_port
from logs_format import Replay

ROOT = Path(__file__).resolve().parents[1]


def _config(tmp_path: Path, pressure: str = "keller") -> Path:
    text = (ROOT / "examples" / "virtual_ports.toml").read_text()
    text = text.replace("/tmp/auvlink/", f"{tmp_path}/ports/").replace("5600", str(free_tcp_port()))
    text = text.replace("bitrate=500000", "bitrate=500000&sleep_after_open=0")
    text = text.replace('format = "keller"', f'format = "{pressure}"')
    path = tmp_path / "vehicle.toml"
    path.write_text(text)
    return path


@pytest.mark.live
@pytest.mark.slow
def test_record_reads_every_simulated_device(tmp_path: Path) -> None:
    cfg_path = _config(tmp_path)
    config = load_config(cfg_path)
    stop, ready = threading.Event(), threading.Event()
    errors: list[BaseException] = []

    def sim() -> None:
        try:
            serve(load_default_scene(), config, speed=1.0, duration=30.0, stop=stop, ready=ready)
        except BaseException as exc:
            errors.append(exc)
            ready.set()

    thread = threading.Thread(target=sim, name="sim-live")
    thread.start()
    try:
        assert ready.wait(20.0) and not errors
        assert (tmp_path / "ports" / "dvl").is_symlink() and (tmp_path / "ports" / "can").is_symlink()
        out = tmp_path / "rec.mcap"
        result = record(str(cfg_path), str(out), duration=2.5)
    finally:
        stop.set()
        thread.join(10.0)
    assert not errors and not thread.is_alive()
    devices = result["devices"]
    assert set(devices) == {"dvl", "gyro", "pressure", "can", "sonar", "gnss"}
    for name, d in devices.items():
        assert d["frames"] > 0 and d["decode_errors"] == 0 and not d["failure"], (name, d)
    assert devices["gyro"]["frames"] >= 150 and devices["sonar"]["frames"] >= 10
    with Replay(out) as rep:
        seen = {s.device for s in rep.samples()}
        assert all(st["decode_errors"] == 0 for st in rep.stats().values())
    assert seen == set(devices)
    assert not any((tmp_path / "ports").iterdir())  # the symlinks are gone


def test_the_config_describes_the_vehicle() -> None:
    config = load_config(ROOT / "examples" / "virtual_ports.toml")
    assert set(match_devices(config)) == {"dvl", "gyro", "pressure", "can", "sonar", "gnss"}
    scene, settings = adapt(load_default_scene(), SimSettings(), config)
    assert scene.sonar.lever_arm == (1.2, 0.0, 0.1) and settings.sensors.pressure == "keller"
    assert settings.sensors.dvl_lever_arm == (0.4, 0.0, 0.25)
    bad = loads_config('[[devices]]\nname = "x"\nformat = "pd6"\nurl = "tcp://127.0.0.1:1"\n')
    with pytest.raises(SimError, match="does not emit"):
        match_devices(bad)


@pytest.mark.live
@pytest.mark.slow
def test_cli_live_stops_cleanly_on_sigterm(tmp_path: Path) -> None:
    cfg = _config(tmp_path, pressure="paro")
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "auvlink", "sim", "--live", str(cfg), "--speed", "2"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline() for _ in range(6)]
        assert "live at 2x" in lines[0] and any("/dev/pts/" in line for line in lines[1:])
        assert (tmp_path / "ports" / "gyro").is_symlink()
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "stopped after" in out
    assert not any((tmp_path / "ports").iterdir())


class _SlowFirstFrame:
    """A port hook whose first frame takes 0.3 s to write (a stalled port): every frame due in that time is late."""

    def __init__(self) -> None:
        self.sent = 0

    def start(self, ports: object) -> None:
        pass

    def send(self, t_s: float, port: Any, raw: bytes) -> None:
        if not self.sent:
            time.sleep(0.3)
        self.sent += 1
        port.send(raw)


@pytest.mark.slow
def test_a_simulator_behind_its_schedule_says_so(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    import auvlink.sim.device_server as device_server
    from auvlink.cli import main

    result = serve(load_default_scene(), load_config(_config(tmp_path)), duration=1.0, hook=_SlowFirstFrame())
    # the gyro alone sends a frame every 10 ms: those due in the first 0.25 s go out more than 0.05 s late
    assert result.late_frames >= 20 and result.behind_s > 0.25, result
    # the command line says so (the run above is the real one; this checks the line the CLI prints from it)
    monkeypatch.setattr(device_server, "serve", lambda *a, **k: device_server.LiveResult(1.0, [], 24, 0.31))
    assert main(["sim", "--live", str(_config(tmp_path)), "--duration", "1"]) == 0
    assert "behind real time: 24 frames late, by up to 0.31 s" in capsys.readouterr().out
