"""The simulated GNSS receiver: antenna fixes at the surface, fix quality 0 under water, as NMEA sentences.

At every ``k / rate_hz`` of mission time (:mod:`auvlink.sim.gnss_config`) the antenna's true position
(body origin + ``R_WB`` x lever arm, world NED) gets white horizontal noise of ``sigma_m`` per axis
(and twice that vertically) and becomes WGS84 latitude, longitude and ellipsoidal height through the
scene's datum (:class:`auvlink.geodesy.Datum`, PROJ). While the antenna is under water (its depth > 0)
the receiver has no fix: it still sends its sentences, empty, with fix quality 0 and status V, as real
receivers do. Each fix goes out as ``GGA``, ``RMC`` and ``ZDA`` (:mod:`auvlink.codecs.nmea`; the
mission's UTC start from the sensor settings).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from auvlink.codecs import nmea
from auvlink.geodesy import Datum
from auvlink.sim.gnss_config import Gnss
from auvlink.sim.noise import stream_rng
from auvlink.sim.trajectory import LawnmowerTrajectory

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class GnssSeries:
    """Every fix of a run (n rows); NaN position where the antenna is under water (no fix)."""

    t: F64  # s, mission time
    valid: NDArray[np.bool_]
    antenna_ned: F64  # (n, 3) measured antenna position, W (NaN without a fix)
    latitude: F64  # deg
    longitude: F64  # deg
    height: F64  # m above the WGS84 ellipsoid
    speed: F64  # m/s over ground (true)
    course: F64  # rad, over ground (true)
    config: Gnss

    def __len__(self) -> int:
        return int(self.t.shape[0])


def simulate_gnss(traj: LawnmowerTrajectory, t: F64, gnss: Gnss, site: Datum, seed: int) -> GnssSeries:
    """The receiver's fixes at mission times ``t`` (see the module docstring)."""
    n = t.shape[0]
    pose = traj.true_pose(t)
    antenna = pose.position + pose.rotation().apply(np.asarray(gnss.lever_arm, float)) if n else np.zeros((0, 3))
    valid = np.asarray(antenna[:, 2] <= 0.0, bool)
    noise = np.zeros((n, 3))
    if gnss.sigma_m > 0.0 and n:
        noise = stream_rng(seed, "gnss", "position").normal(0.0, 1.0, (n, 3)) * \
            np.array([gnss.sigma_m, gnss.sigma_m, 2.0 * gnss.sigma_m])
    meas = np.where(valid[:, None], antenna + noise, np.nan)
    lat, lon, h = site.to_geodetic(meas) if n else (np.zeros(0), np.zeros(0), np.zeros(0))
    v = pose.velocity_ned
    return GnssSeries(t=t, valid=valid, antenna_ned=meas, latitude=lat, longitude=lon, height=h,
                      speed=np.hypot(v[:, 0], v[:, 1]), course=np.mod(np.arctan2(v[:, 1], v[:, 0]), 2 * math.pi),
                      config=gnss)


def _fix(g: GnssSeries, k: int) -> tuple[float | None, float | None]:
    return (float(g.latitude[k]), float(g.longitude[k])) if g.valid[k] else (None, None)


def gga_frame(g: GnssSeries, k: int, start_s: float) -> bytes:
    lat, lon = _fix(g, k)
    c = g.config
    utc = start_s + float(g.t[k])
    if lat is None:
        return nmea.encode(nmea.build_gga(utc % 86400.0, None, None, quality=0))
    return nmea.encode(nmea.build_gga(utc % 86400.0, lat, lon, quality=c.quality, satellites=c.satellites,
                                      hdop=c.hdop, altitude_m=float(g.height[k])))


def rmc_frame(g: GnssSeries, k: int, start_s: float) -> tuple[bytes, float]:
    lat, lon = _fix(g, k)
    rec = nmea.build_rmc(start_s + float(g.t[k]), lat, lon, speed_mps=float(g.speed[k]),
                         course_rad=float(g.course[k]))
    return nmea.encode(rec), float(rec.utc or 0.0)


def zda_frame(g: GnssSeries, k: int, start_s: float) -> tuple[bytes, float]:
    rec = nmea.build_zda(start_s + float(g.t[k]))
    return nmea.encode(rec), float(rec.utc or 0.0)
