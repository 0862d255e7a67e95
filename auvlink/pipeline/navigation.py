"""The navigation solution of a mission log, as ``auvlink replay`` computes it, for ``log export``.

The navigation samples of the log go through the same path as a replay: :class:`logs_format.Replay`
(framers, codecs, drivers), the engine's router and its causal navigator
(:class:`auvlink.pipeline.engine.Engine`, classification off, no sonar frame reconstructed), with
the same time origin (a live log's stored one, else the first routed sample of any device, sonar
included), so the track is the replay's track to the last bit. ``navigation.csv`` has one row per
navigation grid time, at most ``rate_hz``:

``t_utc_s`` (s since the UNIX epoch, UTC), ``t_s`` (s since the mission's time origin), ``lat_deg``,
``lon_deg`` (WGS84, where the run is georeferenced: a ``[site]`` datum and GNSS fixes; else empty),
``north_m``, ``east_m``, ``down_m`` (the vehicle in the world frame W: local NED at the datum when
georeferenced, with the drift correction; else relative to the first navigation sample),
``roll_deg``, ``pitch_deg``, ``yaw_deg`` (R_WB as yaw-pitch-roll, yaw clockwise from north in
(-180, 180]), ``altitude_m`` (DVL altitude above the seabed, empty when stale).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from auvlink.config import VehicleConfig
from auvlink.errors import AuvlinkError
from auvlink.pipeline.engine import Engine, EngineConfig
from auvlink.pipeline.nav_inputs import NAV_FORMATS, SONAR_FORMATS
from auvlink.pipeline.object_labels import ObjectLabeller
from auvlink.pipeline.process import ADVANCE_NS, FRAME_BLOCK, dropped_live, print_warnings, read_setup
from auvlink.pipeline.results import Poses
from logs_format import MissionLogReader, Replay
from recon.frames import euler

COLUMNS = ("t_utc_s", "t_s", "lat_deg", "lon_deg", "north_m", "east_m", "down_m", "roll_deg", "pitch_deg",
           "yaw_deg", "altitude_m")


@dataclass(frozen=True)
class Navigation:
    """The solution: mission time origin (UTC ns), poses (mission s, NED m, R_WB), altitude (m),
    latitude/longitude (deg; NaN without a georeference) and W's frame (``site`` or
    ``first_navigation_sample``)."""

    t0_ns: int
    poses: Poses
    altitude: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    frame: str


def navigation_solution(log: Path, *, rate_hz: float = 10.0, config: VehicleConfig | None = None) -> Navigation:
    """The replay's navigation of ``log`` (see the module docstring)."""
    with MissionLogReader(log) as reader:
        setup, live_cfg, t0_ns, warnings = read_setup(reader, config)
        dropped = dropped_live(reader)
        sonar = [c.topic for c in reader.discover_channels().values() if c.format in SONAR_FORMATS]
        nav = [c.topic for c in reader.channels.values() if c.format in NAV_FORMATS]
        first_sonar = next((m.log_time_ns for m in reader.messages(channels=sonar)), None) if sonar else None
    print_warnings(log, warnings)
    cfg = live_cfg or EngineConfig(frame_block=FRAME_BLOCK)
    engine = Engine(setup, cfg, t0_ns=t0_ns, labeller=ObjectLabeller(False, None))
    index: dict[str, int] = {}
    last_adv: int | None = None
    with Replay(log, channels=nav) as replay:
        for sample in replay.samples():
            t_ns = sample.t_host_ns
            if dropped:  # what live dropped, replay skips (auvlink.pipeline.process.run_log)
                k = index.get(sample.device, 0)
                index[sample.device] = k + 1
                if (sample.device, k) in dropped or (sample.device, -1, t_ns) in dropped:
                    continue
            engine.feed(sample)
            if t0_ns is None and engine.t0_ns is not None and first_sonar is not None:
                engine.t0_ns = t0_ns = min(engine.t0_ns, first_sonar)  # the replay's origin: a frame may be first
            if last_adv is None:
                last_adv = t_ns
            elif t_ns - last_adv >= ADVANCE_NS:
                engine.advance(t_ns)
                last_adv = t_ns
        engine.finish()  # no sonar frame: only the navigation's end (and any end-of-mission correction)
    poses = engine.poses(rate_hz)
    if not poses.t.size:
        raise AuvlinkError(f"{log}: the navigation samples give no position (DVL, gyro and pressure are needed)")
    lat, lon = engine.georef.latlon(poses.position)
    return Navigation(engine.t0_ns or 0, poses, engine.nav.altitude_at(poses.t), lat, lon, engine.georef.frame())


def write_navigation_csv(nav: Navigation, path: Path) -> int:
    """Write ``navigation.csv`` (see the module docstring); returns the rows written."""
    yaw, pitch, roll = (np.degrees(a) for a in euler(Rotation.from_quat(nav.poses.quat)))
    p = nav.poses
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for i in range(p.t.size):
            alt = nav.altitude[i]
            w.writerow([f"{nav.t0_ns * 1e-9 + p.t[i]:.6f}", f"{p.t[i]:.6f}",
                        *(f"{v:.9f}" if np.isfinite(v) else "" for v in (nav.lat[i], nav.lon[i])),
                        *(f"{v:.6f}" for v in p.position[i]),
                        f"{roll[i]:.4f}", f"{pitch[i]:.4f}", f"{yaw[i]:.4f}",
                        f"{alt:.4f}" if np.isfinite(alt) else ""])
    return int(p.t.size)
