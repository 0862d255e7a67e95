"""The JSON Schemas of the four TOML files, generated from their pydantic models.

``python scripts/gen_schemas.py`` writes them to ``docs/schemas/``; a test checks that the
committed files equal what the models generate, so the published schemas cannot drift.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from auvlink.config import VehicleFile
from auvlink.sim.settings import SceneDocument, SettingsTables
from auvlink.validation import json_schema
from classify.training.config import TrainFile

#: file name -> (model, title, description)
SCHEMAS: dict[str, tuple[Any, str, str]] = {
    "vehicle.schema.json": (VehicleFile, "auvlink vehicle configuration",
                            "The vehicle / mission configuration read by auvlink record, live and sim --live."),
    "scene.schema.json": (SceneDocument, "auvlink scene",
                          "A simulator scene: seabed, objects, survey, sonar, vehicle, site, sensors and noise."),
    "settings.schema.json": (SettingsTables, "auvlink simulator settings",
                             "The [sensors] and [noise] tables of a scene file."),
    "train.schema.json": (TrainFile, "classify training settings",
                          "Synthesis, training and quick-run settings of the classifier (classify/data/*.toml)."),
}


def schema_texts() -> dict[str, str]:
    """``{file name: JSON text}`` of every schema (sorted keys, two-space indent, final newline)."""
    return {name: json.dumps(json_schema(model, title, desc), indent=2, sort_keys=True) + "\n"
            for name, (model, title, desc) in SCHEMAS.items()}


def write_schemas(folder: Path) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, text in schema_texts().items():
        path = folder / name
        path.write_text(text, encoding="utf-8")
        out.append(path)
    return out
