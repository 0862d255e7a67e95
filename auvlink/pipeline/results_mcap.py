"""``DIR/results.mcap``: a run's results in Foxglove's own schemas, to open beside the mission log.

Protobuf messages of the ``foxglove-schemas-protobuf`` package, written with ``mcap-protobuf-support``
(each channel's schema is the package's compiled descriptor, a ``FileDescriptorSet``). Times are
UTC ns on the mission log's clock (host receive time), so both files play on one time line.

==========================  =====================  ==============================================
topic                       schema                 what
==========================  =====================  ==============================================
``/tf``                     foxglove.FrameTransforms  ``map`` -> ``world`` (static: ENU z-up over
                                                   the NED world frame W), ``world`` ->
                                                   ``base_link`` (the vehicle, FRD, 10 Hz),
                                                   ``base_link`` -> ``sonar`` (mounting and tilt);
                                                   a simulated mission also ``map`` -> ``ned``
                                                   (the frame of the log's ``truth/pose``)
``/nav/pose``               foxglove.PoseInFrame   the estimated pose in ``world`` (10 Hz)
``/nav/track``              foxglove.PosesInFrame  the whole track (1 Hz), once at the start
``/nav/location``           foxglove.LocationFix   latitude/longitude (1 Hz); see below
``/objects/cloud``          foxglove.PointCloud    every object's points so far (``world``):
                                                   x, y, z (float32, m), ``object_id`` (uint32),
                                                   ``time`` (float32, s since mission start)
``/objects/detections``     foxglove.SceneUpdate   every object so far: a cube (oriented box: centre,
                                                   yaw of the principal axis, length, width, height)
                                                   and a text label "#id class score"
``/sonar/fan``              foxglove.CompressedImage  the sonar frame as a fan (PNG), highlight
                                                   returns as cyan crosses, 1 frame/s
==========================  =====================  ==============================================

Each ``/objects/*`` message holds every object made so far (a viewer that seeks shows the latest
message of a topic, so none depends on earlier ones). The clouds are published at each new object
while their sum stays under ``CLOUD_BUDGET`` bytes, else at every k-th object (the smallest k that
fits) and always at the last one.

``/nav/location``: with a georeference (a datum and GNSS fixes: ``MissionResult.track_info``
``lat``/``lon``, the drift-corrected track of :mod:`auvlink.pipeline.georef`) those positions,
``frame_id`` ``wgs84``; without one (no datum, or no usable fix: the positions are relative to the
first navigation sample) the dead-reckoned track as offsets from 0 N 0 E (``frame_id``
``no_datum_offsets_from_0N_0E``, a ``notice`` in each fix's metadata and in the file's
``auvlink_results`` metadata record): the shape is right, the place is not.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.KeyValuePair_pb2 import KeyValuePair
from foxglove_schemas_protobuf.LocationFix_pb2 import LocationFix
from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.PosesInFrame_pb2 import PosesInFrame
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.writer import CompressionType
from mcap_protobuf.writer import Writer
from scipy.spatial.transform import Rotation

from auvlink.geodesy import Datum
from auvlink.pipeline.results import Detection, MissionResult
from auvlink.pipeline.results_scene import detection_entity
from recon.frames import euler

#: frame ids
MAP, WORLD, BASE, SONAR, FAN = "map", "world", "base_link", "sonar", "sonar_fan"
#: the frame of a simulated log's ``truth/pose``: the scene's NED, at its datum; the same as ``world`` when
#: the run is georeferenced at that datum, or when (no GNSS) the vehicle starts at the scene's origin
TRUTH_NED = "ned"
#: ``map`` (ENU, z up) <- ``world`` (NED): a half turn about (1, 1, 0) / sqrt 2 (x, y, z, w)
NED_TO_ENU = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)
NO_DATUM = "no_datum_offsets_from_0N_0E"
NO_DATUM_NOTICE = ("not georeferenced: latitude/longitude are the dead-reckoned track's offsets from 0 N 0 E "
                   "(shape right, place not); a [site] datum and a GNSS receiver with a fix georeference a run")
CLOUD_BUDGET = 16 << 20  # bytes of /objects/cloud in all
_POINT_BYTES = 20


def stamp(t_ns: int) -> Timestamp:
    ts = Timestamp()
    ts.FromNanoseconds(int(t_ns))
    return ts


def _pose(position: Any, quat: Any) -> Pose:
    p = Pose()
    p.position.x, p.position.y, p.position.z = (float(v) for v in position)
    p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w = (float(v) for v in quat)
    return p


def _transform(t_ns: int, parent: str, child: str, xyz: Any, quat: Any) -> FrameTransform:
    tf = FrameTransform(timestamp=stamp(t_ns), parent_frame_id=parent, child_frame_id=child)
    tf.translation.x, tf.translation.y, tf.translation.z = (float(v) for v in xyz)
    tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w = (float(v) for v in quat)
    return tf


def _thin(t: np.ndarray, rate_hz: float) -> np.ndarray:
    """Indices of ``t`` (s, sorted) at most ``rate_hz``."""
    if not t.size:
        return np.zeros(0, np.int64)
    return np.flatnonzero(np.r_[True, np.diff(np.floor(t * rate_hz)) > 0])


def local_to_geodetic(ned: np.ndarray, lat0: float, lon0: float) -> tuple[np.ndarray, np.ndarray]:
    """Latitude/longitude (deg) of local NED offsets (m) from (lat0, lon0) on the surface (PROJ
    topocentric, :class:`auvlink.geodesy.Datum`; the down component is left out: the fix's altitude)."""
    p = np.asarray(ned, dtype=np.float64).reshape(-1, 3).copy()
    p[:, 2] = 0.0
    lat, lon, _ = Datum(lat0, lon0).to_geodetic(p)
    return lat, lon


class GeoTrack(NamedTuple):
    """The track for ``/nav/location``: UTC ns, WGS84 deg, depth (m, down), heading (deg from north)."""

    t_ns: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    depth: np.ndarray
    heading: np.ndarray
    frame_id: str


def geodetic_track(result: MissionResult) -> GeoTrack:
    """The track for ``/nav/location`` (see the module docstring)."""
    info = result.track_info
    if info.get("time") is not None and info.get("lat") is not None and info.get("lon") is not None:
        lat, lon = np.asarray(info["lat"], float), np.asarray(info["lon"], float)
        ok = np.isfinite(lat) & np.isfinite(lon)
        if ok.any():
            t = np.asarray(info["time"], float)[ok]
            nan = np.full(len(ok), np.nan)
            depth = np.asarray(info.get("depth", nan), float)[ok]
            heading = np.asarray(info.get("heading", nan), float)[ok]
            return GeoTrack(np.round(t * 1e9).astype(np.int64), lat[ok], lon[ok], depth, heading, "wgs84")
    poses = result.poses
    t_ns = result.t0_ns + np.round(poses.t * 1e9).astype(np.int64)
    heading = np.degrees(euler(Rotation.from_quat(poses.quat))[0]) % 360.0 if poses.t.size else np.zeros(0)
    lat, lon = local_to_geodetic(poses.position, 0.0, 0.0)
    return GeoTrack(t_ns, lat, lon, poses.position[:, 2], heading, NO_DATUM)


def by_time(result: MissionResult) -> list[Detection]:
    """The detections in the order they became final (``t_last``; an object a later pass updated
    comes at its update)."""
    return sorted(result.detections, key=lambda d: d.t_last)


def object_cloud(result: MissionResult, upto: int) -> PointCloud:
    """The points of the first ``upto`` detections of :func:`by_time` as one ``foxglove.PointCloud``
    in ``world``."""
    dets = by_time(result)[:upto]
    rec = np.zeros(sum(len(d.points) for d in dets),
                   dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("object_id", "<u4"), ("time", "<f4")])
    k = 0
    for d in dets:
        n = len(d.points)
        p = np.asarray(d.points, dtype=np.float64).reshape(-1, 3)
        rec["x"][k:k + n], rec["y"][k:k + n], rec["z"][k:k + n] = p[:, 0], p[:, 1], p[:, 2]
        rec["object_id"][k:k + n] = d.id
        times = np.asarray(d.times, dtype=np.float64)
        rec["time"][k:k + n] = (times - result.t0_ns * 1e-9) if times.shape == (n,) else d.t_first - result.t0
        k += n
    t_ns = round(dets[-1].t_last * 1e9) if dets else result.t0_ns
    fields = [PackedElementField(name=name, offset=off, type=kind) for name, off, kind in (
        ("x", 0, PackedElementField.FLOAT32), ("y", 4, PackedElementField.FLOAT32),
        ("z", 8, PackedElementField.FLOAT32), ("object_id", 12, PackedElementField.UINT32),
        ("time", 16, PackedElementField.FLOAT32))]
    return PointCloud(timestamp=stamp(t_ns), frame_id=WORLD, pose=_pose((0, 0, 0), (0, 0, 0, 1)),
                      point_stride=rec.dtype.itemsize, fields=fields, data=rec.tobytes())


