"""One scene builder for the tests: :func:`scene_toml` writes a scene file's TOML from the small mission's
scene (:data:`BASE`) with the sections a test changes.

``scene_toml(seed=5, seabed={"depth": 30.0}, objects=[obj("sphere", 8.0, 0.3)])`` is the small mission with
seed 5, a 30 m deep seabed (the rest of ``[seabed]`` kept) and one sphere. A dict updates the section key by
key (a key set to ``None`` is deleted, so the simulator's default applies); any other value replaces the
key or section; ``None`` deletes it. Nested dicts (``noise={"dvl": {...}}``) become sub-tables.
"""

from __future__ import annotations

import copy
import json
import numbers
from typing import Any

Table = dict[str, Any]


def obj(class_name: str, north: float, east: float, heading_deg: float | None = None) -> Table:
    """One ``[[objects]]`` table: a catalogue class at (north, east) m, heading in degrees (None: the default 0)."""
    table: Table = {"class": class_name, "position": [north, east]}
    if heading_deg is not None:
        table["heading_deg"] = heading_deg
    return table


#: The small mission: one 40 m line at 5 m altitude over a pipe and a reef on a 20 m flat seabed, about 27 s.
BASE: Table = {
    "seed": 11,
    "seabed": {"depth": 20.0, "slope_deg": 0.0, "slope_azimuth_deg": 0.0, "roughness": 0.02},
    "objects": [obj("pipe", 16.0, 0.3, 60.0), obj("reef_c", 30.0, -0.3, 0.0)],
    "survey": {"pattern": "lawnmower", "origin": [0.0, 0.0], "heading_deg": 0.0, "line_length": 40.0,
               "line_spacing": 3.5, "lines": 1, "altitude": 5.0, "speed": 1.5},
    "sonar": {"tilt_deg": 30.0, "spread_deg": 14.0, "window_start": 1.0, "window_length": 10.0, "fps": 10.0},
}


def _value(v: Any) -> str:
    """One TOML value: bool, integer, real (numpy's too), string or a (nested) list of them."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):  # numpy floats too
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string for the ASCII text scenes hold
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {v!r}")


def _table(name: str, table: Table, header: str) -> list[str]:
    """``[name]`` (header ``[%s]``) or ``[[name]]`` with its keys, then its sub-tables as ``[name.key]``."""
    lines = [header % name]
    lines += [f"{k} = {_value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    for k, v in table.items():
        if isinstance(v, dict):
            lines += _table(f"{name}.{k}", v, "[%s]")
    return lines


def merge(base: Table, overrides: Table) -> Table:
    """``base`` with ``overrides`` applied as :func:`scene_toml` describes (a new dict; ``base`` is kept)."""
    out = copy.deepcopy(base)
    for key, value in overrides.items():
        if value is None:
            out.pop(key, None)
        elif isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def dumps(scene: Table) -> str:
    """TOML text of a scene dict: top-level keys, then tables, then ``[[objects]]``, in insertion order."""
    lines = [f"{k} = {_value(v)}" for k, v in scene.items() if not isinstance(v, dict) and k != "objects"]
    for key, value in scene.items():
        if isinstance(value, dict):
            lines += _table(key, value, "[%s]")
        elif key == "objects":
            for table in value:
                lines += _table("objects", table, "[[%s]]")
    return "\n".join(lines) + "\n"


def scene_toml(**overrides: Any) -> str:
    """The small mission's scene TOML with ``overrides`` (see the module docstring)."""
    return dumps(merge(BASE, overrides))
