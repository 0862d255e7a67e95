"""A small simulated mission (one 40 m line over a pipe and a reef, about 27 s; ~2 s to simulate).

Tests that need it simulated and replayed take the session fixtures ``small_mission_log`` and
``small_mission_run`` (tests/conftest.py) instead of simulating it again."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scenes import BASE, scene_toml

SCENE = scene_toml()
TRUTH = {o["class"]: tuple(o["position"]) for o in BASE["objects"]}  # class -> (north, east) m


@dataclass(frozen=True)
class SmallMissionRun:
    """The small mission replayed by ``auvlink replay LOG --out OUT --quiet --json``."""

    log: Path  # the simulated mission log
    out: Path  # the replay's folder: detections.jsonl, summary.json, report.html, results.mcap, objects/ ...
    doc: dict[str, Any]  # the JSON object the command printed


def simulate_small(path: Path) -> Path:
    """Simulate the mission into ``path`` (a mission log) and return it."""
    from auvlink.sim.mission import simulate_to_log
    from auvlink.sim.scene import loads_scene

    simulate_to_log(loads_scene(SCENE), path, progress=False)
    return path
