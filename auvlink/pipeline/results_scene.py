"""A detection as a ``foxglove.SceneEntity``: its oriented box as a cube and a text label above it.

The cube's pose is the centre of the object's oriented box (:mod:`recon.shape`) in the world frame
W (NED, m) turned by the yaw of its principal horizontal axis about W's z (down), its size
(length, width, height) the spans along, across and down; colour by class, half transparent. The
label "#id class score" floats 0.5 m above the box (billboard, fixed pixel size). The entity id is
``object_<id>`` and has no lifetime: the viewer keeps it from the moment the object was made. Its
metadata: class, score, points, yaw, length, width, and lat/lon where the run is geo-referenced.
"""

from __future__ import annotations

import math
import zlib

from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CubePrimitive_pb2 import CubePrimitive
from foxglove_schemas_protobuf.KeyValuePair_pb2 import KeyValuePair
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.TextPrimitive_pb2 import TextPrimitive
from google.protobuf.timestamp_pb2 import Timestamp

from auvlink.pipeline.results import Detection

MIN_SIZE_M = 0.05  # a cube never thinner than this (a flat object stays visible)


def class_colour(name: str) -> tuple[float, float, float]:
    """A stable colour (r, g, b in 0..1) per class name."""
    palette = ((0.90, 0.10, 0.29), (0.24, 0.71, 0.29), (1.0, 0.88, 0.10), (0.0, 0.51, 0.78),
               (0.96, 0.51, 0.19), (0.57, 0.12, 0.71), (0.27, 0.94, 0.94), (0.94, 0.20, 0.90))
    return palette[zlib.crc32(name.encode()) % len(palette)]


def _pose(x: float, y: float, z: float, yaw_rad: float = 0.0) -> Pose:
    p = Pose()
    p.position.x, p.position.y, p.position.z = x, y, z
    p.orientation.z, p.orientation.w = math.sin(yaw_rad / 2), math.cos(yaw_rad / 2)
    return p


def detection_entity(det: Detection, t_ns: int, frame_id: str) -> SceneEntity:
    """The scene entity of one detection (see the module docstring)."""
    box = det.box
    r, g, b = class_colour(det.class_name)
    x, y, z = box.centre
    cube = CubePrimitive(pose=_pose(x, y, z, math.radians(box.yaw_deg)), color=Color(r=r, g=g, b=b, a=0.5))
    cube.size.x, cube.size.y, cube.size.z = (max(v, MIN_SIZE_M) for v in (box.length_m, box.width_m, box.height_m))
    label = TextPrimitive(pose=_pose(x, y, z - box.height_m / 2 - 0.5), billboard=True, font_size=14.0,
                          scale_invariant=True, color=Color(r=1.0, g=1.0, b=1.0, a=1.0),
                          text=f"#{det.id} {det.class_name} {det.score:.2f}")
    ts = Timestamp()
    ts.FromNanoseconds(int(t_ns))
    meta = [KeyValuePair(key=k, value=v) for k, v in (
        ("class", det.class_name), ("score", f"{det.score:.4f}"), ("n_points", str(det.n_points)),
        ("yaw_deg", f"{box.yaw_deg:.2f}"), ("length_m", f"{box.length_m:.3f}"), ("width_m", f"{box.width_m:.3f}"))]
    lat, lon = getattr(det, "latitude", None), getattr(det, "longitude", None)  # when geo-referenced
    if lat is not None and lon is not None:
        meta += [KeyValuePair(key="lat", value=f"{lat:.9f}"), KeyValuePair(key="lon", value=f"{lon:.9f}")]
    return SceneEntity(timestamp=ts, frame_id=frame_id, id=f"object_{det.id}", frame_locked=False,
                       metadata=meta, cubes=[cube], texts=[label])
