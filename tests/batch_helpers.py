"""Three short simulated surveys of one site for the batch tests (simulated once per test session).

Two lawnmower lines of 36 m over four objects (classes the pipeline detects in every pass: a pipe lying
30 deg off the line was missed in one of three passes) at a site with a datum; the vehicle gets GNSS
fixes on the surface before the dive and after it (3 s each), so every mission is georeferenced. The surveys are a
month apart (``[sensors] start``) with their own seeds, and the third has the reef removed.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from scenes import obj, scene_toml

from auvlink.sim.mission import simulate_to_log
from auvlink.sim.scene import load_scene

OBJECTS = {  # class -> (north, east) in m
    "sphere": (14.0, 0.4),
    "reef_b": (24.0, -0.3),
    "reef_a": (18.0, 3.8),
    "box": (28.0, 3.2),
}
REMOVED = "reef_a"  # not in the third survey

DATUM = (36.0412, 129.3915)  # the site datum (WGS84 degrees of the NED origin): Jangil Bay, Pohang


SURVEYS = (("survey_2026_01", 3, "2026-01-10T08:00:00Z", True),
           ("survey_2026_02", 4, "2026-02-10T08:00:00Z", True),
           ("survey_2026_03", 5, "2026-03-10T08:00:00Z", False))


def scene_text(seed: int, start: str, with_removed: bool) -> str:
    """Two 36 m lines at the site over :data:`OBJECTS` (less :data:`REMOVED` unless ``with_removed``), the
    sensors' clock starting at ``start`` (ISO 8601 UTC), GNSS fixes at the surface before and after."""
    return scene_toml(seed=seed, site={"latitude": DATUM[0], "longitude": DATUM[1]},
                      gnss={"wait_before_s": 3.0, "wait_after_s": 3.0, "vertical_rate": 2.0},
                      objects=[obj(c, n, e, 30.0) for c, (n, e) in OBJECTS.items() if with_removed or c != REMOVED],
                      survey={"line_length": 36.0, "lines": 2}, sensors={"start": start})


def site_logs(factory: pytest.TempPathFactory) -> list[Path]:
    """The three logs (simulated the first time a test of this session asks), in time order."""
    folder = factory.getbasetemp() / "batch-site-logs"
    folder.mkdir(exist_ok=True)
    logs = []
    for name, seed, start, full in SURVEYS:
        path = folder / f"{name}.mcap"
        if not path.is_file():
            tmp, toml = folder / f".{name}.tmp.mcap", folder / f"{name}.toml"
            toml.write_text(scene_text(seed, start, full))  # [sensors] start is read from the scene's file
            simulate_to_log(load_scene(toml), tmp, progress=False)
            tmp.rename(path)
        logs.append(path)
    return logs
