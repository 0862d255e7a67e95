"""The site datum: local NED (world frame W) <-> WGS84 latitude, longitude, ellipsoidal height, by PROJ.

W is the local tangent frame at the datum (``[site] latitude``, ``longitude``, WGS84 degrees, validated
by :class:`auvlink.validation.Site`; ``height`` above the WGS84 ellipsoid, default 0): x north, y east,
z down, metres, float64, origin on the surface at the datum. The conversion is PROJ's (pyproj) rigorous chain, nothing
written here: geodetic -> ECEF (``+proj=cart``) -> topocentric ENU at the datum
(``+proj=topocentric``), then NED = (N, E, -U). It is exact (round trip below 1e-6 m at 50 km);
what it is not is a map projection: W is flat, so a point on the sea surface s metres away lies
s^2 / (2 R) below W's horizontal plane (0.2 m at 1.6 km, 196 m at 50 km). Depths below the surface
are therefore geometric z of the tangent frame; over a survey of a few hundred metres the difference
is sub-millimetre, and both directions use the same rule, so a round trip is exact at any range.

    datum = Datum(36.0412, 129.3915)
    lat, lon, h = datum.to_geodetic(ned)          # ned: (n, 3) or (3,)
    ned = datum.to_ned(lat, lon, h)
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auvlink.errors import ConfigError

F64 = NDArray[np.float64]

#: the default site of the simulator's scenes: Jangil Bay, Pohang (Korea), where the field trial ran
JANGIL_BAY = (36.0412, 129.3915)


@functools.lru_cache(maxsize=32)
def _transformer(latitude: float, longitude: float, height: float) -> Any:
    import pyproj

    pipeline = ("+proj=pipeline +step +proj=axisswap +order=2,1 +step +proj=unitconvert +xy_in=deg +xy_out=rad "
                f"+step +proj=cart +ellps=WGS84 +step +proj=topocentric +ellps=WGS84 +lat_0={latitude!r} "
                f"+lon_0={longitude!r} +h_0={height!r}")
    return pyproj.Transformer.from_pipeline(pipeline)


@dataclass(frozen=True)
class Datum:
    """The WGS84 position of W's origin (see the module docstring)."""

    latitude: float  # deg, + north
    longitude: float  # deg, + east
    height: float = 0.0  # m above the WGS84 ellipsoid

    def __post_init__(self) -> None:
        if not (math.isfinite(self.latitude) and -90.0 < self.latitude < 90.0):
            raise ConfigError("site.latitude", f"{self.latitude} is not a latitude",
                              "use WGS84 degrees in (-90, 90), + north")
        if not (math.isfinite(self.longitude) and -180.0 <= self.longitude <= 180.0):
            raise ConfigError("site.longitude", f"{self.longitude} is not a longitude",
                              "use WGS84 degrees in [-180, 180], + east")
        if not math.isfinite(self.height):
            raise ConfigError("site.height", f"{self.height} is not a height", "use metres above the ellipsoid")

    def to_geodetic(self, ned: ArrayLike) -> tuple[F64, F64, F64]:
        """NED (n, 3) or (3,) metres -> latitude, longitude (deg) and ellipsoidal height (m), each (n,)."""
        p = np.asarray(ned, dtype=np.float64).reshape(-1, 3)
        t = _transformer(self.latitude, self.longitude, self.height)
        lat, lon, h = t.transform(p[:, 1], p[:, 0], -p[:, 2], direction="INVERSE")
        return np.asarray(lat, np.float64), np.asarray(lon, np.float64), np.asarray(h, np.float64)

    def to_ned(self, latitude: ArrayLike, longitude: ArrayLike, height: ArrayLike | None = None) -> F64:
        """Latitude, longitude (deg) and ellipsoidal height (m; default: the datum's) -> NED (n, 3) metres."""
        lat = np.atleast_1d(np.asarray(latitude, dtype=np.float64))
        lon = np.atleast_1d(np.asarray(longitude, dtype=np.float64))
        h = np.full(lat.shape, self.height) if height is None else \
            np.broadcast_to(np.asarray(height, dtype=np.float64), lat.shape).astype(np.float64)
        t = _transformer(self.latitude, self.longitude, self.height)
        e, n, u = t.transform(lat, lon, h)
        return np.stack([np.asarray(n), np.asarray(e), -np.asarray(u)], axis=-1).astype(np.float64)

    def to_dict(self) -> dict[str, float]:
        return {"latitude": self.latitude, "longitude": self.longitude, "height": self.height}

    @classmethod
    def of_site(cls, site: Any) -> Datum | None:
        """The datum of a validated ``[site]`` table (``latitude``, ``longitude``), None when absent or partial."""
        lat, lon = getattr(site, "latitude", None), getattr(site, "longitude", None)
        return None if lat is None or lon is None else cls(float(lat), float(lon))

    @classmethod
    def from_dict(cls, d: Any) -> Datum | None:
        """From ``{"latitude": .., "longitude": .., "height": ..}`` (a log's metadata); None when absent."""
        if not isinstance(d, dict) or d.get("latitude") is None or d.get("longitude") is None:
            return None
        return cls(float(d["latitude"]), float(d["longitude"]), float(d.get("height") or 0.0))


def horizontal_distance_m(lat1: ArrayLike, lon1: ArrayLike, lat2: ArrayLike, lon2: ArrayLike) -> F64:
    """Geodesic distance (m) on the WGS84 ellipsoid between two sets of points (pyproj.Geod)."""
    import pyproj

    a, b, c, d = np.broadcast_arrays(*(np.asarray(x, np.float64) for x in (lon1, lat1, lon2, lat2)))
    _, _, dist = pyproj.Geod(ellps="WGS84").inv(a.ravel(), b.ravel(), c.ravel(), d.ravel())
    return np.asarray(dist, dtype=np.float64).reshape(a.shape)