def cloud_steps(sizes: list[int], budget: int = CLOUD_BUDGET) -> list[int]:
    """Indices of the objects after which the cumulative cloud is published (see the module docstring)."""
    n = len(sizes)
    if not n:
        return []
    cum = np.cumsum(np.asarray(sizes, dtype=np.int64)) * _POINT_BYTES
    for step in range(1, n + 1):
        idx = sorted({*range(step - 1, n, step), n - 1})
        if int(cum[idx].sum()) <= budget or step == n:
            return idx
    return [n - 1]  # pragma: no cover


def messages(result: MissionResult) -> Iterator[tuple[int, str, Any]]:
    """``(log_time_ns, topic, message)`` of every message of ``results.mcap`` (not sorted)."""
    poses, t0 = result.poses, result.t0_ns
    statics = [_transform(t0, MAP, WORLD, (0, 0, 0), NED_TO_ENU)]
    if result.setup.truth:  # a simulated mission: its truth/pose channel (JSON) is in the scene's "ned" frame
        statics.append(_transform(t0, MAP, TRUTH_NED, (0, 0, 0), NED_TO_ENU))
    if result.geometry is not None:
        m = result.geometry.mounting
        statics.append(_transform(t0, BASE, SONAR, m.lever, m.rotation.as_quat()))
    for i in _thin(poses.t, 10.0):
        t_ns = t0 + round(float(poses.t[i]) * 1e9)
        tfs = [_transform(t_ns, WORLD, BASE, poses.position[i], poses.quat[i])]
        yield t_ns, "/tf", FrameTransforms(transforms=[*statics, *tfs])
        yield t_ns, "/nav/pose", PoseInFrame(timestamp=stamp(t_ns), frame_id=WORLD,
                                             pose=_pose(poses.position[i], poses.quat[i]))
    if not poses.t.size:
        yield t0, "/tf", FrameTransforms(transforms=statics)
    else:
        sel = _thin(poses.t, 1.0)
        t_start = t0 + round(float(poses.t[0]) * 1e9)
        yield t_start, "/nav/track", PosesInFrame(
            timestamp=stamp(t_start), frame_id=WORLD,
            poses=[_pose(poses.position[i], poses.quat[i]) for i in sel])
    geo = geodetic_track(result)
    meta = [KeyValuePair(key="notice", value=NO_DATUM_NOTICE)] if geo.frame_id == NO_DATUM else []
    for i in _thin(geo.t_ns * 1e-9, 1.0):
        t_ns = int(geo.t_ns[i])
        fix = LocationFix(timestamp=stamp(t_ns), frame_id=geo.frame_id, latitude=float(geo.lat[i]),
                          longitude=float(geo.lon[i]), position_covariance_type=LocationFix.UNKNOWN, metadata=meta)
        if math.isfinite(geo.depth[i]):
            fix.altitude = -float(geo.depth[i])  # m above the surface (the datum's height)
        if math.isfinite(geo.heading[i]):
            fix.heading = float(geo.heading[i])
        yield t_ns, "/nav/location", fix
    entities = []
    dets = by_time(result)
    clouds = set(cloud_steps([len(d.points) for d in dets]))
    for k, det in enumerate(dets):
        t_ns = round(det.t_last * 1e9)
        entities.append(detection_entity(det, t_ns, WORLD))
        if k in clouds:
            yield t_ns, "/objects/cloud", object_cloud(result, k + 1)
        yield t_ns, "/objects/detections", SceneUpdate(entities=entities)
    for fr in result.fan_frames:
        t_ns = t0 + round(fr.t * 1e9)
        yield t_ns, "/sonar/fan", CompressedImage(timestamp=stamp(t_ns), frame_id=FAN, data=fr.png, format="png")


