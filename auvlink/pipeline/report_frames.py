"""The sonar frames that saw each detection, as small fan-shaped PNGs for the report.

For every detection the log's imaging-sonar frames logged between its first and last sighting
(``t_first .. t_last``, receive time) are read back through the live framers and codecs, a few of
them picked evenly, and each drawn as a fan (range/azimuth geometry, :mod:`logs_format.fan`; far
range at the top, starboard right) at a reduced resolution, so a mission's report stays a few MB.
"""

from __future__ import annotations

import base64
import io
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg", force=False)
import matplotlib.image as mpimg
import numpy as np

from auvlink import formats
from auvlink.errors import AuvlinkError
from auvlink.pipeline.results import Detection
from logs_format import LogError, MissionLogReader
from logs_format.fan import FanGrid, fan_grid, render_fan, sonar_geometry

SONAR_FORMATS = ("didson", "aris")
FAN_HEIGHT_PX = 180  # picture height; the width follows the fan's aperture


@dataclass(frozen=True)
class FanPicture:
    """One sonar frame drawn as a fan: ``png_b64`` (base64 PNG), its log time (s since the epoch)."""

    t: float
    png_b64: str
    range_m: tuple[float, float]  # near and far range of the frame's window
    ringed: bool = False  # the object's place is drawn (a cyan ring)


def _png(picture: np.ma.MaskedArray, vmax: float, ring: tuple[float, float, float] | None = None) -> str:
    """The fan as a base64 PNG (inferno, transparent outside the fan); ``ring`` = (row, column, radius)
    px draws a cyan circle there (the object)."""
    rgba = matplotlib.colormaps["inferno"](np.clip(np.ma.filled(picture.astype(np.float32), 0.0) / vmax, 0.0, 1.0))
    rgba[np.ma.getmaskarray(picture)] = 0.0
    if ring is not None:
        rows, cols = np.indices(rgba.shape[:2])
        d = np.hypot(rows - ring[0], cols - ring[1])
        rgba[np.abs(d - ring[2]) <= 1.0] = (0.0, 1.0, 1.0, 1.0)
    buf = io.BytesIO()
    mpimg.imsave(buf, rgba, format="png")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _interp(track: Mapping[str, np.ndarray], t: float) -> tuple[float, float, float, float] | None:
    """Vehicle north, east, depth (m) and heading (rad) at ``t`` (s since the epoch) from the track
    columns (``time``, ``north``, ``east``, ``depth``, ``heading`` deg), or None outside it."""
    tt = track.get("time")
    if tt is None or len(tt) < 2 or not tt[0] <= t <= tt[-1]:
        return None
    n, e, z = (float(np.interp(t, tt, track[k])) for k in ("north", "east", "depth"))
    h = float(np.interp(t, tt, np.unwrap(np.radians(np.asarray(track["heading"], dtype=np.float64)))))
    return n, e, z, h


def object_in_fan(det: Detection, pose: tuple[float, float, float, float]) -> tuple[float, float]:
    """Where ``det`` appears in the fan picture of a frame taken at ``pose`` (vehicle north, east,
    depth m, heading rad): (x starboard, y forward) m in the fan's plane, from the slant range and the
    azimuth of the object's centre (the sonar at the vehicle's position: its lever arm is left out)."""
    dn, de = det.position_ned[0] - pose[0], det.position_ned[1] - pose[1]
    dz = det.position_ned[2] - pose[2]
    fwd = dn * np.cos(pose[3]) + de * np.sin(pose[3])
    stb = -dn * np.sin(pose[3]) + de * np.cos(pose[3])
    r = float(np.sqrt(fwd * fwd + stb * stb + dz * dz))
    theta = float(np.arctan2(stb, np.hypot(fwd, dz)))
    return r * float(np.sin(theta)), r * float(np.cos(theta))


def _pick(times: list[int], k: int) -> list[int]:
    if len(times) <= k:
        return list(range(len(times)))
    return sorted({round(float(x)) for x in np.linspace(0, len(times) - 1, k)})


def detection_frames(log: Path | None, detections: list[Detection], per_detection: int = 3,
                     track: Mapping[str, np.ndarray] | None = None) -> dict[int, list[FanPicture]]:
    """Up to ``per_detection`` fan pictures per detection id (empty when the log is gone, has no
    sonar channel or no frame in the window). A damaged log gives what can be read. With the track
    (``MissionResult.track_info``) each picture rings where the object is (:func:`object_in_fan`)."""
    out: dict[int, list[FanPicture]] = {d.id: [] for d in detections}
    if log is None or not detections or not Path(log).is_file():
        return out
    try:
        with MissionLogReader(log) as reader:
            channels = [c.topic for c in reader.channels.values() if c.format in SONAR_FORMATS]
            if not channels:
                return out
            grids: dict[tuple[int, float, float, float, float], FanGrid] = {}
            for det in detections:
                start, end = int(det.t_first * 1e9), int(det.t_last * 1e9) + 1
                msgs = list(reader.messages(channels=channels[:1], start_ns=start, end_ns=end))
                for m in (msgs[i] for i in _pick([m.log_time_ns for m in msgs], per_detection)):
                    pose = _interp(track, m.log_time_ns * 1e-9) if track else None
                    pic = _fan(m.format or "", m.data, m.log_time_ns, grids, det, pose)
                    if pic is not None:
                        out[det.id].append(pic)
    except (LogError, OSError):
        return out  # the report shows what it has; the log's damage is reported elsewhere
    return out


def _fan(fmt_name: str, data: bytes, t_ns: int, grids: dict[tuple[int, float, float, float, float], FanGrid],
         det: Detection, pose: tuple[float, float, float, float] | None) -> FanPicture | None:
    try:
        fmt = formats.get(fmt_name)
        framer = fmt.framer()
        raws = framer.feed(data) + framer.flush()
        if not raws:
            return None
        geom = sonar_geometry(fmt.decode(raws[0]))
    except (AuvlinkError, LogError, ValueError):
        return None
    if geom is None:
        return None
    image, ranges, az = geom
    key = (len(ranges), float(ranges[0]), float(ranges[-1]), float(az[0]), float(az[-1]))
    grid = grids.get(key)
    if grid is None:
        span = float(ranges.max()) - float(ranges.min()) * float(np.cos(np.abs(az).max()))
        grid = grids[key] = fan_grid(ranges, az, px_per_m=FAN_HEIGHT_PX / max(span, 1e-3))
    vmax = max(float(np.percentile(image, 99.5)), 1.0)
    ring = None
    if pose is not None:
        x, y = object_in_fan(det, pose)
        radius = max(0.6, 0.5 * max(det.size[:2])) * grid.px_per_m
        ring = ((grid.y_max - y) * grid.px_per_m, (x - grid.x_min) * grid.px_per_m, radius)
    picture = _png(render_fan(image, grid), vmax, ring)
    return FanPicture(t_ns * 1e-9, picture, (float(ranges.min()), float(ranges.max())), ring is not None)
