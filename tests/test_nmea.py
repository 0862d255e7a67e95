"""NMEA 0183 GNSS sentences: golden captures (a research vessel's DGPS, a u-blox without fix), exact round
trips, the simulator's builders, and the framer (any chunking, garbage, cut lines, bad checksums, linear)."""

from __future__ import annotations

import datetime as dt
import math
import time
from pathlib import Path

import pytest
from framer_helpers import run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import nmea
from auvlink.decode_file import decode_path
from auvlink.errors import ChecksumError, DecodeError
from auvlink.framing.nmea import MAX_SENTENCE, NmeaFramer

GOLDEN = Path(__file__).parent / "golden" / "nmea"
RHB = (GOLDEN / "atomic2020_rhb_gps.nmea").read_bytes()
NOFIX = (GOLDEN / "ublox_neo6m_nofix.nmea").read_bytes()


def lines(blob: bytes) -> list[bytes]:
    return [x + b"\n" for x in blob.split(b"\n") if x]


def test_golden_gga_values() -> None:
    gga = nmea.decode(lines(RHB)[1])
    assert isinstance(gga, nmea.GgaFix)
    assert gga.talker == "GP" and gga.quality == 2 and gga.satellites == 6
    # 15 deg 41.31258893' N, 51 deg 30.51204125' W
    assert gga.latitude_deg == pytest.approx(15 + 41.31258893 / 60, abs=1e-12)
    assert gga.longitude_deg == pytest.approx(-(51 + 30.51204125 / 60), abs=1e-12)
    assert gga.time_s == 19 * 3600 + 59 * 60 + 59
    assert (gga.hdop, gga.altitude_m, gga.geoid_separation_m, gga.dgps_age_s) == (1.5, 9.2, -37.6, 4.0)
    assert gga.ellipsoidal_height_m == pytest.approx(9.2 - 37.6)
    assert gga.has_fix


def test_golden_rmc_and_zda_carry_utc() -> None:
    rmc = nmea.decode(lines(RHB)[5])
    zda = nmea.decode(lines(RHB)[4])
    assert isinstance(rmc, nmea.RmcFix) and isinstance(zda, nmea.ZdaTime)
    utc = dt.datetime(2020, 1, 14, 19, 59, 59, tzinfo=dt.UTC).timestamp()
    assert rmc.utc == utc and zda.utc == utc
    assert nmea.sensor_time(rmc) == utc and nmea.sensor_time(zda) == utc
    assert rmc.valid and rmc.mode == "D" and rmc.has_fix
    assert rmc.speed_mps == pytest.approx(0.26 * 1852 / 3600)
    assert rmc.course_rad == pytest.approx(math.radians(147.44))


def test_golden_file_every_sentence_decodes_and_round_trips() -> None:
    kinds = []
    for raw in lines(RHB) + lines(NOFIX):
        rec = nmea.decode(raw)
        assert nmea.encode(rec) == raw  # the fields exactly as sent
        kinds.append(type(rec).__name__)
    assert kinds.count("GgaFix") == 4 and kinds.count("RmcFix") == 4 and kinds.count("ZdaTime") == 3


def test_golden_no_fix() -> None:
    gga = nmea.decode(b"$GPGGA,,,,,,0,00,99.99,,,,,,*48\r\n")
    rmc = nmea.decode(b"$GPRMC,,V,,,,,,,,,,N*53\r\n")
    assert isinstance(gga, nmea.GgaFix) and not gga.has_fix and gga.quality == 0
    assert math.isnan(gga.latitude_deg) and math.isnan(gga.time_s)
    assert isinstance(rmc, nmea.RmcFix) and not rmc.has_fix and rmc.utc is None


def test_decode_file_cli_path() -> None:
    got: list[object] = []
    res = decode_path(GOLDEN / "atomic2020_rhb_gps.nmea", formats.get("nmea"), got.append)
    assert res.records == 29 and res.decode_errors == 0 and res.framer["dropped_bytes"] == 0
    assert formats.by_encoding("nmea.0183").name == "nmea"


@pytest.mark.parametrize("raw", [
    b"$GPGGA,195959.00,1541.31258893,N,05130.51204125,W,2,06,1.5,9.2,M,-37.6,M,4.0,0138\r\n",  # no checksum
    b"GPGGA garbage\r\n", b"$\r\n", "$GPGGA,é*00\r\n".encode(),
    b"$GPGGA,195959.00,1541.31258893,Q,05130.51204125,W,2,06,1.5,9.2,M,-37.6,M,4.0,0138*62\r\n",  # bad hemisphere
])
def test_malformed_raises(raw: bytes) -> None:
    with pytest.raises(DecodeError):
        nmea.decode(raw)


def test_bad_checksum_carries_expected_and_actual() -> None:
    bad = lines(RHB)[1].replace(b"*7E", b"*7F")
    with pytest.raises(ChecksumError) as info:
        nmea.decode(bad)
    assert info.value.expected == 0x7F and info.value.actual == 0x7E


@given(st.floats(-89.999, 89.999), st.floats(-179.999, 179.999), st.floats(0, 86399.99), st.integers(1, 8),
       st.integers(0, 40), st.floats(0.5, 9.9))
