"""Frames/s of every simulated sonar model (:data:`auvlink.sim.scene.SIMULATED_MODELS`) on the default scene's
survey flown with it (:func:`auvlink.sim.scene.with_sonar_model`): its own realistic acoustic profile against the
``ideal`` model, on the same frames (an object inside the range window, or the seabed only), wall and CPU time.
The Oculus' image is 512 beams x its range lines at 2.5 mm (4096, the most an image holds, over the default window)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from _sim_frames import fps, fps_cpu, frames_of

from auvlink.sim.acoustics import AcousticsTable
from auvlink.sim.scene import SIMULATED_MODELS, Scene, with_acoustics, with_sonar_model
from auvlink.sim.sonar_render import SonarRenderer


def model_rows(scene: Scene, n: int, stride: int, repeat: int) -> list[dict[str, Any]]:
    """One row per sonar model and acoustics (``ideal``, then the model's realistic profile)."""
    rows = []
    for model in SIMULATED_MODELS:
        flown = with_sonar_model(replace(scene, acoustics=AcousticsTable(profile="didson")), model)
        frames = frames_of(flown, n, stride)
        for acoustics in ("ideal", "realistic"):
            rd = SonarRenderer(flown if acoustics == "realistic" else with_acoustics(flown, "ideal"))
            g = rd.geometry
            row: dict[str, Any] = {"model": model, "image": f"{g.n_beams}x{g.n_bins}", "acoustics": acoustics}
            for view, key in (("objects in view", "objects"), ("seabed only", "seabed")):
                row[f"fps_{key}"] = fps(rd, frames[view], repeat)
                row[f"fps_cpu_{key}"] = fps_cpu(rd, frames[view], repeat)
            rows.append(row)
    return rows
