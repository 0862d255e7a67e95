"""Paroscientific Digiquartz ASCII lines: golden vectors, exact round trips, framer fuzz."""

from __future__ import annotations

import json

import pytest
from framer_helpers import run
from hypothesis import given
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import paro
from auvlink.codecs.paro import PA_PER_UNIT, ParoReading, ParoResponse, build_reading, decode, encode, to_json
from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.ascii import ParoFramer

READING = b"*00012991.11891\r\n"  # data/README.md
PT_RESPONSE = b"*0001P4=16.7509,23.01532\r\n"  # data/README.md
PSI = 6894.757293168361  # Pa per psi (0.45359237 kg * 9.80665 m/s^2 / (0.0254 m)^2)


# --- codec -------------------------------------------------------------------------------
def test_psi_factor() -> None:
    assert PA_PER_UNIT["psi"] == pytest.approx(0.45359237 * 9.80665 / 0.0254**2, rel=1e-15)


def test_golden_reading() -> None:
    r = decode(READING)
    assert r == ParoReading(destination=0, source=1, text="2991.11891", unit="psi")
    assert isinstance(r, ParoReading)
    assert r.value == 2991.11891
    assert r.pressure_pa == pytest.approx(2991.11891 * PSI)
    assert r.pressure_pa == pytest.approx(20.6230e6, rel=1e-5)
    assert r.temperature_c is None
    assert encode(r) == READING


def test_golden_pressure_temperature_response() -> None:
    r = decode(PT_RESPONSE)
    assert r == ParoResponse(0, 1, "P4", "16.7509,23.01532", "psi")
    assert isinstance(r, ParoResponse)
    assert r.values == (16.7509, 23.01532)
    assert r.pressure_pa == pytest.approx(16.7509 * PSI)
    assert r.temperature_c == 23.01532
    assert encode(r) == PT_RESPONSE


def test_generic_response_and_units() -> None:
    r = decode(b"*0001UN=1\r\n")
    assert r == ParoResponse(0, 1, "UN", "1")
    assert isinstance(r, ParoResponse)
    assert r.values == (1.0,) and r.pressure_pa is None and r.temperature_c is None
    v = decode(b"*0001VR=R5.10\r\n")
    assert isinstance(v, ParoResponse) and v.values is None
    bar = decode(READING, unit="bar")
    assert bar.pressure_pa == pytest.approx(2991.11891e5)
    assert decode(READING, unit="counts").pressure_pa is None
    t = decode(b"*000123.015\r\n", unit="degC")
    assert isinstance(t, ParoReading) and t.temperature_c == 23.015 and t.pressure_pa is None


def test_terminator_optional_on_decode() -> None:
    assert decode(READING.rstrip()) == decode(READING) == decode(READING[:-2] + b"\n")
    assert encode(decode(READING.rstrip())) == READING


def test_addresses() -> None:
    r = decode(b"*9902-0.00012\r\n")
    assert (r.destination, r.source) == (99, 2)
    assert isinstance(r, ParoReading) and r.value == -0.00012


@pytest.mark.parametrize(
    "raw",
    [
        b"",
        b"*0001",
        b"00012991.1\r\n",
        b"*0A012991.1\r\n",
        b"*0001hello\r\n",
        b"*0001 \r\n",
        b"*00012991.1\r\r\n",
        b"*0001\xb02.0\r\n",
        b"*0001p4=1\r\n",
    ],
)
def test_malformed_raises(raw: bytes) -> None:
    with pytest.raises(DecodeError):
        decode(raw)


def test_encode_rejects() -> None:
    for bad in (
        ParoReading(100, 1, "1.0"),
        ParoReading(0, 1, "1.0\r\n"),
        ParoResponse(0, 1, "P4", "é"),
        ParoReading(0, 1, ""),
    ):
        with pytest.raises(EncodeError):
            encode(bad)
    with pytest.raises(EncodeError):
        build_reading(1e5, unit="furlongs")


def test_build_reading() -> None:
    r = build_reading(101325.0 + 1025 * 9.80665 * 10.0)  # 10 m of sea water
    assert r.text == "29.27488" and r.unit == "psi"  # 2.0184 bar * 14.50377 psi/bar
    assert decode(encode(r)) == r
    assert r.pressure_pa == pytest.approx(101325.0 + 1025 * 9.80665 * 10.0, abs=0.5e-5 * PSI)
    assert build_reading(2e5, unit="bar", decimals=3).text == "2.000"


def test_to_json_and_registry() -> None:
    for raw in (READING, PT_RESPONSE, b"*0001VR=R5.10\r\n"):
        out = to_json(decode(raw))
        assert json.loads(json.dumps(out)) == out
    assert to_json(decode(PT_RESPONSE))["values"] == [16.7509, 23.01532]
    assert to_json(decode(READING))["pressure_pa"] == pytest.approx(2991.11891 * PSI)
    wf = formats.get("paro")
    assert wf is paro.WIRE_FORMAT and wf.encoding == "paro.digiquartz"
    assert wf.sensor_time(wf.decode(READING)) is None


numbers = st.one_of(
    st.decimals(-1e6, 1e6, places=5, allow_nan=False).map(str),
    st.floats(-1e9, 1e9).map(repr),
    st.integers(-99999, 99999).map(str),
)
addr = st.integers(0, 99)
units = st.sampled_from([*PA_PER_UNIT, "degC"])
commands = st.from_regex(r"\A[A-Z][A-Z0-9]{1,3}\Z")
safe_text = st.text(
    st.characters(codec="ascii", min_codepoint=0x20, max_codepoint=0x7E, exclude_characters="*"), max_size=30
)
records = st.one_of(
    st.builds(ParoReading, addr, addr, numbers, units),
    st.builds(ParoResponse, addr, addr, commands, safe_text, units),
)


@given(records)
def test_decode_encode_record(r: ParoReading | ParoResponse) -> None:
    assert decode(encode(r), unit=r.unit) == r


@given(records)
def test_encode_decode_bytes_exact(r: ParoReading | ParoResponse) -> None:
    raw = encode(r)
    assert encode(decode(raw)) == raw


def test_many_generated_lines() -> None:
    for i in range(5000):
        raw = f"*{i % 100:02d}{(i * 7) % 100:02d}{(i - 2500) * 1.37:.5f}\r\n".encode()
        assert encode(decode(raw)) == raw


# --- framer ------------------------------------------------------------------------------
def test_framer_drops_noise_and_partial_lines() -> None:
    stream = READING[6:] + b"\x00\xff*0" + READING + b"junk\r\n" + PT_RESPONSE + READING[:9]
    f = ParoFramer()
    assert run(f, stream, [4, 4]) == [READING, PT_RESPONSE]
    assert f.stats.truncated == 1
    assert f.stats.dropped_bytes == len(stream) - len(READING) - len(PT_RESPONSE)


def test_framer_garbage_tail_not_truncated() -> None:
    f = ParoFramer()
    assert run(f, READING + b"noise", []) == [READING]
    assert f.stats.truncated == 0


