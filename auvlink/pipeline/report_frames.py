"""The sonar frames that saw each detection, as small fan-shaped PNGs for the report.

For every detection the log's imaging-sonar frames logged between its first and last sighting
(``t_first .. t_last``, receive time) are read back through the live framers and codecs, a few of
them picked evenly, and each drawn as a fan (range/azimuth geometry, :mod:`logs_format.fan`; far
range at the top, starboard right) at a reduced resolution, so a mission's report stays a few MB.
"""

from __future__ import annotations

import base64
import io
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


def _png(picture: np.ma.MaskedArray, vmax: float) -> str:
    buf = io.BytesIO()
    data = np.ma.filled(picture.astype(np.float32), np.nan)
    mpimg.imsave(buf, data, cmap="inferno", vmin=0.0, vmax=vmax, format="png")
    return base64.b64encode(buf.getvalue()).decode("ascii")


def _pick(times: list[int], k: int) -> list[int]:
    if len(times) <= k:
        return list(range(len(times)))
    return sorted({round(float(x)) for x in np.linspace(0, len(times) - 1, k)})


def detection_frames(log: Path | None, detections: list[Detection], per_detection: int = 3
                     ) -> dict[int, list[FanPicture]]:
    """Up to ``per_detection`` fan pictures per detection id (empty when the log is gone, has no
    sonar channel or no frame in the window). A damaged log gives what can be read."""
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
                    pic = _fan(m.format or "", m.data, m.log_time_ns, grids)
                    if pic is not None:
                        out[det.id].append(pic)
    except (LogError, OSError):
        return out  # the report shows what it has; the log's damage is reported elsewhere
    return out


def _fan(fmt_name: str, data: bytes, t_ns: int, grids: dict[tuple[int, float, float, float, float], FanGrid]
         ) -> FanPicture | None:
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
    return FanPicture(t_ns * 1e-9, _png(render_fan(image, grid), vmax), (float(ranges.min()), float(ranges.max())))
