"""Reference frames, attitudes, mountings and the RDI vendor frames (converted once, here).

Conventions (docs ARCHITECTURE.md): world W is local NED (float64 metres); body B is FRD;
attitude is (yaw, pitch, roll) with R_WB = Rz(yaw) Ry(pitch) Rx(roll), i.e. scipy's intrinsic
``Rotation.from_euler("ZYX", [yaw, pitch, roll])``. A :class:`Mounting` places an instrument frame
X in B: a lever arm (metres, in B) and the rotation R_BX (vectors in X -> vectors in B).

RDI (Teledyne RD Instruments "ADCP Coordinate Transformation", P/N 951-6079) frames:
- ship coordinates (starboard, forward, up) -> FRD: (forward, starboard, -up);
- earth coordinates (east, north, up) -> NED: (north, east, -up);
- instrument coordinates (X, Y, Z) -> B through the configured DVL mounting; for a down-looking unit
  with beam 3 forward and no heading misalignment, instrument axes are the ship axes, which is the
  default :func:`rdi_instrument_mounting`.
PD0 bottom-track velocity is the bottom moving relative to the instrument, so the velocity of the
instrument over the ground is its negative (PD4/5/6 already report the vehicle moving).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.errors import GeometryError

F64 = NDArray[np.float64]

#: Axis swap shared by RDI ship -> FRD and RDI earth -> NED (a reflection-free proper rotation:
#: det = +1): out = (in[1], in[0], -in[2]).
RDI_SWAP = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])

VelocityFrame = Literal["ship", "earth", "instrument", "body", "ned"]


def attitude(yaw: ArrayLike, pitch: ArrayLike, roll: ArrayLike) -> Rotation:
    """R_WB from yaw (heading, clockwise +), pitch (nose up +) and roll (starboard down +), radians."""
    y, p, r = np.broadcast_arrays(np.asarray(yaw, float), np.asarray(pitch, float), np.asarray(roll, float))
    if y.ndim == 0:
        return Rotation.from_euler("ZYX", [float(y), float(p), float(r)])
    return Rotation.from_euler("ZYX", np.stack([y, p, r], axis=-1))


def euler(rot: Rotation) -> tuple[F64, F64, F64]:
    """(yaw, pitch, roll) in radians of R_WB; yaw wrapped to (-pi, pi]."""
    ypr = np.asarray(rot.as_euler("ZYX"), dtype=np.float64)
    return ypr[..., 0], ypr[..., 1], ypr[..., 2]


def check_attitude(rot: Rotation, max_abs_pitch: float = np.deg2rad(80.0)) -> None:
    """Raise :class:`GeometryError` for attitudes the sonar geometry cannot serve.

    Near pitch +-90 deg yaw and roll are not defined (gimbal lock) and the fan no longer looks at
    the seabed; the test is |R_WB[2, 0]| = |sin pitch| <= sin(max_abs_pitch), no Euler extraction.
    """
    m = rot.as_matrix().reshape(-1, 3, 3)
    s = np.abs(m[:, 2, 0])
    if not np.all(np.isfinite(m)):
        raise GeometryError("attitude has non-finite components")
    if np.any(s > np.sin(max_abs_pitch)):
        worst = float(np.rad2deg(np.arcsin(min(1.0, float(s.max())))))
        raise GeometryError(
            f"pitch of {worst:.1f} deg is beyond the {np.rad2deg(max_abs_pitch):.0f} deg the sonar "
            "geometry serves (near +-90 deg yaw and roll are undefined)"
        )


@dataclass(frozen=True)
class Mounting:
    """An instrument frame X in body B: lever arm (m, in B) and rotation R_BX as a quaternion."""

    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # scipy order (x, y, z, w)
    _rot: Rotation = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        lever = np.asarray(self.lever_arm, dtype=float)
        if lever.shape != (3,) or not np.all(np.isfinite(lever)):
            raise GeometryError(f"lever arm must be 3 finite numbers, got {self.lever_arm!r}")
        object.__setattr__(self, "_rot", Rotation.from_quat(self.quat))

    @classmethod
    def from_rotation(cls, rot: Rotation, lever_arm: ArrayLike = (0.0, 0.0, 0.0)) -> Mounting:
        q = rot.as_quat()
        la = np.asarray(lever_arm, dtype=float)
        return cls((float(la[0]), float(la[1]), float(la[2])),
                   (float(q[0]), float(q[1]), float(q[2]), float(q[3])))

    @classmethod
    def from_euler(cls, yaw: float = 0.0, pitch: float = 0.0, roll: float = 0.0,
                   lever_arm: ArrayLike = (0.0, 0.0, 0.0)) -> Mounting:
        """Mounting rotated by (yaw, pitch, roll) in B, radians, same convention as the attitude."""
        return cls.from_rotation(attitude(yaw, pitch, roll), lever_arm)

    @classmethod
    def sonar(cls, tilt: float, lever_arm: ArrayLike = (0.0, 0.0, 0.0)) -> Mounting:
        """Sonar frame S tilted down by ``tilt`` (rad, positive looking down): R_BS = Ry(-tilt)."""
        return cls.from_euler(0.0, -tilt, 0.0, lever_arm)

    @property
    def rotation(self) -> Rotation:
        """R_BX: maps vectors in the instrument frame to the body frame."""
        return self._rot

    @property
    def lever(self) -> F64:
        return np.asarray(self.lever_arm, dtype=np.float64)


def rdi_instrument_mounting(lever_arm: ArrayLike = (0.0, 0.0, 0.0), heading_misalignment: float = 0.0,
                            up_looking: bool = False, pitch: float = 0.0, roll: float = 0.0) -> Mounting:
    """Mounting of an RDI DVL's instrument frame (X, Y, Z) in FRD.

    Down-looking, beam 3 forward: instrument X = starboard, Y = forward, Z = up (the ship axes).
    ``heading_misalignment`` (rad, clockwise +) is RDI's EA; an up-looking unit is rolled 180 deg.
    ``pitch`` and ``roll`` (rad) tilt the unit in B: R = Rz(yaw) Ry(pitch) Rx(roll) R_ship.
    """
    rot = Rotation.from_matrix(RDI_SWAP)
    if up_looking:
        rot = rot * Rotation.from_euler("y", np.pi)  # instrument Y (forward) kept, X and Z reversed
    if pitch or roll:
        rot = attitude(heading_misalignment, pitch, roll) * rot
    else:
        rot = Rotation.from_euler("z", heading_misalignment) * rot
    return Mounting.from_rotation(rot, lever_arm)


def dvl_seabed_offsets(rot_wb: Rotation, altitude: ArrayLike, mounting: Mounting) -> F64:
    """World offsets (N, 3) NED m from the body origin to the seabed point a DVL's ``altitude`` (N,) m measures.

    A DVL's altitude is the mean of its beams' ranges projected on the axis of its beam cone (RDI: each beam's
    "vertical" range, in the instrument frame), so it is the distance to the seabed along that axis, which turns
    with the vehicle: the seabed point is lever + altitude x axis, in B, rotated by the attitude ``rot_wb``. A
    vehicle that pitches with a 10 deg slope measures the distance normal to the seabed; taken as vertical, the
    seabed points lay ``altitude (1 - cos 10 deg)`` = 0.09 m too shallow at 6 m (measured on random surveys).
    The axis is the instrument Z axis in B, turned to point down (RDI's Z is up for a down-looking unit)."""
    axis = mounting.rotation.apply(np.array([0.0, 0.0, 1.0]))
    axis = axis if axis[2] >= 0.0 else -axis
    a = np.asarray(altitude, dtype=np.float64).reshape(-1)
    body = mounting.lever[None, :] + a[:, None] * axis[None, :]
    return np.asarray(rot_wb.apply(body), dtype=np.float64).reshape(-1, 3)


def rdi_ship_to_body(v: ArrayLike) -> F64:
    """RDI ship (starboard, forward, up) vectors -> FRD (forward, starboard, down)."""
    a = np.asarray(v, dtype=np.float64)
    return np.stack([a[..., 1], a[..., 0], -a[..., 2]], axis=-1)


def rdi_earth_to_ned(v: ArrayLike) -> F64:
    """RDI earth (east, north, up) vectors -> NED (north, east, down)."""
    a = np.asarray(v, dtype=np.float64)
    return np.stack([a[..., 1], a[..., 0], -a[..., 2]], axis=-1)


def bottom_track_to_vehicle(bt: ArrayLike) -> F64:
    """PD0 bottom-track velocity (bottom relative to the instrument) -> instrument over ground."""
    return -np.asarray(bt, dtype=np.float64)


def to_body(v: ArrayLike, frame: VelocityFrame, mounting: Mounting | None = None) -> F64:
    """Vectors reported in ``frame`` ('ship', 'instrument' or 'body') expressed in FRD body axes."""
    a = np.asarray(v, dtype=np.float64)
    if frame == "body":
        return a
    if frame == "ship":
        return rdi_ship_to_body(a)
    if frame == "instrument":
        m = mounting if mounting is not None else rdi_instrument_mounting()
        return np.asarray(m.rotation.apply(a.reshape(-1, 3)), dtype=np.float64).reshape(a.shape)
    raise GeometryError(f"frame {frame!r} is not fixed to the body (use to_ned for 'earth'/'ned')")


def to_ned(v: ArrayLike, frame: VelocityFrame, rot_wb: Rotation | None = None,
           mounting: Mounting | None = None) -> F64:
    """Vectors reported in ``frame`` expressed in NED; body-fixed frames need the attitude R_WB."""
    a = np.asarray(v, dtype=np.float64)
    if frame == "ned":
        return a
    if frame == "earth":
        return rdi_earth_to_ned(a)
    if rot_wb is None:
        raise GeometryError(f"frame {frame!r} needs the attitude R_WB to reach NED")
    b = to_body(a, frame, mounting)
    return np.asarray(rot_wb.apply(b.reshape(-1, 3)), dtype=np.float64).reshape(a.shape)
