"""PD6 codec and the generic ASCII line framer: exact round trips, values, fuzzing."""

from __future__ import annotations

import datetime as dt
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import pd6
from auvlink.codecs.pd6 import Pd6Attitude, Pd6Distance, Pd6Raw, Pd6Timing, Pd6Velocity, decode, encode
from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.ascii_lines import LineFramer

# canonical WorkHorse spacing (the manual's field widths), one ensemble of bottom and water track
CANONICAL = [
    b":SA, -2.31, +1.96,212.78\r\n",
    b":TS,04081111563644,35.0,+21.0,   0.0,1524.0,  0\r\n",
    b":WI,-32768,-32768,-32768,-32768,V\r\n",
    b":BI,   +24,   -39,   +16,    +2,A\r\n",
    b":WS,-32768,-32768,-32768,V\r\n",
    b":BS,   -46,   +10,   +16,A\r\n",
    b":WE,-32768,-32768,-32768,V\r\n",
    b":BE,   +43,   -18,   +16,A\r\n",
    b":WD,       +0.00,       +0.00,       +0.00,   0.00,  0.00\r\n",
    b":BD,       +0.45,       -0.19,       +0.16,  20.89,  0.06\r\n",
]
# wider padding seen from other RDI firmware (Pathfinder), and a health-monitor line
OTHER_SPACING = [
    b":SA,   +0.00,   +0.00,  0.00\r\n",
    b":SA,  -5.91,   +4.35,  0.00\r\n",
    b":TS,23070714400162,35.0, +26.1,   0.0,1536.9,  0\r\n",
    b":BI,    +0,    +0,    +0,-32768,A\r\n",
    b":BD,        +0.00,        +0.00,        +0.00,   7.15,  0.00\r\n",
    b":HM,G,D,0e89,0ffe, 10.842, 1.974, 5.493\r\n",
]


@pytest.mark.parametrize("line", OTHER_SPACING)  # the canonical lines: tests/test_conformance.py
def test_round_trip_exact(line: bytes) -> None:
    rec = decode(line)
    assert encode(rec) == line
    assert decode(encode(rec)) == rec


def test_canonical_widths_are_the_default() -> None:
    for line in CANONICAL:
        rec = decode(line)
        assert encode(type(rec)(**{**rec.__dict__, "widths": None})) == line


def test_values() -> None:
    sa = decode(CANONICAL[0])
    assert isinstance(sa, Pd6Attitude)
    assert math.degrees(sa.pitch_rad) == pytest.approx(-2.31)
    assert math.degrees(sa.heading_rad) == pytest.approx(212.78)
    ts = decode(CANONICAL[1])
    assert isinstance(ts, Pd6Timing)
    assert ts.time == dt.datetime(2004, 8, 11, 11, 56, 36, 440000, dt.UTC)
    assert (ts.salinity_ppt, ts.temperature_c, ts.depth_m, ts.speed_of_sound_mps, ts.bit_result) == (
        35.0, 21.0, 0.0, 1524.0, 0)
    assert pd6.sensor_time(ts) == ts.time.timestamp() and pd6.sensor_time(sa) is None
    wi = decode(CANONICAL[2])
    assert isinstance(wi, Pd6Velocity) and not wi.valid and wi.track == "water" and wi.frame == "instrument"
    assert all(math.isnan(v) for v in wi.velocity_mps) and wi.error_velocity_mps is not None
    assert math.isnan(wi.error_velocity_mps)
    bi = decode(CANONICAL[3])
    assert isinstance(bi, Pd6Velocity) and bi.valid and bi.velocity_mps == (0.024, -0.039, 0.016)
    assert bi.error_velocity_mps == 0.002
    be = decode(CANONICAL[7])
    assert isinstance(be, Pd6Velocity) and be.frame == "earth" and be.error_velocity_mps is None
    bd = decode(CANONICAL[9])
    assert isinstance(bd, Pd6Distance) and (bd.east_m, bd.north_m, bd.up_m) == (0.45, -0.19, 0.16)
    assert (bd.range_m, bd.time_since_good_s) == (20.89, 0.06)
    hm = decode(OTHER_SPACING[-1])
    assert isinstance(hm, Pd6Raw) and hm.tag == "HM"
    assert pd6.to_json(bi)["velocity_mps"] == [0.024, -0.039, 0.016]
    assert pd6.to_json(wi)["velocity_mps"] == [None, None, None]
    assert pd6.to_json(ts)["time"] == "2004-08-11T11:56:36.440Z"


