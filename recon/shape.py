"""The horizontal footprint of an object's points: orientation, length and width (an oriented box).

The principal horizontal axis is the eigenvector of the largest eigenvalue of the (N, E) covariance
of the points. ``yaw_deg`` is its direction as a heading in the world frame W (local NED): degrees
clockwise from north toward east, in [0, 180) (an axis has no sense: 30 and 210 are the same).
``length_m`` and ``width_m`` are the full spans (max - min) of the points along and across that
axis, ``height_m`` the span in down; ``centre`` is the middle of those spans (N, E, D), the centre
of the oriented box that holds every point. Pure numpy; one object at a time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class OrientedBox:
    """An object's oriented bounding box in W (NED, m); see the module docstring."""

    centre: tuple[float, float, float]
    yaw_deg: float
    length_m: float
    width_m: float
    height_m: float


def oriented_box(points: ArrayLike) -> OrientedBox:
    """The oriented box of (N, 3) NED points (a point or none: zero spans, yaw 0)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if p.shape[0] == 0:
        return OrientedBox((0.0, 0.0, 0.0), 0.0, 0.0, 0.0, 0.0)
    xy = p[:, :2]
    mean = xy.mean(axis=0)
    d = xy - mean
    if p.shape[0] >= 2 and np.any(d):
        w, v = np.linalg.eigh(d.T @ d)
        axis = v[:, int(np.argmax(w))]
    else:
        axis = np.array([1.0, 0.0])
    if axis[0] < 0 or (axis[0] == 0 and axis[1] < 0):
        axis = -axis
    across = np.array([-axis[1], axis[0]])
    a, c = d @ axis, d @ across
    a_mid, c_mid = (a.max() + a.min()) / 2, (c.max() + c.min()) / 2
    centre_xy = mean + a_mid * axis + c_mid * across
    z0, z1 = float(p[:, 2].min()), float(p[:, 2].max())
    yaw = float(np.degrees(np.arctan2(axis[1], axis[0]))) % 180.0
    yaw = 0.0 if yaw >= 180.0 else yaw  # -1e-17 % 180 rounds to 180
    return OrientedBox((float(centre_xy[0]), float(centre_xy[1]), (z0 + z1) / 2), yaw,
                       float(a.max() - a.min()), float(c.max() - c.min()), z1 - z0)