def test_build_gga_round_trip(lat: float, lon: float, t: float, q: int, sats: int, hdop: float) -> None:
    rec = nmea.build_gga(t, lat, lon, quality=q, satellites=sats, hdop=hdop)
    assert nmea.decode(nmea.encode(rec)) == rec
    # 7 decimals of minutes: 1.7e-9 deg (0.2 mm)
    assert abs(rec.latitude_deg - lat) < 1e-9 and abs(rec.longitude_deg - lon) < 1e-9
    assert rec.quality == q and rec.satellites == sats and abs(rec.time_s - t) <= 0.005 + 1e-9


def test_build_rmc_zda_no_fix() -> None:
    utc = dt.datetime(2026, 1, 1, 0, 0, 3, 200000, tzinfo=dt.UTC).timestamp()
    rmc = nmea.build_rmc(utc, 36.0412, 129.3915, speed_mps=1.5, course_rad=1.0)
    assert rmc.utc == pytest.approx(utc) and rmc.has_fix and rmc.speed_mps == pytest.approx(1.5, abs=0.01)
    assert nmea.build_zda(utc).utc == pytest.approx(utc)
    assert nmea.encode(nmea.build_gga(5.0, None, None)) == b"$GNGGA,000005.00,,,,,0,00,99.99,,,,,,*7D\r\n"
    assert not nmea.build_rmc(utc, None, None).has_fix


# --- framer -------------------------------------------------------------------------------------------
def test_framer_golden_any_chunking() -> None:
    for chunk in (1, 2, 7, 64, len(RHB)):
        fr = NmeaFramer()
        got = run(fr, RHB, [chunk] * (len(RHB) // chunk))
        assert got == lines(RHB), chunk
        assert fr.stats.dropped_bytes == 0 and fr.stats.truncated == 0


def test_framer_garbage_cut_lines_and_bad_checksums_counted() -> None:
    good = lines(RHB)
    bad = good[1].replace(b"*7E", b"*7F")
    stream = b"\x00\xffnoise" + good[0] + b"$GPGGA,1959" + good[1] + bad + b"\n\n" + good[2] + b"$GPZDA,2000"
    fr = NmeaFramer()
    got = run(fr, stream, [3] * 200)
    assert got == good[:3]
    assert fr.stats.bad_checksums == 1 and fr.stats.truncated == 1
    assert fr.stats.dropped_bytes == len(stream) - sum(map(len, good[:3]))


def test_framer_drops_sentences_without_a_checksum() -> None:
    good = lines(RHB)[4]  # $GPZDA,195959.00,14,01,2020,00,00*6A
    for bad in (good.replace(b"*6A", b""), good.replace(b"*6A", b"*6a"), good.replace(b"*6A", b"-6A")):
        fr = NmeaFramer()
        assert run(fr, bad + good, [5]) == [good] and fr.stats.dropped_bytes == len(bad)


def test_framer_over_long_line_and_bounded_buffer() -> None:
    fr = NmeaFramer()
    junk = b"$" + b"A" * 10_000  # a start character, then no end: never more than a sentence buffered
    for k in range(0, len(junk), 13):
        fr.feed(junk[k : k + 13])
        assert fr.buffered <= MAX_SENTENCE
    assert fr.feed(lines(RHB)[1]) == [lines(RHB)[1]]


def test_framer_linear_time() -> None:
    """One byte at a time through long partial sentences: the cost per byte does not grow with the stream."""
    def cost(n: int) -> float:
        stream = (b"$GPGSV," + b"1," * 70 + b"\r\n") * n  # over-long lines: all garbage
        fr = NmeaFramer()
        t0 = time.perf_counter()
        for i in range(len(stream)):
            fr.feed(stream[i : i + 1])
        return time.perf_counter() - t0

    small, big = cost(40), cost(160)
    assert big < 8.0 * small + 0.05, (small, big)


@st.composite
def noisy_stream(draw: st.DrawFn) -> tuple[bytes, list[bytes], list[int]]:
    good = lines(RHB)
    picks = draw(st.lists(st.sampled_from(good), min_size=1, max_size=12))
    parts, kept = [], []
    for g in picks:
        noise = draw(st.binary(max_size=8).map(lambda b: bytes(c for c in b if c not in b"$!\n")))
        parts += [noise, g]
        kept.append(g)
    stream = b"".join(parts)
    cuts = draw(st.lists(st.integers(1, 40), max_size=30))
    return stream, kept, cuts


@settings(derandomize=True, max_examples=150, suppress_health_check=[HealthCheck.too_slow])
@given(noisy_stream())
def test_framer_fuzz(case: tuple[bytes, list[bytes], list[int]]) -> None:
    stream, kept, cuts = case
    fr = NmeaFramer()
    got = run(fr, stream, cuts)
    assert got == kept


@settings(max_examples=100)
@given(st.binary(max_size=400), st.integers(1, 64))
def test_framer_garbage_never_raises(data: bytes, chunk: int) -> None:
    fr = NmeaFramer()
    frames = run(fr, data, [chunk] * (len(data) // chunk))
    for f in frames:
        assert f[:1] in (b"$", b"!") and f.endswith(b"\n")
