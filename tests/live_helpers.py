"""Helpers of the live-loop tests: a short scene, a vehicle config on private virtual ports, and the
simulator and ``LiveRun`` on threads that are always stopped and joined."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from scenes import obj, scene_toml

from auvlink.config import load_config
from auvlink.sim.device_server import serve
from auvlink.sim.scene import loads_scene
from auvlink.virtual import free_tcp_port

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

# one 26 m line at 2 m/s (13 s), two objects on it; the pipe comes into view 3 s into the line, once recon has
# measured the beam's lower edge from the seabed (recon.beam_edge: an object seen only before that leaves no points)
TRUTH_NE = ((16.0, 0.3), (25.0, -0.3))
SCENE = scene_toml(seed=5, objects=[obj("pipe", *TRUTH_NE[0], 60.0), obj("reef_c", *TRUTH_NE[1], 0.0)],
                   survey={"line_length": 26.0, "speed": 2.0})


def classes_against_truth(detections: list[dict[str, Any]], scene_text: str) -> tuple[list[str], list[str]]:
    """(detected classes, the simulator's truth class of each detection's nearest object) from
    ``detections.jsonl`` objects; asserts one detection per true object."""
    objects = loads_scene(scene_text).objects
    truth = np.array([[o.north, o.east] for o in objects]).reshape(-1, 2)
    found = np.array([d["position_ned"][:2] for d in detections]).reshape(-1, 2)
    nearest = np.linalg.norm(found[:, None] - truth[None], axis=2).argmin(axis=1).tolist()
    assert sorted(nearest) == list(range(len(objects))), (nearest, detections)
    return [d["class"] for d in detections], [objects[j].class_name for j in nearest]


def vehicle_config(tmp_path: Path, pressure: str = "paro") -> Path:
    """examples/virtual_ports.toml with the ports under ``tmp_path`` and a free TCP port."""
    text = (ROOT / "examples" / "virtual_ports.toml").read_text()
    text = text.replace("/tmp/auvlink/", f"{tmp_path}/ports/").replace("5600", str(free_tcp_port()))
    text = text.replace("bitrate=500000", "bitrate=500000&sleep_after_open=0")
    text = text.replace('format = "keller"', f'format = "{pressure}"')
    path = tmp_path / "vehicle.toml"
    path.write_text(text)
    return path


@contextmanager
def threads() -> Iterator[list[tuple[threading.Thread, threading.Event]]]:
    """Threads registered here are stopped (their event set) and joined on the way out."""
    started: list[tuple[threading.Thread, threading.Event]] = []
    try:
        yield started
    finally:
        for _, stop in started:
            stop.set()
        for t, _ in started:
            t.join(30.0)
        assert not any(t.is_alive() for t, _ in started)


def start(pool: list[tuple[threading.Thread, threading.Event]], target: Any, stop: threading.Event,
          name: str) -> tuple[threading.Thread, list[Any], list[BaseException]]:
    """Run ``target()`` on a thread; its return value or exception lands in the lists returned."""
    out: list[Any] = []
    errors: list[BaseException] = []

    def body() -> None:
        try:
            out.append(target())
        except BaseException as exc:
            errors.append(exc)

    t = threading.Thread(target=body, name=name)
    pool.append((t, stop))
    t.start()
    return t, out, errors


@contextmanager
def sim_process(cfg: Path, scene_text: str = SCENE, speed: float = 1.0,
                hook: str | None = None) -> Iterator[subprocess.Popen[str]]:
    """``auvlink sim --live`` serving ``cfg``'s ports in its own process, as a vehicle's devices are (a simulator
    on a thread of the process under test would share its interpreter lock and fall behind its schedule);
    yielded once its ports are open, killed on the way out if it is still running. Its stdout is the CLI's
    (the port list, then the end summary: ``sim_summary``). With ``hook`` (``MODULE:ATTRIBUTE``, a
    ``PortHook`` of a module here, e.g. a fault injector) the same through ``tests/sim_serve.py``."""
    scene = cfg.parent / "scene.toml"
    scene.write_text(scene_text)
    if hook is None:
        cmd = ["-m", "auvlink", "sim", "--scene", str(scene), "--live", str(cfg), "--speed", str(speed)]
    else:
        cmd = [str(HERE / "sim_serve.py"), str(cfg), str(scene), str(speed), hook]
    env = {**os.environ, "PYTHONUNBUFFERED": "1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")]))}
    proc = subprocess.Popen([sys.executable, *cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=ROOT)
    try:
        assert proc.stdout is not None
        header = proc.stdout.readline()  # printed once every port is open
        assert "live at" in header, (header, proc.stderr.read() if proc.stderr else "")
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()


def sim_summary(proc: subprocess.Popen[str], timeout: float) -> str:
    """The simulator's end summary (its stdout from the port list on) once it has finished the survey;
    asserts it ended cleanly within ``timeout`` s."""
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err
    return out


def simulate(cfg: Path, stop: threading.Event, speed: float = 1.0, **kw: Any) -> Any:
    return serve(loads_scene(SCENE), load_config(cfg), speed=speed, stop=stop, **kw)
