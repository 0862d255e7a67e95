"""GNSS anchoring: the start anchor (lever arm applied), the closure error and its linear correction, and a
receiver that sends garbage, drops out, reports fix quality 0 or wild positions: counted, never an anchor."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from auvlink.codecs import nmea
from auvlink.geodesy import Datum
from auvlink.pipeline.georef import Georef, gnss_payload
from recon.nav_anchor import AnchorConfig, GnssAnchor

SITE = Datum(36.0412, 129.3915)
LEVER = (0.3, 0.1, -0.6)


class FakeNav:
    """Dead reckoning in its own frame D = W - TRUE_OFFSET, drifting ``drift`` m/s east after the dive."""

    TRUE_OFFSET = np.array([-120.0, 85.0])

    def __init__(self, t_dive: float, drift: float = 0.0, yaw: float = 0.7, covered_from: float = 0.0) -> None:
        self.t_dive, self.drift, self.yaw, self.covered_from = t_dive, drift, yaw, covered_from

    def true_w(self, t: float) -> np.ndarray:  # the body origin in W, moving 1 m/s north after the dive
        return np.array([-120.0 + max(0.0, t - self.t_dive), 85.0])

    def depth(self, t: float) -> float:
        return 0.0 if t < self.t_dive or t > self.t_dive + 100 else 10.0

    def covered(self, t: float) -> np.ndarray:
        return np.array([t >= self.covered_from])

    def pose_at(self, t: float) -> tuple[np.ndarray, Rotation]:
        d = self.true_w(t) - self.TRUE_OFFSET + [0.0, self.drift * max(0.0, t - self.t_dive)]
        return np.array([[d[0], d[1], self.depth(t)]]), Rotation.from_euler("ZYX", [[self.yaw, 0.02, -0.05]])

    def antenna_w(self, t: float) -> np.ndarray:
        _, rot = self.pose_at(t)
        return self.true_w(t) + rot.apply(LEVER)[0, :2]


def gga_bytes(t: float, ne: np.ndarray, quality: int = 2, hdop: float = 0.8) -> bytes:
    lat, lon, _ = SITE.to_geodetic([ne[0], ne[1], -0.5])
    return nmea.encode(nmea.build_gga(t % 86400, float(lat[0]), float(lon[0]), quality=quality, hdop=hdop))


def test_anchor_applies_the_lever_arm_and_corrects_linearly() -> None:
    nav = FakeNav(t_dive=20.0, drift=0.01)
    a = GnssAnchor(AnchorConfig(lever_arm=LEVER))
    for t in np.arange(0.0, 20.0, 1.0):
        p, rot = nav.pose_at(t)
        a.add_fix(t, nav.antenna_w(t), 0.8, p[0], rot, depth=float(p[0, 2]))
    a.observe_depth([19.5, 20.5, 21.0], [0.2, 2.5, 3.0])
    assert a.t_dive == 20.5
    assert np.allclose(a.start_anchor, FakeNav.TRUE_OFFSET, atol=1e-9)  # exact: the lever arm is removed
    for t in np.arange(121.0, 131.0, 1.0):
        p, rot = nav.pose_at(t)
        a.add_fix(t, nav.antenna_w(t), 0.8, p[0], rot, depth=float(p[0, 2]))
    # dead reckoning drifted 0.01 m/s east from t = 20: 1.055 m at the mean time of the fixes (125.5 s)
    assert a.closure == pytest.approx([0.0, -1.055], abs=1e-6) and a.t_closure == 125.5
    corr = a.correction_at([0.0, 20.5, 73.0, 125.5, 200.0])
    assert np.allclose(corr[:, 1], [0.0, 0.0, -0.5275, -1.055, -1.055]) and np.allclose(corr[:, 0], 0.0)
    assert a.summary()["fixes"]["used_before_dive"] == 20 and a.summary()["fixes"]["used_after_surfacing"] == 10


def test_bad_receiver_gives_counted_errors_and_no_bad_anchor() -> None:
    """Garbage bytes, cut sentences, bad checksums, dropouts, quality 0, a huge HDOP and wild jumps."""
    from auvlink.framing.nmea import NmeaFramer

    nav = FakeNav(t_dive=60.0, covered_from=2.0)
    rng = np.random.default_rng(3)
    stream = b""
    expected_no_fix = expected_hdop = expected_bad = 0
    for k, t in enumerate(np.arange(0.0, 60.0, 1.0)):
        if 20 <= t < 35:  # a dropout: nothing at all
            continue
        good = nav.antenna_w(t) + rng.normal(0, 0.3, 2)
        if k % 7 == 3:
            stream += gga_bytes(t, good, quality=0).replace(b",2,12,", b",0,12,")  # claims no fix
            stream += nmea.encode(nmea.build_gga(t, None, None))
            expected_no_fix += 1
        elif k % 11 == 5:
            stream += gga_bytes(t, good + [400.0, -250.0])  # a wild jump (multipath, a bad solution)
        elif k % 13 == 6:
            stream += gga_bytes(t, good, hdop=40.0)
            expected_hdop += 1
        else:
            stream += gga_bytes(t, good)
        stream += bytes(rng.integers(0, 256, 9, dtype=np.uint8)).replace(b"$", b"#")  # line noise
        if k % 5 == 0:
            stream += b"$GNGGA,1200"  # a sentence cut short
        if k % 9 == 0:
            stream += gga_bytes(t, good).replace(b"*", b"5*")  # checksum mismatch
            expected_bad += 1
    fr = NmeaFramer()
    geo = Georef(SITE, LEVER, has_gnss=True)
    fixes = 0
    for i in range(0, len(stream), 17):
        for frame in fr.feed(stream[i : i + 17]):
            rec = nmea.decode(frame)
            payload = gnss_payload(rec, True)
            assert payload is not None
            geo.on_fix(rec.time_s if math.isfinite(rec.time_s) else -1.0, payload, nav)  # type: ignore[union-attr]
            fixes += 1
    assert fr.stats.bad_checksums == expected_bad and fr.stats.dropped_bytes > 0
    s = geo.summary()
    assert s["fixes"]["no_fix"] >= expected_no_fix and s["fixes"]["poor_hdop"] == expected_hdop
    assert s["fixes"]["outliers"] >= 3 and s["fixes"]["before_navigation"] >= 1
    off = geo.offset
    assert off is not None and np.linalg.norm(off - FakeNav.TRUE_OFFSET) < 0.3  # the anchor is good


def test_only_no_fix_gives_no_anchor_and_says_so() -> None:
    nav = FakeNav(t_dive=30.0)
    geo = Georef(SITE, LEVER, has_gnss=True)
    for t in np.arange(0.0, 30.0):
        geo.on_fix(t, gnss_payload(nmea.build_gga(t, None, None), True), nav)  # type: ignore[arg-type]
    s = geo.summary()
    assert geo.offset is None and not s["georeferenced"] and s["frame"] == "first_navigation_sample"
    assert s["fixes"]["no_fix"] == 30
    assert np.all(geo.shift([1.0, 2.0], corrected=True) == 0.0)


def test_two_wild_fixes_of_three_give_no_anchor() -> None:
    a = GnssAnchor(AnchorConfig())
    for t, r in ((0.0, [0.0, 0.0]), (1.0, [300.0, 0.0]), (2.0, [0.0, -500.0])):
        a.add_fix(t, r, 1.0, [0.0, 0.0, 0.0], depth=0.0)
    assert a.start_anchor is None  # fewer than min_fixes inliers: no anchor rather than a bad one


def test_adaptor_takes_gga_and_rmc_only_from_receivers_without_gga() -> None:
    from auvlink.pipeline.nav_inputs import NavAdaptor
    from auvlink.records import Sample

    gga = nmea.build_gga(10.0, 36.0412, 129.3915)
    rmc = nmea.build_rmc(1767225610.0, 36.0412, 129.3915)
    zda = nmea.build_zda(1767225610.0)

    def sample(dev: str, rec: object, k: int) -> Sample:
        return Sample(dev, "nmea", k, b"", rec)

    r = NavAdaptor()
    assert r.route(sample("rmc_only", rmc, 1)).kind == "gnss"  # type: ignore[union-attr]
    assert r.route(sample("rmc_only", zda, 2)) is None
    ev = r.route(sample("gga", gga, 3))
    assert ev is not None and ev.kind == "gnss" and ev.payload.quality == 2
    assert r.route(sample("gga", rmc, 4)) is None  # GGA carries the fix; RMC would count it twice
    nofix = gnss_payload(nmea.build_rmc(1767225611.0, None, None), False)
    assert nofix is not None and nofix.quality == 0 and math.isnan(nofix.latitude)
