"""Decoded channels of a mission log as JSON with jsonschema schemas (viewers such as Foxglove open them).

* poses: schema ``foxglove.PoseInFrame`` (the viewer's well-known name, drawn in its 3D panel):
  ``timestamp {sec, nsec}``, ``frame_id``, ``pose {position {x, y, z}, orientation {x, y, z, w}}``.
  Position in the world frame W (local NED, m); orientation the quaternion of R_WB.
* detections: schema ``auvlink.Detection``: the fields of one line of ``detections.jsonl``
  (``id``, ``class``, ``score``, ``position_ned`` [m], ``size`` [m], ``n_points``, ``t_first``,
  ``t_last``, optional ``cloud``).

    writer.add_json("nav/pose", POSE_SCHEMA_NAME, POSE_SCHEMA, t_ns, pose_message(t_ns, p, q))
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import jsonschema

from logs_format.profile import LogError

POSE_SCHEMA_NAME = "foxglove.PoseInFrame"
DETECTION_SCHEMA_NAME = "auvlink.Detection"

_VEC3 = {
    "type": "object",
    "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}},
    "required": ["x", "y", "z"],
}
_QUAT = {
    "type": "object",
    "properties": {k: {"type": "number"} for k in ("x", "y", "z", "w")},
    "required": ["x", "y", "z", "w"],
}
_TIME = {
    "type": "object",
    "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0,
                                                                       "maximum": 999_999_999}},
    "required": ["sec", "nsec"],
}

POSE_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": POSE_SCHEMA_NAME,
    "description": "A timestamped pose of the vehicle in the world frame (local NED, m)",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame_id": {"type": "string"},
        "pose": {
            "type": "object",
            "properties": {"position": _VEC3, "orientation": _QUAT},
            "required": ["position", "orientation"],
        },
    },
    "required": ["timestamp", "frame_id", "pose"],
}

_VEC3_ARRAY = {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}

DETECTION_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": DETECTION_SCHEMA_NAME,
    "description": "One classified object (a line of detections.jsonl)",
    "type": "object",
    "properties": {
        "id": {"type": "integer", "minimum": 0},
        "class": {"type": "string"},
        "score": {"type": "number", "minimum": 0, "maximum": 1},
        "position_ned": _VEC3_ARRAY,
        "size": _VEC3_ARRAY,
        "n_points": {"type": "integer", "minimum": 0},
        "t_first": {"type": "number"},
        "t_last": {"type": "number"},
        "cloud": {"type": "string"},
    },
    "required": ["id", "class", "score", "position_ned", "size", "n_points", "t_first", "t_last"],
}

SCHEMAS: dict[str, dict[str, Any]] = {POSE_SCHEMA_NAME: POSE_SCHEMA, DETECTION_SCHEMA_NAME: DETECTION_SCHEMA}


def stamp(t_ns: int) -> dict[str, int]:
    """``{sec, nsec}`` of a UTC nanosecond time."""
    return {"sec": t_ns // 1_000_000_000, "nsec": t_ns % 1_000_000_000}


def pose_message(t_ns: int, position_ned: Sequence[float], quat_xyzw: Sequence[float],
                 frame_id: str = "ned") -> dict[str, Any]:
    """A ``foxglove.PoseInFrame`` message (quaternion as scipy gives it: x, y, z, w)."""
    x, y, z = (float(v) for v in position_ned)
    qx, qy, qz, qw = (float(v) for v in quat_xyzw)
    return {"timestamp": stamp(t_ns), "frame_id": frame_id,
            "pose": {"position": {"x": x, "y": y, "z": z},
                     "orientation": {"x": qx, "y": qy, "z": qz, "w": qw}}}


def detection_message(det: Mapping[str, Any]) -> dict[str, Any]:
    """An ``auvlink.Detection`` message from a detection dict (extra keys are dropped)."""
    keys = DETECTION_SCHEMA["properties"].keys()
    return {k: det[k] for k in keys if k in det}


def validate(message: Any, schema_name: str) -> None:
    """Raise :class:`LogError` when ``message`` does not follow the named schema."""
    try:
        jsonschema.validate(message, SCHEMAS[schema_name])
    except KeyError as exc:
        raise LogError(f"unknown schema {schema_name!r}; known: {', '.join(SCHEMAS)}") from exc
    except jsonschema.ValidationError as exc:
        raise LogError(f"{schema_name}: {exc.message}") from exc
