"""What a simulated mission log records besides the raw frames: vehicle configuration and ground truth.

- :func:`vehicle_config` - the configuration of the simulated vehicle (devices ``dvl``, ``gyro``,
  ``pressure``, ``can``, ``sonar`` on the URLs of ``examples/virtual_ports.toml``, their mountings,
  the sonar's tilt, spread and window), as a :class:`~auvlink.config.VehicleConfig` with TOML text.
- :func:`ground_truth` - the ``ground_truth`` metadata record: the scene file's text and values,
  seed, start time, duration, sensor settings and noise, object poses and classes; and its
  attachments: one PLY mesh per object (world NED, m, resting on the seabed) and the true
  trajectory at ``truth_hz`` as a NumPy ``.npy`` structured array (:data:`TRAJECTORY_DTYPE`).

Nothing here depends on the host or the clock, so the same run writes the same bytes.
"""

from __future__ import annotations

import io
from dataclasses import asdict
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auvlink.config import VehicleConfig, loads_config
from auvlink.jsonutil import to_jsonable
from auvlink.sim.object_meshes import bounding_sphere, object_pose, placed_mesh
from auvlink.sim.oculus_ping import sonar_format
from auvlink.sim.scene import Scene
from auvlink.sim.seabed import SeabedSurface
from auvlink.sim.settings import SimSettings
from auvlink.sim.trajectory import TruePose
from auvlink.version import __version__

TRAJECTORY_ATTACHMENT = "truth/trajectory.npy"
POSE_TOPIC = "truth/pose"
#: the true trajectory attachment: mission time (s), UTC ns, position NED (m), attitude (rad),
#: velocity over ground NED and body (m/s), body rates (rad/s), altitude (m), survey line (-1 turning)
TRAJECTORY_DTYPE = np.dtype([
    ("t", "<f8"), ("t_ns", "<i8"), ("north", "<f8"), ("east", "<f8"), ("down", "<f8"),
    ("yaw", "<f8"), ("pitch", "<f8"), ("roll", "<f8"), ("vn", "<f8"), ("ve", "<f8"), ("vd", "<f8"),
    ("u", "<f8"), ("v", "<f8"), ("w", "<f8"), ("p", "<f8"), ("q", "<f8"), ("r", "<f8"),
    ("altitude", "<f8"), ("line", "<i4"),
])
#: devices of the simulated vehicle and their URLs (as in examples/virtual_ports.toml)
URLS = {
    "dvl": "/tmp/auvlink/dvl?baudrate=115200",
    "gyro": "/tmp/auvlink/gyro?baudrate=921600",
    "pressure": "/tmp/auvlink/pressure?baudrate=9600",
    "can": "can://slcan//tmp/auvlink/can?bitrate=500000",
    "sonar": "tcp://127.0.0.1:5600",
    "gnss": "/tmp/auvlink/gnss?baudrate=9600",
}


def _vec(v: tuple[float, ...]) -> str:
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def vehicle_config_text(scene: Scene, settings: SimSettings) -> str:
    s, sonar = settings.sensors, scene.sonar
    rows = [
        "# Vehicle of a simulated mission (auvlink.sim): the devices the simulator emits and their mountings.",
        '[vehicle]\nname = "sim-auv"',
    ]
    devices = [
        ("dvl", "pd0", s.dvl_lever_arm, s.dvl_rpy_deg), ("gyro", "dsp1760", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ("pressure", s.pressure, s.pressure_lever_arm, (0.0, 0.0, 0.0)),
        ("can", "can", None, None), ("sonar", sonar_format(sonar), sonar.lever_arm, (0.0, 0.0, 0.0)),
    ]
    if scene.gnss is not None:
        devices.append(("gnss", "nmea", scene.gnss.lever_arm, (0.0, 0.0, 0.0)))
    for name, fmt, xyz, rpy in devices:
        dev = f'[[devices]]\nname = "{name}"\nformat = "{fmt}"\nurl = "{URLS[name]}"'
        if xyz is not None and rpy is not None:
            dev += f"\nmounting = {{ xyz = {_vec(xyz)}, rpy_deg = {_vec(rpy)} }}"
        rows.append(dev)
    table = (f'[sonar]\ndevice = "sonar"\ntilt_deg = {sonar.tilt_deg!r}\nspread_deg = {sonar.spread_deg!r}\n'
             f"window_start = {sonar.window_start!r}\nwindow_length = {sonar.window_length!r}")
    for key in ("model", "frequency_mode"):  # written when the scene names them: the log says which sonar flew
        if getattr(sonar, key) is not None:
            table += f'\n{key} = "{getattr(sonar, key)}"'
    rows.append(table)
    rows.append('[can]\ndbc = "auvlink_nav.dbc"')
    site = scene.datum
    rows.append(f"[site]\nlatitude = {site.latitude!r}\nlongitude = {site.longitude!r}")
    return "\n\n".join(rows) + "\n"


def vehicle_config(scene: Scene, settings: SimSettings) -> VehicleConfig:
    return loads_config(vehicle_config_text(scene, settings), source="auvlink.sim")


def ply_bytes(vertices: NDArray[np.float64], faces: NDArray[np.int32], comment: str = "") -> bytes:
    """A binary little-endian PLY mesh: double x, y, z; triangles as ``list uchar int``."""
    v = np.ascontiguousarray(vertices, "<f8").reshape(-1, 3)
    f = np.asarray(faces).reshape(-1, 3)
    tri = np.empty(f.shape[0], dtype=[("n", "u1"), ("i", "<i4", (3,))])
    tri["n"], tri["i"] = 3, f
    head = ["ply", "format binary_little_endian 1.0"] + ([f"comment {comment}"] if comment else [])
    head += [f"element vertex {v.shape[0]}", "property double x", "property double y", "property double z",
             f"element face {f.shape[0]}", "property list uchar int vertex_indices", "end_header"]
    return ("\n".join(head) + "\n").encode("ascii") + v.tobytes() + tri.tobytes()


def trajectory_array(pose: TruePose, start_ns: int) -> NDArray[Any]:
    out = np.zeros(len(pose), TRAJECTORY_DTYPE)
    out["t"], out["t_ns"] = pose.t, start_ns + np.round(pose.t * 1e9).astype(np.int64)
    out["north"], out["east"], out["down"] = pose.position.T
    out["yaw"], out["pitch"], out["roll"] = pose.yaw, pose.pitch, pose.roll
    out["vn"], out["ve"], out["vd"] = pose.velocity_ned.T
    out["u"], out["v"], out["w"] = pose.velocity_body.T
    out["p"], out["q"], out["r"] = pose.angular_rate_body.T
    out["altitude"], out["line"] = pose.altitude, pose.line
    return out


def npy_bytes(array: NDArray[Any]) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array, allow_pickle=False)
    return buf.getvalue()


