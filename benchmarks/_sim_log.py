"""The ``sim`` benchmark's log section: seconds to simulate a whole survey into a mission log.

A lawnmower survey over the default scene's seabed, stretched to last ``minutes`` (10 lines for 10
minutes and more, else 4) with the default scene's objects and more along the long lines, at the
default scene's 10 fps; every device (DVL 5 Hz, gyro 100 Hz, pressure 10 Hz, CAN 50 messages/s,
sonar) through its real encoder into one MCAP log (``auvlink sim --out``). Reports wall seconds,
CPU seconds (this process and its workers), sonar frames/s and the log size; the goal is a
30-minute survey in <= 60 s.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import default_scene_text, loads_scene

_CLASSES = ("sphere", "box", "pipe", "reef_a", "hemisphere", "half_pipe", "reef_b", "reef_c")


def survey_scene_text(minutes: float) -> str:
    """The default scene with its survey stretched to ``minutes`` (10 lines when >= 10 minutes)."""
    text = default_scene_text()
    scene = loads_scene(text)
    sv = scene.survey
    lines = 10 if minutes >= 10 else 4
    turns = (lines - 1) * math.pi * sv.line_spacing / 2.0
    length = (minutes * 60.0 * sv.speed - turns) / lines
    text = text.replace(f"line_length = {sv.line_length}", f"line_length = {length:.3f}")
    text = text.replace(f"lines = {sv.lines}", f"lines = {lines}")
    extra = []
    for i in range(int(length // 25) if lines == 10 else 0):  # about one object per 25 m of line
        north = 75.0 + (i * 37.0) % max(1.0, length - 80.0)
        east = ((i * 7) % lines) * sv.line_spacing + (0.5 if i % 2 else -0.5)
        extra.append(f'[[objects]]\nclass = "{_CLASSES[i % 8]}"\nposition = [{north:.1f}, {east:.1f}]\n'
                     f"heading_deg = {(i * 29) % 180:.1f}\n")
    return text.replace("[survey]", "\n".join(extra) + "\n[survey]") if extra else text


def run_log(quick: bool = True, minutes: float | None = None) -> dict[str, Any]:
    minutes = minutes if minutes is not None else 3.0 if quick else 30.0
    with tempfile.TemporaryDirectory(prefix="auvlink-bench-sim-") as tmp:
        scene_path = Path(tmp) / "survey.toml"
        scene_path.write_text(survey_scene_text(minutes))
        scene = loads_scene(scene_path.read_text(), source=str(scene_path))
        before, t0 = os.times(), time.perf_counter()
        result = simulate_to_log(scene, Path(tmp) / "survey.mcap", progress=False)
        wall = time.perf_counter() - t0
        after = os.times()
        size = (Path(tmp) / "survey.mcap").stat().st_size
    cpu = sum(getattr(after, k) - getattr(before, k) for k in ("user", "system", "children_user",
                                                               "children_system"))
    out = {
        "minutes": result.duration_s / 60.0, "objects": len(scene.objects), "wall_s": wall, "cpu_s": cpu,
        "workers": result.workers, "frames": result.frames, "messages": sum(result.frames.values()),
        "sonar_fps": result.frames["sonar"] / wall, "log_mb": size / 1e6,
        "seconds_per_30_min": wall * 30.0 / (result.duration_s / 60.0), "goal_s_per_30_min": 60.0,
    }
    print(f"\nsimulated survey log: {out['minutes']:.1f} min of mission ({out['messages']} frames, "
          f"{out['log_mb']:.0f} MB) in {wall:.1f} s wall / {cpu:.1f} s CPU with {result.workers} worker(s): "
          f"{out['sonar_fps']:.0f} sonar frames/s, {out['seconds_per_30_min']:.0f} s per 30 min (goal 60)")
    return out
