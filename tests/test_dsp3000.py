"""KVH DSP-3000 ASCII lines: golden vector, exact field widths, round trips, framer fuzz."""

from __future__ import annotations

import json
import math

import pytest
from framer_helpers import run
from hypothesis import given
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import dsp3000
from auvlink.codecs.dsp3000 import MODES, Dsp3000Reading, build, decode, encode, to_json
from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.ascii import Dsp3000Framer

VECTOR = b"       0.015733   1\r\n"  # data/README.md


def line(micro_deg: int, flag: int) -> bytes:
    """A canonical line built with integer arithmetic (no float formatting involved)."""
    sign = "-" if micro_deg < 0 else ""
    whole, frac = divmod(abs(micro_deg), 1_000_000)
    return f"{sign}{whole}.{frac:06d}".rjust(15).encode() + f"{flag:4d}\r\n".encode()


# --- codec -------------------------------------------------------------------------------
def test_vector_layout() -> None:
    assert len(VECTOR) == 21
    assert VECTOR[:15] == b"       0.015733" and VECTOR[15:19] == b"   1"
    assert line(15733, 1) == VECTOR


def test_golden_decode_and_round_trip() -> None:
    r = decode(VECTOR)
    assert r == Dsp3000Reading(math.radians(0.015733), True, "rate")
    assert r.value == pytest.approx(2.74593e-4, rel=1e-5)  # rad/s
    assert r.rate == r.value and r.angle is None
    assert r.value_deg == pytest.approx(0.015733, abs=1e-12)
    assert encode(r) == VECTOR


@pytest.mark.parametrize("mode", MODES)
def test_modes(mode: str) -> None:
    r = decode(VECTOR, mode=mode)
    assert r.mode == mode
    assert (r.rate is None) == (mode != "rate")
    assert (r.angle is None) == (mode == "rate")
    assert to_json(r)["unit"] == ("rad/s" if mode == "rate" else "rad")
    assert encode(r) == VECTOR
    assert dsp3000.wire_format(mode).decode(VECTOR) == r


def test_invalid_flag_and_negative() -> None:
    raw = b"      -1.234567   0\r\n"
    r = decode(raw)
    assert not r.valid
    assert r.value == math.radians(-1.234567)
    assert encode(r) == raw


def test_decode_tolerates_spacing_and_missing_terminator() -> None:
    assert decode(b"0.015733 1") == decode(VECTOR)
    assert decode(b"  0.015733\t1\n") == decode(VECTOR)


@pytest.mark.parametrize(
    "raw",
    [
        b"",
        b"\r\n",
        b"0.015733\r\n",
        b"abc   1\r\n",
        b"0.01 2\r\n",
        b"1.0 1 1\r\n",
        b"\xff1.0 1\r\n",
        b"nan 1",
    ],
)
def test_malformed_raises(raw: bytes) -> None:
    with pytest.raises(DecodeError):
        decode(raw)


def test_bad_mode_and_non_finite() -> None:
    with pytest.raises(ValueError):
        decode(VECTOR, mode="delta")
    with pytest.raises(EncodeError):
        encode(Dsp3000Reading(math.inf))
    with pytest.raises(EncodeError):
        build(math.nan)


def test_overflowing_value_keeps_all_digits() -> None:
    raw = line(123456789_123456, 1)  # 16 characters: wider than the field
    assert raw == b"123456789.123456   1\r\n"
    assert encode(decode(raw, mode="integrated")) == raw
    f = Dsp3000Framer()
    assert run(f, b"\r\n" + raw + b"x\n" + raw, [3]) == [raw, raw]
    assert f.stats.dropped_bytes == 4


def test_to_json_and_registry() -> None:
    out = to_json(decode(VECTOR))
    assert json.loads(json.dumps(out)) == out
    assert out == {"mode": "rate", "value": math.radians(0.015733), "unit": "rad/s", "valid": True}
    wf = formats.get("dsp3000")
    assert wf is dsp3000.WIRE_FORMAT and wf.encoding == "kvh.dsp3000"
    assert dsp3000.WIRE_FORMAT_INTEGRATED.encoding == "kvh.dsp3000.integrated"
    assert wf.sensor_time(wf.decode(VECTOR)) is None


@given(st.integers(-9_999_999_999_999, 9_999_999_999_999), st.integers(0, 1))
def test_encode_decode_bytes_exact(micro_deg: int, flag: int) -> None:
    raw = line(micro_deg, flag)
    assert encode(decode(raw)) == raw


def test_many_generated_lines() -> None:
    for n in range(-3_000_000, 3_000_000, 997):
        raw = line(n, n & 1)
        assert encode(decode(raw, mode="incremental")) == raw


@given(st.floats(-1e5, 1e5), st.booleans(), st.sampled_from(MODES))
def test_decode_encode_record(value: float, valid: bool, mode: str) -> None:
    r = build(value, valid=valid, mode=mode)
    assert decode(encode(r), mode=mode) == r
    # half the micro-degree step, plus the rounding of the degree conversion at this magnitude (a rate of 6.7e4 rad
    # landed 3e-12 rad beyond the half step)
    assert r.value == pytest.approx(value, abs=math.radians(0.5e-6) * 1.0001 + 64 * math.ulp(value))


# --- framer ------------------------------------------------------------------------------
def test_framer_joined_mid_line() -> None:
    # the port opened in the middle of a line: its tail is not a frame and is dropped
    f = Dsp3000Framer()
    out = run(f, VECTOR[7:] + VECTOR + b"xx\x00" + VECTOR + VECTOR[:9], [5])
    assert out == [VECTOR, VECTOR]
    assert f.stats.dropped_bytes == 14 + 3 + 9
    assert f.stats.truncated == 1


def test_framer_garbage_tail_not_truncated() -> None:
    f = Dsp3000Framer()
    assert run(f, VECTOR + b"\x00garbage", []) == [VECTOR]
    assert f.stats.truncated == 0 and f.stats.dropped_bytes == 8


def test_framer_long_garbage_is_cut() -> None:
    f = Dsp3000Framer()
    out = f.feed(b"z" * 1000)
    assert out == [] and f.buffered <= f.max_line
    assert f.feed(VECTOR) == [VECTOR]