def ground_truth(scene: Scene, settings: SimSettings, duration: float, pose: TruePose,
                 devices: dict[str, str], phases: dict[str, float] | None = None
                 ) -> tuple[dict[str, Any], dict[str, bytes]]:
    """The ``ground_truth`` metadata and its attachments (name -> bytes); ``phases``: mission times of the
    surface phases (a scene with ``[gnss]``)."""
    seabed = SeabedSurface(scene.seabed, scene.seed)
    attachments: dict[str, bytes] = {}
    objects = []
    for i, obj in enumerate(scene.objects):
        pos, rot = object_pose(obj, seabed)
        v, f = placed_mesh(obj, seabed)
        name = f"truth/objects/{i:02d}_{obj.class_name}.ply"
        attachments[name] = ply_bytes(v, f, f"auvlink.sim object {i} {obj.class_name}, world NED m")
        centre, radius = bounding_sphere(obj.class_name)
        lo, hi = v.min(axis=0), v.max(axis=0)
        objects.append({
            "index": i, "class": obj.class_name, "class_index": obj.class_index,
            "position_ned": pos.tolist(), "heading_deg": obj.heading_deg, "quat_xyzw": rot.as_quat().tolist(),
            "centre_ned": (rot.as_matrix() @ centre + pos).tolist(), "bounding_radius": radius,
            "bbox_min_ned": lo.tolist(), "bbox_max_ned": hi.tolist(), "mesh": name,
        })
    attachments[TRAJECTORY_ATTACHMENT] = npy_bytes(trajectory_array(pose, settings.sensors.start_ns))
    if objects:
        lat, lon, _ = scene.datum.to_geodetic([o["position_ned"] for o in objects])
        for o, a, b in zip(objects, lat.tolist(), lon.tolist(), strict=True):
            o["latitude"], o["longitude"] = a, b
    rate = settings.sensors.truth_hz
    data = {
        "generator": f"auvlink.sim {__version__}",
        "seed": scene.seed,
        "scene_toml": settings.scene_text,
        "scene_source": scene.source,
        "scene": to_jsonable(asdict(scene)),
        "start_utc": settings.sensors.start.isoformat().replace("+00:00", "Z"),
        "start_ns": settings.sensors.start_ns,
        "duration_s": duration,
        "sensors": to_jsonable(asdict(settings.sensors)),
        "noise": to_jsonable(asdict(settings.noise)),
        "devices": devices,
        "objects": objects,
        "trajectory": {"attachment": TRAJECTORY_ATTACHMENT, "rate_hz": rate, "samples": len(pose),
                       "fields": list(TRAJECTORY_DTYPE.names or ()), "pose_topic": POSE_TOPIC,
                       "pose_topic_hz": settings.sensors.truth_topic_hz},
        "frames": "world: local NED (m), origin on the surface at the site datum (WGS84, 'site'); body: FRD; "
                  "R_WB = Rz(yaw) Ry(pitch) Rx(roll)",
        "seabed_depth_at_origin_m": float(seabed.depth(0.0, 0.0)),
        "site": scene.datum.to_dict(),
        "gnss": None if scene.gnss is None else {**to_jsonable(asdict(scene.gnss)), **(phases or {})},
    }
    return data, attachments
