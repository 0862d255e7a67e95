"""Forward-scan sonar geometry: beams, range bins, the highlight ray, seabed onset.

The beams and range lines are those of :class:`auvlink.sonar.SonarDescription` (any count, uneven tables).

Sonar frame S: x boresight, y starboard, z down, mounted in B with a pitch-down tilt t (R_BS =
Ry(-t)) and a lever arm. A return at range r, azimuth theta (+ starboard), elevation phi (+ down from
boresight, |phi| <= s/2) lies at p_S = r [cos phi cos theta, cos phi sin theta, sin phi].

Range of row m (bin centre): r_m = window_start + (m + 0.5) window_length / n_bins. Beam n has the
azimuth of the device's table, or a linear fan from -fov/2 (column 0, port) to +fov/2.

Highlight-extension points lie on the steepest ray of the beam:
- ``exact`` (default): phi = +s/2 in S, rotated by the tilt: d_B = Ry(-t) [cos(s/2) cos theta,
  cos(s/2) sin theta, sin(s/2)];
- ``paper``: Sung et al.'s equation (1) approximation, elevation t + s/2 below the horizontal at every
  azimuth: d_B = [cos e cos theta, cos e sin theta, sin e], e = t + s/2. Both agree at theta = 0; the
  paper ray is steeper off-axis (see :func:`paper_minus_exact`).

Seabed onset: the range at which the beam's vertical fan first meets a seabed plane. It is the
minimum over phi in [-s/2, s/2] of H / (a cos phi + b sin phi) (H the sonar height above the plane,
a, b the approach rates of the phi = 0 direction and of the S z-axis); for any usable tilt the
minimum is at phi = +s/2, the steepest ray, but the general maximum is taken so rolled or pitched
poses stay right.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from auvlink.sonar import DEFAULT_SONAR, DIDSON, Sonar
from auvlink.sonar import Mounting as DeviceMounting
from recon.errors import GeometryError
from recon.frames import Mounting, attitude

F64 = NDArray[np.float64]
GeometryMode = Literal["exact", "paper"]
UP_NED = np.array([0.0, 0.0, -1.0])
#: the default image: the beams, field of view and samples per beam of :data:`auvlink.sonar.DIDSON` (the DIDSON
#: 300 m's data sheet); tilt, vertical spread and range window come from :data:`auvlink.sonar.DEFAULT_SONAR`
DEFAULT_BEAMS = DIDSON.n_beams
DEFAULT_BINS = DIDSON.range_lines(DEFAULT_SONAR.window_length)
DEFAULT_FOV_DEG = DIDSON.field_of_view_deg


def points_sonar(r: ArrayLike, theta: ArrayLike, phi: ArrayLike) -> F64:
    """p_S = r [cos phi cos theta, cos phi sin theta, sin phi] (broadcast), shape (..., 3)."""
    r_, th, ph = np.broadcast_arrays(np.asarray(r, float), np.asarray(theta, float), np.asarray(phi, float))
    cp = np.cos(ph)
    return np.stack([r_ * cp * np.cos(th), r_ * cp * np.sin(th), r_ * np.sin(ph)], axis=-1)


@dataclass(frozen=True)
class SonarGeometry:
    """Image layout and mounting of the sonar; angles in radians, distances in metres."""

    n_bins: int = DEFAULT_BINS
    n_beams: int = DEFAULT_BEAMS
    window_start: float = DEFAULT_SONAR.window_start
    window_length: float = DEFAULT_SONAR.window_length
    tilt: float = DEFAULT_SONAR.tilt
    spread: float = DEFAULT_SONAR.spread
    fov: float = float(np.deg2rad(DEFAULT_FOV_DEG))
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    azimuth_table: tuple[float, ...] | None = None
    #: roll, pitch, yaw (rad) of the sonar's mounting in B, applied before the tilt: R_BS = R(rpy) Ry(-tilt)
    mount_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    _az: F64 = field(init=False, repr=False, compare=False)
    _mount: Mounting = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.n_bins < 1 or self.n_beams < 1:
            raise GeometryError(f"image must have bins and beams, got {self.n_bins} x {self.n_beams}")
        if not (self.window_length > 0 and np.isfinite(self.window_start) and self.window_start >= 0):
            raise GeometryError(f"bad range window start={self.window_start} length={self.window_length}")
        if not (0 < self.spread < np.pi / 2) or not (-np.pi / 2 < self.tilt < np.pi / 2):
            raise GeometryError(f"tilt {self.tilt} rad / spread {self.spread} rad out of range")
        if self.azimuth_table is not None:
            az = np.asarray(self.azimuth_table, dtype=np.float64)
            if az.shape != (self.n_beams,) or not np.all(np.isfinite(az)) or np.any(np.abs(az) >= np.pi / 2):
                raise GeometryError(f"azimuth table must hold {self.n_beams} finite angles within +-90 deg")
        else:
            az = np.linspace(-self.fov / 2, self.fov / 2, self.n_beams)
        az.setflags(write=False)
        object.__setattr__(self, "_az", az)
        mount = Mounting.sonar(self.tilt, self.lever_arm)
        if any(self.mount_rpy):
            roll, pitch, yaw = self.mount_rpy
            mount = Mounting.from_rotation(attitude(yaw, pitch, roll) * mount.rotation, self.lever_arm)
        object.__setattr__(self, "_mount", mount)

    @classmethod
    def of(cls, sonar: Sonar, mounting: DeviceMounting | None = None, *, azimuths: ArrayLike | None = None,
           window: tuple[float, float] | None = None, n_bins: int | None = None) -> SonarGeometry:
        """The geometry of the shared sonar description and its device mounting (lever arm and rpy).

        ``azimuths`` (rad) is the device's beam table, ``window`` (start, length, m) the frames' own range
        window and ``n_bins`` their range lines; each overrides the description (:attr:`Sonar.description`: a
        linear fan by its field of view, an uneven one by its table) where the frames carry it.
        """
        m = mounting or DeviceMounting()
        d = sonar.description
        start, length = window if window is not None else d.image_window(sonar.window_start, sonar.window_length)
        fov = float(np.deg2rad(d.field_of_view_deg))
        if azimuths is not None:
            table: tuple[float, ...] | None = tuple(float(a) for a in np.asarray(azimuths, dtype=np.float64))
        else:
            table = None if d.is_linear else d.bearings_rad
        beams = d.n_beams if table is None else len(table)
        bins = n_bins if n_bins is not None else d.range_lines(length)
        return cls(n_bins=bins, n_beams=beams, window_start=start, window_length=length, tilt=sonar.tilt,
                   spread=sonar.spread, fov=fov, lever_arm=m.xyz, azimuth_table=table, mount_rpy=m.rpy)

    @classmethod
    def from_degrees(cls, tilt_deg: float = 30.0, spread_deg: float = 14.0, **kw: object) -> SonarGeometry:
        return cls(tilt=float(np.deg2rad(tilt_deg)), spread=float(np.deg2rad(spread_deg)), **kw)  # type: ignore[arg-type]

    @property
    def azimuths(self) -> F64:
        return self._az

    @property
    def ranges(self) -> F64:
        """Bin-centre ranges r_m (m)."""
        r = self.window_start + (np.arange(self.n_bins) + 0.5) * self.bin_size
        return np.asarray(r, dtype=np.float64)

    @property
    def max_range(self) -> float:
        """End of the range window (m): no return lies farther from the sonar."""
        return self.window_start + self.window_length

    @property
    def bin_size(self) -> float:
        return self.window_length / self.n_bins

    @property
    def mounting(self) -> Mounting:
        return self._mount

    def range_to_row(self, r: ArrayLike) -> F64:
        """Fractional row index of range ``r`` (inverse of r_m)."""
        return (np.asarray(r, dtype=np.float64) - self.window_start) / self.bin_size - 0.5

    def directions_body(self, phi: ArrayLike, theta: ArrayLike | None = None) -> F64:
        """Unit vectors in B of the rays (theta, phi) in S; theta defaults to the beam table."""
        th = self._az if theta is None else np.asarray(theta, dtype=np.float64)
        d_s = points_sonar(1.0, th, phi)
        return np.asarray(self._mount.rotation.apply(d_s.reshape(-1, 3)), dtype=np.float64).reshape(d_s.shape)

    def highlight_directions(self, mode: GeometryMode = "exact", theta: ArrayLike | None = None) -> F64:
        """Unit vectors in B of each beam's highlight-extension ray (see the module docstring)."""
        th = self._az if theta is None else np.asarray(theta, dtype=np.float64)
        if mode == "exact":
            return self.directions_body(0.5 * self.spread, th)
        if mode == "paper":
            e = self.tilt + 0.5 * self.spread
            ce = np.cos(e)
            return np.stack([ce * np.cos(th), ce * np.sin(th), np.full_like(th, np.sin(e))], axis=-1)
        raise GeometryError(f"unknown geometry mode {mode!r} (use 'exact' or 'paper')")

    def onset_ranges(self, position: ArrayLike, rotation: Rotation, seabed_point: ArrayLike,
                     seabed_normal: ArrayLike = UP_NED) -> F64:
        """Per frame and beam, the range at which the fan first meets the seabed plane.

        ``position`` (F, 3) and ``rotation`` (F) are the vehicle poses (R_WB); the plane passes
        through ``seabed_point`` (F, 3) with unit ``seabed_normal`` (3,) or (F, 3) pointing into
        the water. Returns (F, n_beams): inf where the fan never meets the plane, 0 below it.
        """
        pos = np.atleast_2d(np.asarray(position, dtype=np.float64))
        q = np.atleast_2d(np.asarray(seabed_point, dtype=np.float64))
        nrm = np.atleast_2d(np.asarray(seabed_normal, dtype=np.float64))
        nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
        m_wb = rotation.as_matrix().reshape(-1, 3, 3)
        m_ws = m_wb @ self._mount.rotation.as_matrix()
        origin = pos + m_wb @ self._mount.lever
        height = np.einsum("fi,fi->f", nrm, origin - q)
        n_s = np.einsum("fi,fij->fj", nrm, m_ws)  # plane normal in S
        a = -(n_s[:, :1] * np.cos(self._az) + n_s[:, 1:2] * np.sin(self._az))
        b = np.broadcast_to(-n_s[:, 2:3], a.shape)
        half = 0.5 * self.spread
        phi_star = np.arctan2(b, a)
        inside = np.abs(phi_star) <= half
        ends = np.maximum(a * np.cos(half) - b * np.sin(half), a * np.cos(half) + b * np.sin(half))
        gmax = np.where(inside, np.hypot(a, b), ends)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(gmax > 0, height[:, None] / gmax, np.inf)
        return np.where(height[:, None] <= 0, 0.0, r)

    def flat_onset_ranges(self, position: ArrayLike, rotation: Rotation, altitude: ArrayLike) -> F64:
        """:meth:`onset_ranges` for a flat seabed ``altitude`` m below the vehicle origin (NaN -> inf)."""
        pos = np.atleast_2d(np.asarray(position, dtype=np.float64))
        alt = np.atleast_1d(np.asarray(altitude, dtype=np.float64))
        q = pos.copy()
        q[:, 2] += np.where(np.isfinite(alt), alt, 0.0)
        r = self.onset_ranges(pos, rotation, q)
        return np.where(np.isfinite(alt)[:, None], r, np.inf)


def paper_minus_exact(geometry: SonarGeometry, r: float, theta: ArrayLike | None = None) -> F64:
    """Distance (m) between the ``paper`` and ``exact`` highlight points at range ``r`` per azimuth."""
    d = geometry.highlight_directions("paper", theta) - geometry.highlight_directions("exact", theta)
    return np.asarray(r * np.linalg.norm(d, axis=-1), dtype=np.float64)
