"""A vehicle trajectory: times, NED positions (float64), attitudes; poses by interpolation.

:meth:`Trajectory.pose_at` interpolates position linearly and attitude by spherical linear
interpolation (scipy ``Slerp``) at any time inside the span; never the nearest sample. Heading wraps
(179 deg -> -179 deg) are handled by the quaternions, not by Euler angles.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation, Slerp

from recon.errors import NavigationError
from recon.frames import attitude

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Samples of the vehicle pose, strictly increasing in time.

    ``degraded[i]`` flags a pose built without fresh DVL velocity (dropout longer than the hold
    time) or across a sensor gap; ``altitude`` is metres above the seabed (NaN where unknown);
    ``seabed_offsets`` (optional, (n, 3) NED m) go from each position to the seabed point the DVL measured
    (:func:`recon.frames.dvl_seabed_offsets`), where the altitude alone would put it straight below.
    """

    times: F64
    positions: F64
    rotations: Rotation
    degraded: NDArray[np.bool_] | None = None
    altitude: F64 | None = None
    seabed_offsets: F64 | None = None
    _slerp: Slerp = field(init=False, repr=False)

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=np.float64)
        p = np.asarray(self.positions, dtype=np.float64)
        n = t.shape[0]
        if t.ndim != 1 or n < 2:
            raise NavigationError(f"a trajectory needs at least 2 samples, got {t.shape}")
        if p.shape != (n, 3):
            raise NavigationError(f"positions must be ({n}, 3), got {p.shape}")
        if len(self.rotations) != n:
            raise NavigationError(f"{len(self.rotations)} attitudes for {n} times")
        if not np.all(np.diff(t) > 0):
            raise NavigationError("trajectory times must be strictly increasing (sort, drop duplicates)")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(p))):
            raise NavigationError("trajectory times and positions must be finite")
        deg = np.zeros(n, bool) if self.degraded is None else np.asarray(self.degraded, dtype=bool)
        alt = np.full(n, np.nan) if self.altitude is None else np.asarray(self.altitude, dtype=np.float64)
        if deg.shape != (n,) or alt.shape != (n,):
            raise NavigationError("degraded and altitude must have one value per sample")
        if self.seabed_offsets is not None and np.shape(self.seabed_offsets) != (n, 3):
            raise NavigationError(f"seabed_offsets must be ({n}, 3), got {np.shape(self.seabed_offsets)}")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "positions", p)
        object.__setattr__(self, "degraded", deg)
        object.__setattr__(self, "altitude", alt)
        object.__setattr__(self, "_slerp", Slerp(t, self.rotations))

    @classmethod
    def from_euler(cls, times: ArrayLike, positions: ArrayLike, yaw: ArrayLike, pitch: ArrayLike,
                   roll: ArrayLike, altitude: ArrayLike | None = None) -> Trajectory:
        """From true poses (e.g. the simulator's): NED positions and yaw/pitch/roll in radians."""
        t = np.asarray(times, dtype=np.float64)
        alt = None if altitude is None else np.asarray(altitude, dtype=np.float64)
        return cls(t, np.asarray(positions, dtype=np.float64), attitude(yaw, pitch, roll), altitude=alt)

    @property
    def span(self) -> tuple[float, float]:
        return float(self.times[0]), float(self.times[-1])

    def __len__(self) -> int:
        return int(self.times.shape[0])

    def _check(self, t: F64) -> None:
        t0, t1 = self.span
        if t.size and (not np.all(np.isfinite(t)) or t.min() < t0 or t.max() > t1):
            bad = t[~((t >= t0) & (t <= t1))]
            raise NavigationError(f"time {float(bad[0]) if bad.size else float('nan')!r} is outside "
                                  f"the trajectory span [{t0!r}, {t1!r}]")

    def pose_at(self, t: ArrayLike) -> tuple[F64, Rotation]:
        """Positions (n, 3) and attitudes R_WB (n) at times ``t`` (linear position, slerp attitude)."""
        ta = np.atleast_1d(np.asarray(t, dtype=np.float64))
        self._check(ta)
        pos = np.empty((ta.shape[0], 3), dtype=np.float64)
        for k in range(3):
            pos[:, k] = np.interp(ta, self.times, self.positions[:, k])
        return pos, self._slerp(ta)

    def altitude_at(self, t: ArrayLike) -> F64:
        """Altitude above the seabed at ``t`` (linear; NaN where either neighbour is unknown)."""
        ta = np.atleast_1d(np.asarray(t, dtype=np.float64))
        self._check(ta)
        alt = self.altitude
        assert alt is not None
        i = np.clip(np.searchsorted(self.times, ta, side="right") - 1, 0, len(self) - 2)
        w = (ta - self.times[i]) / (self.times[i + 1] - self.times[i])
        return (1.0 - w) * alt[i] + w * alt[i + 1]

    def degraded_at(self, t: ArrayLike) -> NDArray[np.bool_]:
        """True where the pose at ``t`` leans on a degraded sample (either neighbour)."""
        ta = np.atleast_1d(np.asarray(t, dtype=np.float64))
        self._check(ta)
        deg = self.degraded
        assert deg is not None
        i = np.clip(np.searchsorted(self.times, ta, side="right") - 1, 0, len(self) - 2)
        exact = ta == self.times[i]
        return np.where(exact, deg[i], deg[i] | deg[i + 1])

    def seabed_points(self) -> F64:
        """Seabed points the DVL measured, where known: position + ``seabed_offsets``, else + altitude along NED
        down."""
        alt = self.altitude
        assert alt is not None
        ok = np.isfinite(alt)
        if self.seabed_offsets is not None:
            ok &= np.all(np.isfinite(self.seabed_offsets), axis=1)
            return np.asarray(self.positions[ok] + self.seabed_offsets[ok], dtype=np.float64)
        pts = self.positions[ok].copy()
        pts[:, 2] += alt[ok]
        return pts

    def shifted(self, offset: ArrayLike) -> Trajectory:
        """The same trajectory translated by ``offset`` (NED metres); for tests and tiling."""
        off = np.asarray(offset, dtype=np.float64).reshape(1, 3)
        return Trajectory(self.times, self.positions + off, self.rotations, self.degraded, self.altitude,
                          self.seabed_offsets)
