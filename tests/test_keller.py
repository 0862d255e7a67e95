"""Keller bus (Series 30) F48 / F73 frames: CRC vector, records, pairing, framer fuzz."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from framer_helpers import run
from hypothesis import given
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import keller
from auvlink.codecs.keller import (
    KellerException,
    KellerInitRequest,
    KellerInitResponse,
    KellerReading,
    KellerReadRequest,
    KellerReadResponse,
    build_pressure_response,
    build_read_response,
    decode,
    encode,
    iter_readings,
    pair,
    to_json,
)
from auvlink.crc import crc16_modbus
from auvlink.errors import ChecksumError, DecodeError, EncodeError
from auvlink.framing.keller import FRAME_LENGTHS, KellerFramer


def with_crc(body: bytes) -> bytes:
    return body + crc16_modbus(body).to_bytes(2, "big")


# --- codec -------------------------------------------------------------------------------
def test_crc_vector_high_byte_first() -> None:
    # data/README.md: request [0x02, 0x30] -> CRC bytes C4 00
    raw = encode(KellerInitRequest(address=2))
    assert raw == bytes([0x02, 0x30, 0xC4, 0x00])
    assert decode(raw) == KellerInitRequest(2)


def test_read_request_and_response_by_hand() -> None:
    req = with_crc(bytes([1, 73, 1]))
    rq = decode(req)
    assert rq == KellerReadRequest(1, 1)
    assert isinstance(rq, KellerReadRequest) and rq.channel_name == "P1"
    resp = with_crc(bytes([1, 73]) + struct.pack(">f", 1.5) + b"\x00")
    r = decode(resp)
    assert r == KellerReadResponse(1, 1.5, 0)
    assert encode(r) == resp
    reading = pair(KellerReadRequest(1, 1), r)
    assert reading.pressure_pa == 1.5e5 and reading.temperature_c is None
    assert reading.channel_name == "P1" and reading.wire_unit == "bar"
    tob = pair(KellerReadRequest(1, keller.CH_TOB1), KellerReadResponse(1, 21.25))
    assert tob.temperature_c == 21.25 and tob.pressure_pa is None and tob.channel_name == "TOB1"


def test_init_response_fields() -> None:
    raw = with_crc(bytes([250, 48, 5, 20, 14, 33, 10, 1]))
    r = decode(raw)
    assert r == KellerInitResponse(250, device_class=5, group=20, year=14, week=33, buffer=10, status=1)
    assert encode(r) == raw


def test_exception_response() -> None:
    raw = with_crc(bytes([2, 73 | 0x80, 32]))
    r = decode(raw)
    assert r == KellerException(address=2, function=73, code=32)
    assert isinstance(r, KellerException) and "initialisation" in r.message
    assert encode(r) == raw
    assert decode(with_crc(bytes([2, 48 | 0x80, 1]))) == KellerException(2, 48, 1)


def test_bad_crc() -> None:
    raw = bytearray(encode(KellerReadRequest(1, 4)))
    raw[2] = 1
    with pytest.raises(ChecksumError) as info:
        decode(bytes(raw))
    assert info.value.expected == int.from_bytes(raw[-2:], "big")
    assert info.value.actual == crc16_modbus(bytes(raw[:-2]))


@pytest.mark.parametrize(
    "raw",
    [
        b"",
        b"\x01\x30\x00",
        with_crc(bytes([1, 73, 1, 2])),
        with_crc(bytes([1, 99, 1])),
        with_crc(b"\x01\x30\x00"),
    ],
)
def test_malformed_raises(raw: bytes) -> None:
    with pytest.raises(DecodeError):
        decode(raw)


def test_encode_rejects() -> None:
    for bad in (KellerInitRequest(256), KellerReadRequest(1, -1), KellerReadResponse(1, 1e39), "x"):
        with pytest.raises(EncodeError):
            encode(bad)  # type: ignore[arg-type]


def test_pairing() -> None:
    with pytest.raises(DecodeError):
        pair(KellerReadRequest(1, 1), KellerReadResponse(2, 1.0))
    stream = [
        KellerInitRequest(1),
        KellerInitResponse(1),
        KellerReadRequest(1, 1),
        KellerReadResponse(1, 2.0),
        KellerReadRequest(2, 4),
        KellerReadRequest(1, 4),
        KellerReadResponse(1, 20.5),  # answers the later request to address 1
        KellerReadResponse(2, 19.0),
        KellerReadResponse(2, 99.0),  # no request pending: skipped
        KellerReadRequest(3, 1),
        KellerException(3, 73, 32),
        KellerReadResponse(3, 1.0),  # the request was answered by the exception: skipped
    ]
    readings = list(iter_readings(stream))
    assert readings == [
        KellerReading(1, 1, 2.0),
        KellerReading(1, 4, 20.5),
        KellerReading(2, 4, 19.0),
    ]
    assert readings[0].pressure_pa == 2e5


def test_builders() -> None:
    r = build_pressure_response(1, 250_000.0)
    assert r == KellerReadResponse(1, 2.5, 0)
    assert decode(encode(r)) == r
    p = 101325.0 + 1025 * 9.80665 * 37.0  # 37 m of sea water: 4.732 bar
    depth = build_pressure_response(1, p)
    assert depth.value == struct.unpack(">f", struct.pack(">f", p / 1e5))[0]
    assert pair(KellerReadRequest(1, 1), depth).pressure_pa == pytest.approx(p, rel=1e-7)
    assert build_read_response(1, keller.CH_TOB1, 21.5).value == 21.5


def test_to_json_and_registry() -> None:
    recs: list[keller.KellerRecord | KellerReading] = [
        KellerInitRequest(1),
        KellerInitResponse(1),
        KellerReadRequest(1, 1),
        KellerReadResponse(1, 1.25),
        KellerException(1, 73, 2),
        KellerReading(1, 1, 1.25),
    ]
    for rec in recs:
        out = to_json(rec)
        assert json.loads(json.dumps(out)) == out
    assert to_json(KellerReading(1, 1, 1.25))["pressure_pa"] == 125000.0
    assert to_json(KellerReadRequest(1, 4))["channel_name"] == "TOB1"
    wf = formats.get("keller")
    assert wf is keller.WIRE_FORMAT and wf.encoding == "keller.bus"
    assert wf.sensor_time(KellerReadRequest(1, 1)) is None


byte = st.integers(0, 255)
records = st.one_of(
    st.builds(KellerInitRequest, byte),
    st.builds(KellerInitResponse, byte, byte, byte, byte, byte, byte, byte),
    st.builds(KellerReadRequest, byte, byte),
    st.builds(KellerReadResponse, byte, st.floats(width=32, allow_nan=False), byte),
    st.builds(KellerException, byte, st.sampled_from([48, 73]), byte),
)


@given(records)
def test_decode_encode_record(r: keller.KellerRecord) -> None:
    assert decode(encode(r)) == r


def test_many_generated_frames_round_trip() -> None:
    rng = np.random.default_rng(30)
    for _ in range(3000):
        func = int(rng.choice(list(FRAME_LENGTHS)))
        n = int(rng.choice(FRAME_LENGTHS[func]))
        body = bytearray(rng.integers(0, 256, n - 2, dtype=np.uint8).tobytes())
        body[1] = func
        if n == 9 and np.isnan(struct.unpack_from(">f", body, 2)[0]):
            continue
        raw = with_crc(bytes(body))
        assert encode(decode(raw)) == raw


# --- framer ------------------------------------------------------------------------------
def session(n: int) -> list[bytes]:
    """What a tap sees: init, then alternating P1 and TOB1 reads, each answered."""
    frames = [encode(KellerInitRequest(1)), encode(KellerInitResponse(1, 5, 20, 19, 7, 10, 0))]
    for i in range(n):
        ch = 1 if i % 2 == 0 else 4
        frames.append(encode(KellerReadRequest(1, ch)))
        value = (
            build_pressure_response(1, 1e5 + 1e3 * i) if ch == 1 else build_read_response(1, 4, 20.0 + i / 8)
        )
        frames.append(encode(value))
    return frames


def test_framer_session_one_byte_at_a_time() -> None:
    frames = session(30)
    stream = b"".join(frames)
    f = KellerFramer()
    out = run(f, stream, [1] * len(stream))
    assert out == frames
    assert f.stats.dropped_bytes == 0 and f.stats.bad_checksums == 0
    readings = list(iter_readings(decode(x) for x in out))
    assert len(readings) == 30
    assert readings[2].pressure_pa == pytest.approx(1.02e5) and readings[1].temperature_c == 20.125


def test_framer_request_alone_waits_then_flushes() -> None:
    f = KellerFramer()
    req = encode(KellerReadRequest(1, 1))
    assert f.feed(req) == []  # could still be the start of a 9-byte response
    assert f.flush() == [req]
    assert f.stats.truncated == 0


def test_framer_response_that_starts_like_a_request() -> None:
    # a F73 response whose first five bytes also pass as a request's CRC: framed whole
    head = bytes([1, 73, 0x3F])
    fake = head + crc16_modbus(head).to_bytes(2, "big")
    resp = with_crc(fake[:6] + b"\x00\x00")
    assert len(resp) == 9 and decode(fake) == KellerReadRequest(1, 0x3F)
    nxt = encode(KellerReadRequest(1, 4))
    f = KellerFramer()
    assert run(f, resp + nxt + resp, [1] * 23) == [resp, nxt, resp]


def test_framer_counts_bad_and_resyncs() -> None:
    good = session(2)
    bad = bytearray(good[3])
    bad[4] ^= 0x08
    stream = b"\x00\xff\x13" + good[2] + bytes(bad) + good[4] + good[5] + good[3][:5]
    f = KellerFramer()
    out = run(f, stream, [3] * 20)
    assert out == [good[2], good[4], good[5]]
    assert f.stats.bad_checksums >= 1
    assert f.stats.truncated == 1
    assert f.stats.dropped_bytes + sum(map(len, out)) == len(stream)