@pytest.mark.parametrize("line", [
    b":SA,-2.31,+1.96\r\n", b":SA,x,+1.96,3\r\n", b":TS,0408111156364,35.0,+21.0,0.0,1524.0,0\r\n",
    b":TS,04131111563644,35.0,+21.0,0.0,1524.0,0\r\n", b":BI,+1,+2,+3,A\r\n", b":BS,+1,+2,+3,AV\r\n",
    b"SA,1,2,3\r\n", b":\xff\xfe\r\n", b":BD,1,2,3,4\r\n",
])
def test_decode_errors(line: bytes) -> None:
    with pytest.raises(DecodeError):
        decode(line)


def test_encode_errors() -> None:
    with pytest.raises(EncodeError):
        encode(Pd6Velocity("BI", (40.0, 0.0, 0.0), 0.0, "A"))
    with pytest.raises(EncodeError):
        encode(Pd6Velocity("XX", (0.0, 0.0, 0.0), None, "A"))
    with pytest.raises(EncodeError):
        encode(Pd6Timing(dt.datetime(1999, 1, 1, tzinfo=dt.UTC), 35.0, 10.0, 0.0, 1500.0, 0))


def test_wire_format() -> None:
    wf = formats.get("pd6")
    assert wf.name == "pd6" and wf.encoding == "rdi.pd6" and wf.decode is decode
    assert wf.framer().format_name == "pd6"


# --- property tests ---------------------------------------------------------------------------
cents = st.integers(-99999, 99999).map(lambda v: v / 100)
mm = st.one_of(st.just(math.nan), st.integers(-32767, 32767).map(lambda v: v / 1000))


@st.composite
def records(draw: st.DrawFn) -> pd6.Pd6Record:
    kind = draw(st.sampled_from(["SA", "TS", "I", "S", "E", "D"]))
    if kind == "SA":
        p, r, h = (math.radians(draw(st.integers(-9999, 35999)) / 100) for _ in range(3))
        return Pd6Attitude(p, r, h)
    if kind == "TS":
        cs = draw(st.integers(0, 300_000_000_00))
        t = dt.datetime(2000, 1, 1, tzinfo=dt.UTC) + dt.timedelta(milliseconds=10 * cs)
        return Pd6Timing(t, draw(st.integers(0, 999)) / 10, draw(st.integers(-99, 999)) / 10,
                         draw(st.integers(0, 99999)) / 10, draw(st.integers(13000, 16000)) / 10,
                         draw(st.integers(0, 999)))
    track = draw(st.sampled_from("BW"))
    if kind == "D":
        e, n, u = draw(cents), draw(cents), draw(cents)
        return Pd6Distance(track + "D", e, n, u, abs(draw(cents)), abs(draw(cents)))
    vel = (draw(mm), draw(mm), draw(mm))
    return Pd6Velocity(track + kind, vel, draw(mm) if kind == "I" else None, draw(st.sampled_from("AV")))


@settings(max_examples=300, deadline=None)
@given(records())
def test_record_round_trip(rec: pd6.Pd6Record) -> None:
    line = encode(rec)
    assert line.endswith(b"\r\n") and line.startswith(b":" + rec.tag.encode())
    back = decode(line)
    assert back == rec and encode(back) == line


def test_framer_resyncs_on_a_cut_line_and_counts_truncation() -> None:
    framer = pd6.Pd6Framer()
    stream = b"\n:SA, -2.31, +1.:BI,   +24,   -39,   +16,    +2,A\r\n :BD,       +0.45"
    got = [f for b in stream for f in framer.feed(bytes([b]))]
    assert got == [CANONICAL[3]]
    assert framer.flush() == [] and framer.stats.truncated == 1
    assert framer.stats.frames == 1 and framer.stats.dropped_bytes == len(stream) - len(CANONICAL[3])


