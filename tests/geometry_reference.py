"""An independent reference of the sonar geometry, written from docs ARCHITECTURE.md only (no recon code).

A return at range r, azimuth theta (+ starboard), elevation phi (+ down from boresight) lies at
p_S = r [cos phi cos theta, cos phi sin theta, sin phi] in the sonar frame S; the highlight-extension
point takes phi = +s/2 (the steepest ray). S is mounted in body B (FRD) pitched down by the tilt t,
then by the mounting's roll/pitch/yaw, with a lever arm; B is placed in the world (NED) by
R_WB = Rz(yaw) Ry(pitch) Rx(roll). Rotations are composed one elementary axis at a time with scipy.
Row m of the image is range r_m = start + (m + 1/2) length / bins; beam n of a linear fan has azimuth
-fov/2 + n fov / (beams - 1).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation


def r_wb(yaw: float, pitch: float, roll: float) -> Rotation:
    """R_WB = Rz(yaw) Ry(pitch) Rx(roll), radians (a product of three elementary rotations)."""
    return Rotation.from_rotvec([0, 0, yaw]) * Rotation.from_rotvec([0, pitch, 0]) * Rotation.from_rotvec([roll, 0, 0])


def r_bs(tilt: float, mount_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Rotation:
    """Sonar to body: the mounting's roll/pitch/yaw, then a pitch *down* by ``tilt`` (Ry(-tilt))."""
    roll, pitch, yaw = mount_rpy
    return r_wb(yaw, pitch, roll) * Rotation.from_rotvec([0, -tilt, 0])


def p_sonar(r: float, theta: float, phi: float) -> NDArray[np.float64]:
    return r * np.array([np.cos(phi) * np.cos(theta), np.cos(phi) * np.sin(theta), np.sin(phi)])


def highlight_point(r: float, theta: float, *, tilt: float, spread: float, position: NDArray[np.float64],
                    ypr: tuple[float, float, float], lever: NDArray[np.float64],
                    mount_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> NDArray[np.float64]:
    """World point (NED, m) of a return at (r, theta) on the highlight ray phi = +s/2."""
    p_b = lever + r_bs(tilt, mount_rpy).apply(p_sonar(r, theta, spread / 2))
    return np.asarray(position + r_wb(*ypr).apply(p_b), dtype=np.float64)


def paper_point(r: float, theta: float, *, tilt: float, spread: float) -> NDArray[np.float64]:
    """The paper's equation (1) in B: elevation t + s/2 below the horizontal at every azimuth."""
    e = tilt + spread / 2
    return r * np.array([np.cos(e) * np.cos(theta), np.cos(e) * np.sin(theta), np.sin(e)])


def row_range(m: int, start: float, length: float, bins: int) -> float:
    return start + (m + 0.5) * length / bins


def beam_azimuth(n: int, fov: float, beams: int) -> float:
    return -fov / 2 + n * fov / (beams - 1)
