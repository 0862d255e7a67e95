"""The site datum: NED <-> WGS84 by PROJ, exact to the millimetre over tens of km, checked against pymap3d
(an independent implementation) and pyproj's geodesic."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from auvlink.errors import ConfigError
from auvlink.geodesy import JANGIL_BAY, Datum, horizontal_distance_m


def points(n: int, radius: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ang = rng.uniform(0, 2 * np.pi, n)
    r = radius * np.sqrt(rng.uniform(0, 1, n))
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), rng.uniform(-5.0, 200.0, n)])


@pytest.mark.parametrize("site", [Datum(*JANGIL_BAY), Datum(-45.5, -170.2, 31.0), Datum(78.9, 11.9)])
def test_round_trip_below_a_millimetre_at_50_km(site: Datum) -> None:
    ned = points(2000, 50_000.0)
    ned[0] = [50_000.0, 0.0, 0.0]
    lat, lon, h = site.to_geodetic(ned)
    back = site.to_ned(lat, lon, h)
    assert back.dtype == np.float64 and back.shape == ned.shape
    assert np.abs(back - ned).max() < 1e-3


@pytest.mark.parametrize("site", [Datum(*JANGIL_BAY), Datum(-33.9, 151.3, 12.0)])
def test_agrees_with_pymap3d(site: Datum) -> None:
    ned = points(500, 50_000.0, seed=1)
    lat, lon, h = site.to_geodetic(ned)
    lat2, lon2, h2 = pymap3d.ned2geodetic(ned[:, 0], ned[:, 1], ned[:, 2], site.latitude, site.longitude,
                                          site.height)
    # angles to metres (1 deg of latitude is ~111 km): agreement far below a millimetre
    assert np.abs(lat - lat2).max() * 111_000 < 1e-4
    assert np.abs(lon - lon2).max() * 111_000 * np.cos(np.radians(site.latitude)) < 1e-4
    assert np.abs(h - h2).max() < 1e-4
    n, e, d = pymap3d.geodetic2ned(lat, lon, h, site.latitude, site.longitude, site.height)
    assert np.abs(np.column_stack([n, e, d]) - ned).max() < 1e-4


def test_surface_distance_matches_the_geodesic() -> None:
    site = Datum(*JANGIL_BAY)
    ned = np.array([[250.0 * np.cos(a), 250.0 * np.sin(a), 0.0] for a in np.linspace(0, 2 * np.pi, 9)])
    lat, lon, _ = site.to_geodetic(ned)
    d = horizontal_distance_m(site.latitude, site.longitude, lat, lon)
    assert np.allclose(d, 250.0, atol=1e-3)
    # north is north: a point 1 km north has the datum's longitude and a larger latitude
    lat1, lon1, _ = site.to_geodetic([1000.0, 0.0, 0.0])
    assert lat1[0] > site.latitude and abs(lon1[0] - site.longitude) < 1e-12


def test_datum_of_site_and_errors() -> None:
    from auvlink.validation import Site

    assert Datum.of_site(Site(36.0412, 129.3915)) == Datum(36.0412, 129.3915, 0.0)
    assert Datum.of_site(Site(36.0, None)) is None and Datum.of_site(None) is None
    with pytest.raises(ConfigError, match=r"site\.latitude"):
        Datum(91.0, 0.0)
    with pytest.raises(ConfigError, match=r"site\.longitude"):
        Datum(1.0, 200.0)
    assert Datum.from_dict({"latitude": 1.0, "longitude": 2.0}) == Datum(1.0, 2.0)
    assert Datum.from_dict(None) is None