@pytest.mark.parametrize("resync", [True, False])
def test_over_long_line_is_dropped_whatever_the_chunking(resync: bool) -> None:
    blob = b":" + b"x" * 300 + b"\r\n" + CANONICAL[0] + b":" + b"y" * 300 + CANONICAL[1]
    expected = [CANONICAL[0], CANONICAL[1]] if resync else [CANONICAL[0]]
    bulk = LineFramer(b"\r\n", b":", max_length=256, resync_on_start=resync)
    one = LineFramer(b"\r\n", b":", max_length=256, resync_on_start=resync)
    assert bulk.feed(blob) + bulk.flush() == expected
    assert [f for b in blob for f in one.feed(bytes([b]))] + one.flush() == expected
    assert bulk.stats.dropped_bytes == one.stats.dropped_bytes == len(blob) - sum(map(len, expected))


def test_line_framer_generic_options() -> None:
    dollar = LineFramer(b"\n", lambda b: b == ord("$"), format_name="nmea")
    assert dollar.feed(b"junk$GPGGA,1*00\n$GPRMC,2") == [b"$GPGGA,1*00\n"]
    assert dollar.flush() == [] and dollar.stats.truncated == 1 and dollar.format_name == "nmea"
    anyline = LineFramer(b"\r\n", None, max_length=8)
    blob = b"abc\r\n\r\n0123456789xy\r\nok\r\n"
    assert anyline.feed(blob) == [b"abc\r\n", b"ok\r\n"]
    one = LineFramer(b"\r\n", None, max_length=8)
    assert [f for b in blob for f in one.feed(bytes([b]))] == [b"abc\r\n", b"ok\r\n"]
    multi = LineFramer(b";", b"*#")
    assert multi.feed(b"--#a;*b;c;") == [b"#a;", b"*b;"]
    with pytest.raises(ValueError):
        LineFramer(b"")


@settings(max_examples=150, deadline=None)
@given(st.lists(st.sampled_from([b":", b"a", b"b", b"\r", b"\n", b"\r\n"]), max_size=300), st.data(),
       st.sampled_from([(b":", True), (b":", False), (None, False)]))
def test_line_framer_chunking_invariant(parts: list[bytes], data: st.DataObject,
                                        mode: tuple[bytes | None, bool]) -> None:
    blob = b"".join(parts)
    make = lambda: LineFramer(b"\r\n", mode[0], max_length=12, resync_on_start=mode[1])  # noqa: E731
    bulk = make()
    expected = bulk.feed(blob) + bulk.flush()
    cuts = sorted(data.draw(st.lists(st.integers(0, len(blob)), max_size=40)))
    chunked, got, prev = make(), [], 0
    for c in [*cuts, len(blob)]:
        got += chunked.feed(blob[prev:c])
        prev = c
    got += chunked.flush()
    assert got == expected
    assert chunked.stats.as_dict() == bulk.stats.as_dict()
    assert sum(map(len, got)) + bulk.stats.dropped_bytes == len(blob)


@pytest.mark.parametrize("resync", [False, True])
def test_a_line_of_max_length_cut_inside_its_terminator_is_kept(resync: bool) -> None:
    blob = b"aa" + b":" * 12 + b"\r\n"  # garbage, then a line of exactly max_length bytes
    bulk = LineFramer(b"\r\n", b":", max_length=12, resync_on_start=resync)
    chunked = LineFramer(b"\r\n", b":", max_length=12, resync_on_start=resync)
    whole = bulk.feed(blob)
    assert whole == ([b":\r\n"] if resync else [blob[2:]])  # with resync a run of starts keeps only its last
    assert chunked.feed(blob[:15]) + chunked.feed(blob[15:]) == whole  # the cut between \r and \n
    assert chunked.stats.as_dict() == bulk.stats.as_dict()