def results_notice(result: MissionResult) -> dict[str, str]:
    """The ``auvlink_results`` metadata record."""
    frame = geodetic_track(result).frame_id
    return {"log": str(result.log or ""), "mode": result.mode, "detections": str(len(result.detections)),
            "world_frame": "world: local NED (m), origin " + (
                "the site datum (georeferenced)" if result.georef.get("georeferenced")
                else "the first navigation sample") + "; map: the same origin, ENU (z up)",
            "location_frame": frame, "notice": NO_DATUM_NOTICE if frame == NO_DATUM else ""}


def write_results_mcap(result: MissionResult, path: str | Path) -> Path:
    """Write ``results.mcap`` of ``result`` to ``path`` (the caller makes it atomic; see outputs.py)."""
    out = Path(path)
    msgs = sorted(messages(result), key=lambda m: (m[0], m[1]))
    seq: dict[str, int] = {}
    with open(out, "wb") as f:
        writer = Writer(f, chunk_size=1 << 20, compression=CompressionType.ZSTD, profile="")
        for t_ns, topic, msg in msgs:
            n = seq.get(topic, 0)
            seq[topic] = n + 1
            writer.write_message(topic, msg, log_time=max(0, t_ns), publish_time=max(0, t_ns), sequence=n)
        writer.add_metadata("auvlink_results", results_notice(result))
        writer.finish()
    return out

