"""The seabed a mission covered: the area swept by the sonar's seabed onset along the track.

Highlight-extension points come only from the steepest ray of each beam (elevation +s/2 in the sonar
frame), where it meets the seabed: the *onset chord*, a short arc ahead of the vehicle across the
fan (azimuth -fov/2..+fov/2, the sonar model's field, :mod:`auvlink.sonar`). An object is seen when
that chord passes over it, so a mission's covered area is the union of the quadrilaterals swept by the
chord between consecutive track poses (each the convex hull of two consecutive chords; a shapely
union). With the default DIDSON-class geometry at 5 m altitude the chord lies about 6.6 m ahead and is
about 4.2 m wide.

Frames and units: world NED (m); a pose is (north, east) of the vehicle, heading (rad, 0 = north,
clockwise +) and altitude (m above the seabed). The sonar is placed by its mounting's yaw and pitch
plus the tilt (R_BS = Rz(yaw) Ry(pitch) Ry(-tilt), as :mod:`recon.sonar_geometry`); vehicle pitch and
roll (a few degrees in survey flight) and the lever arm (decimetres) are neglected: the chord moves
by less than the merge radius of the catalogue. Poses closer than ``step`` m to the previous kept
pose are skipped, and so are poses where the seabed onset lies outside the sonar's range window (at
the surface, diving, climbing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from auvlink.sonar import DIDSON

F64 = NDArray[np.float64]

#: half the horizontal field of view of the default sonar, rad (:data:`auvlink.sonar.DIDSON`)
DEFAULT_HALF_FOV = math.radians(DIDSON.half_fov_deg)
CHORD_POINTS = 5  # points along the onset chord (it is an arc: 5 keep it within millimetres of the arc)


@dataclass(frozen=True)
class Track:
    """Vehicle poses for coverage: north, east (m, world NED), heading (rad), altitude (m)."""

    north: F64
    east: F64
    heading: F64
    altitude: F64

    def __len__(self) -> int:
        return int(self.north.shape[0])


def track_from_positions(positions: F64, altitude: float | F64) -> Track:
    """A :class:`Track` from positions (n, 3) alone: heading from the direction of motion (the crab
    angle of a current is neglected), a constant or per-pose altitude (m)."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    d = np.diff(p[:, :2], axis=0)
    heading = np.arctan2(d[:, 1], d[:, 0]) if len(d) else np.zeros(0)
    heading = np.append(heading, heading[-1:]) if len(heading) else np.zeros(len(p))
    alt = np.broadcast_to(np.asarray(altitude, dtype=np.float64), (len(p),)).copy()
    return Track(p[:, 0].copy(), p[:, 1].copy(), heading, alt)


def onset_directions(tilt: float, spread: float, half_fov: float = DEFAULT_HALF_FOV,
                     mount_pitch: float = 0.0, mount_yaw: float = 0.0) -> F64:
    """Unit directions (CHORD_POINTS, 3) in the body frame of the steepest rays across the fan (rad)."""
    theta = np.linspace(-half_fov, half_fov, CHORD_POINTS)
    phi = spread / 2.0
    d_s = np.stack([np.cos(phi) * np.cos(theta), np.cos(phi) * np.sin(theta), np.full_like(theta, np.sin(phi))], 1)
    r_bs = Rotation.from_euler("ZY", [mount_yaw, mount_pitch - tilt])
    return np.asarray(r_bs.apply(d_s), dtype=np.float64)


def kept_poses(track: Track, directions: F64, step: float = 0.5,
               window: tuple[float, float] = (0.0, math.inf)) -> NDArray[np.intp]:
    """Indices of the poses that make the coverage: a finite, positive altitude; the whole chord inside
    the sonar's range ``window`` (start, end in m of slant range: at the surface, or high above the
    seabed, the sonar sees no seabed whatever its rays' geometry says); one pose per ``step`` m."""
    if directions[:, 2].min() <= 1e-6:  # rays that do not point down never meet the seabed
        return np.zeros(0, dtype=np.intp)
    ok = np.isfinite(track.north) & np.isfinite(track.east) & np.isfinite(track.heading)
    ok &= np.isfinite(track.altitude) & (track.altitude > 0)
    with np.errstate(invalid="ignore"):
        ranges = track.altitude[:, None] / directions[None, :, 2]  # slant range of each ray to the seabed
        ok &= (ranges.min(axis=1) >= window[0]) & (ranges.max(axis=1) <= window[1])
    keep: list[int] = []
    last = (math.nan, math.nan)
    good = np.flatnonzero(ok).tolist()
    for i in good:  # a loop over poses (thousands), not over points
        p = (float(track.north[i]), float(track.east[i]))
        if not keep or math.hypot(p[0] - last[0], p[1] - last[1]) >= step:
            keep.append(i)
            last = p
    if good and keep[-1] != good[-1]:
        keep.append(good[-1])  # the end of the track
    return np.asarray(keep, dtype=np.intp)


def onset_chords(track: Track, directions: F64, idx: NDArray[np.intp]) -> F64:
    """The seabed onset chord at the poses ``idx``: (n, CHORD_POINTS, 2) north, east (m)."""
    if idx.size == 0:
        return np.zeros((0, directions.shape[0], 2))
    scale = track.altitude[idx, None] / directions[None, :, 2]  # (n, m): range to the seabed plane
    c, s = np.cos(track.heading[idx]), np.sin(track.heading[idx])
    fwd = directions[None, :, 0] * scale
    stb = directions[None, :, 1] * scale
    north = track.north[idx, None] + c[:, None] * fwd - s[:, None] * stb
    east = track.east[idx, None] + s[:, None] * fwd + c[:, None] * stb
    return np.stack([north, east], axis=-1)


def coverage_polygon(track: Track, directions: F64, step: float = 0.5,
                     window: tuple[float, float] = (0.0, math.inf)) -> Any:
    """The covered seabed as a shapely geometry in (east, north) metres (x = east, y = north, as a map
    draws it); empty when the track has fewer than two usable poses. Consecutive kept poses more than
    ``4 * step`` apart (a gap in the track, or poses dropped in between) are not joined."""
    from shapely import MultiPoint, Polygon, unary_union

    idx = kept_poses(track, directions, step, window)
    chords = onset_chords(track, directions, idx)
    if len(chords) < 2:
        return Polygon()
    en = chords[..., ::-1]  # (east, north)
    gap = np.hypot(np.diff(track.north[idx]), np.diff(track.east[idx])) > 4 * step
    pieces = [MultiPoint(np.concatenate([en[i], en[i + 1]])).convex_hull for i in range(len(en) - 1) if not gap[i]]
    return unary_union(pieces).buffer(0)


def geometry_to_json(geom: Any, ndigits: int = 3) -> dict[str, Any]:
    """A shapely geometry as a GeoJSON geometry dict (coordinates rounded to ``ndigits``)."""
    from shapely import set_precision
    from shapely.geometry import mapping

    g = set_precision(geom, 10.0 ** -ndigits) if not geom.is_empty else geom
    out: dict[str, Any] = dict(mapping(g))
    return _lists(out)


def geometry_from_json(doc: dict[str, Any]) -> Any:
    from shapely.geometry import shape

    return shape(doc)


def _lists(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _lists(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_lists(v) for v in obj]
    return obj
