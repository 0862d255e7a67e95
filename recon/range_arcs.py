"""The range arc of a highlight-extension return, as the 10 columns that travel with each point.

A return at range r in a beam of azimuth theta could come from any elevation phi in [-s/2, +s/2] of the
beam's vertical fan: it lies on the arc o + r (cos phi u + sin phi w) in the world frame W, with o the sonar
origin, u = R_WS [cos theta, sin theta, 0] the beam's look direction at phi = 0 and w = R_WS [0, 0, 1] the
sonar's down axis. The record is one float64 row per point: o (columns 0-2), u (3-5), w (6-8), r (9);
:class:`RangeArcs` names those columns, :func:`arc_record` builds the rows, :func:`arc_columns` builds them
for image returns (frame, beam, row) and :func:`steepest_points` places them on the steepest ray.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]
#: columns of the record: origin (3), u (3), w (3), range (1)
ARC_COLUMNS = 10


class RangeArcs(NamedTuple):
    """Named views of an (N, 10) arc record: ``origin``, ``u``, ``w`` (N, 3) and ``range_m`` (N,)."""

    origin: F64
    u: F64
    w: F64
    range_m: F64

    @classmethod
    def of(cls, arcs: ArrayLike) -> RangeArcs:
        """The columns of ``arcs`` (N, 10), as views."""
        a = np.asarray(arcs, dtype=np.float64).reshape(-1, ARC_COLUMNS)
        return cls(a[:, 0:3], a[:, 3:6], a[:, 6:9], a[:, 9])


def arc_record(origin: ArrayLike, u: ArrayLike, w: ArrayLike, range_m: ArrayLike) -> F64:
    """The (N, 10) record of the arcs o + r (cos phi u + sin phi w) from ``origin``, ``u``, ``w`` (N, 3) and
    ``range_m`` (N,)."""
    return np.column_stack([origin, u, w, range_m])


def is_arc_record(arcs: F64, n: int) -> bool:
    """True when ``arcs`` is the record of ``n`` points (an object built without arcs has none)."""
    return bool(arcs.shape == (n, ARC_COLUMNS))


def arc_columns(geometry: SonarGeometry, frame: NDArray[np.int64], beam: NDArray[np.int64],
                row: NDArray[np.int64], positions: F64, rotations: Rotation) -> F64:
    """Per image return (frame, beam, row), its range arc record: the vehicle poses ``positions`` (F, 3) and
    ``rotations`` (F, R_WB) of the frames, the sonar's mounting, azimuths and bin ranges from ``geometry``."""
    m_wb = rotations.as_matrix().reshape(-1, 3, 3)[frame]
    m_ws = m_wb @ geometry.mounting.rotation.as_matrix()
    o = np.asarray(positions, dtype=np.float64).reshape(-1, 3)[frame] + m_wb @ geometry.mounting.lever
    th = geometry.azimuths[beam]
    u = m_ws[:, :, 0] * np.cos(th)[:, None] + m_ws[:, :, 1] * np.sin(th)[:, None]
    return arc_record(o, u, m_ws[:, :, 2], geometry.ranges[row])


def steepest_points(arcs: F64, spread: float) -> F64:
    """The uncorrected (steepest-ray, phi = +spread/2, exact geometry) points of ``arcs`` (N, 10): e.g. the cloud
    a classifier trained on uncorrected highlight-extension clouds expects (``DetectedObject.extra``)."""
    return points_at(arcs, 0.5 * spread)


def points_at(arcs: F64, phi: float | F64) -> F64:
    """The points of ``arcs`` (N, 10) at elevation ``phi`` (rad below the fan's axis, one or (N,), exact geometry)."""
    a = RangeArcs.of(arcs)
    ph = np.asarray(phi, dtype=np.float64).reshape(-1, 1) if np.ndim(phi) else float(phi)
    return np.asarray(a.origin + a.range_m[:, None] * (np.cos(ph) * a.u + np.sin(ph) * a.w), dtype=np.float64)


def arc_elevations(points: F64, arcs: F64) -> F64:
    """The elevation (rad below the fan's axis, (N,)) of each of ``points`` (N, 3) on its arc (N, 10)."""
    a = RangeArcs.of(arcs)
    d = np.asarray(points, dtype=np.float64).reshape(-1, 3) - a.origin
    return np.asarray(np.arctan2(np.einsum("ni,ni->n", d, a.w), np.einsum("ni,ni->n", d, a.u)), dtype=np.float64)
