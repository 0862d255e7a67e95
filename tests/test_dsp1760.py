"""KVH DSP-1750/1760 36-byte binary messages: golden vector, round trips, framer fuzz."""

from __future__ import annotations

import json
import math
import struct

import numpy as np
import pytest
from framer_helpers import run
from hypothesis import assume, given
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import dsp1760
from auvlink.codecs.dsp1760 import Dsp1760Message, G, build, decode, decode_array, encode, to_json
from auvlink.crc import crc32_mpeg2
from auvlink.errors import ChecksumError, DecodeError, EncodeError
from auvlink.framing.dsp1760 import FRAME_SIZE, HEADER, Dsp1760Framer

# published test vector (data/README.md): 32 bytes + CRC 0x4BFA34D8
BODY = bytes.fromhex("FE81FF55 37A96A6E 38586C1F B75BF862 BF803E78 BB650D28 3B0A37AC 77 3D 0028")
VECTOR = BODY + bytes.fromhex("4BFA34D8")

f32 = st.floats(width=32, allow_nan=False)


def frame_from_payload(payload: bytes) -> bytes:
    body = HEADER + payload
    return body + crc32_mpeg2(body).to_bytes(4, "big")


def has_nan(frame: bytes) -> bool:
    return any(math.isnan(v) for v in struct.unpack_from(">6f", frame, 4))


# --- codec -------------------------------------------------------------------------------
def test_golden_crc() -> None:
    assert crc32_mpeg2(BODY) == 0x4BFA34D8
    assert len(VECTOR) == FRAME_SIZE == 36


def test_golden_decode() -> None:
    m = decode(VECTOR)
    assert m.mode == "rate"
    assert m.gyro == pytest.approx((2.0196e-5, 5.1599e-5, -1.3111e-5), rel=1e-4)
    assert m.angular_rate == m.gyro and m.delta_angle is None
    assert m.accel_g == pytest.approx((-1.00191, -0.003495, 0.002109), rel=1e-4)
    assert m.accel == pytest.approx((-1.00191 * G, -0.003495 * G, 0.002109 * G), rel=1e-4)
    assert m.accel[0] == pytest.approx(-9.8253, abs=1e-4)  # m/s^2: one g pointing along -x
    assert m.status == 0x77 and m.valid
    assert m.gyro_valid == (True, True, True) and m.accel_valid == (True, True, True)
    assert m.sequence == 61
    assert m.temperature_c == 40


def test_delta_mode() -> None:
    m = decode(VECTOR, mode="delta")
    assert m.delta_angle == m.gyro and m.angular_rate is None
    assert to_json(m)["gyro_unit"] == "rad"
    assert encode(m) == VECTOR
    with pytest.raises(ValueError):
        decode(VECTOR, mode="integrated")


def test_status_bits() -> None:
    m = build((0, 0, 0), (0, 0, 0), status=0x15)  # gyro x, gyro z, accel x
    assert m.gyro_valid == (True, False, True)
    assert m.accel_valid == (True, False, False)
    assert not m.valid


def test_bad_crc_raises_with_values() -> None:
    bad = bytearray(VECTOR)
    bad[10] ^= 0x01
    with pytest.raises(ChecksumError) as info:
        decode(bytes(bad))
    assert info.value.expected == 0x4BFA34D8
    assert info.value.actual == crc32_mpeg2(bytes(bad[:32]))


@pytest.mark.parametrize("raw", [VECTOR[:-1], VECTOR + b"\x00", b"\x00" + VECTOR[1:], b""])
def test_malformed_raises_decode_error(raw: bytes) -> None:
    with pytest.raises(DecodeError):
        decode(raw)


def test_encode_rejects_out_of_range() -> None:
    m = decode(VECTOR)
    for bad in (
        Dsp1760Message(m.gyro, m.accel, m.status, 256, m.temperature_c),
        Dsp1760Message(m.gyro, m.accel, m.status, m.sequence, 40000),
        Dsp1760Message((1e39, 0.0, 0.0), m.accel, m.status, m.sequence, m.temperature_c),
    ):
        with pytest.raises(EncodeError):
            encode(bad)
    with pytest.raises(EncodeError):
        build((1e39, 0, 0), (0, 0, 0))


def test_many_generated_frames_round_trip() -> None:
    rng = np.random.default_rng(1760)
    payloads = rng.integers(0, 256, size=(3000, 28), dtype=np.uint8)
    n = 0
    for p in payloads:
        frame = frame_from_payload(p.tobytes())
        if has_nan(frame):
            continue
        assert encode(decode(frame)) == frame
        n += 1
    assert n > 2500


def test_decode_array_matches_decode() -> None:
    rng = np.random.default_rng(7)
    msgs = [
        build(rng.normal(0, 0.1, 3), rng.normal(0, 9.8, 3), sequence=i, temperature_c=20 + i % 7)
        for i in range(200)
    ]
    blob = bytearray(b"".join(encode(m) for m in msgs))
    blob[36 * 5 + 12] ^= 0x40  # damage message 5
    arr = decode_array(bytes(blob))
    assert arr["ok"].sum() == 199 and not arr["ok"][5]
    for i in (0, 17, 199):
        m = msgs[i]
        assert tuple(arr["gyro"][i]) == m.gyro
        assert tuple(arr["accel"][i]) == m.accel
        assert arr["sequence"][i] == m.sequence and arr["temperature_c"][i] == m.temperature_c
    with pytest.raises(DecodeError):
        decode_array(bytes(blob[:-1]))


def test_build_quantises_and_wraps() -> None:
    m = build((0.1, -0.2, 0.3), (0.0, 0.0, -G), sequence=130, temperature_c=21.6)
    assert m.sequence == 2 and m.temperature_c == 22
    assert m.gyro[0] == struct.unpack(">f", struct.pack(">f", 0.1))[0]
    assert m.accel[2] == -G
    assert decode(encode(m)) == m


def test_to_json_and_registry() -> None:
    out = to_json(decode(VECTOR))
    assert json.loads(json.dumps(out)) == out
    assert out["temperature_c"] == 40 and out["sequence"] == 61 and out["gyro_unit"] == "rad/s"
    wf = formats.get("dsp1760")
    assert wf is dsp1760.WIRE_FORMAT
    assert wf.encoding == "kvh.dsp1760"
    assert wf.sensor_time(wf.decode(VECTOR)) is None
    assert isinstance(wf.framer(), Dsp1760Framer)


@given(payload=st.binary(min_size=28, max_size=28))
def test_encode_decode_bytes_exact(payload: bytes) -> None:
    frame = frame_from_payload(payload)
    assume(not has_nan(frame))
    assert encode(decode(frame)) == frame


@given(
    gyro=st.tuples(f32, f32, f32),
    accel_g=st.tuples(f32, f32, f32),
    status=st.integers(0, 255),
    sequence=st.integers(0, 255),
    temp=st.integers(-32768, 32767),
    mode=st.sampled_from(dsp1760.MODES),
)
def test_decode_encode_record(
    gyro: tuple[float, float, float],
    accel_g: tuple[float, float, float],
    status: int,
    sequence: int,
    temp: int,
    mode: str,
) -> None:
    accel = (accel_g[0] * G, accel_g[1] * G, accel_g[2] * G)
    m = Dsp1760Message(gyro, accel, status, sequence, temp, mode)
    assert decode(encode(m), mode=mode) == m


@given(
    gyro=st.tuples(*[st.floats(-10, 10)] * 3),
    accel=st.tuples(*[st.floats(-200, 200)] * 3),
    sequence=st.integers(0, 10_000),
)
def test_build_round_trip(
    gyro: tuple[float, float, float], accel: tuple[float, float, float], sequence: int
) -> None:
    m = build(gyro, accel, sequence=sequence, mode="delta")
    assert decode(encode(m), mode="delta") == m
    assert m.gyro == pytest.approx(gyro, rel=1e-6, abs=1e-37)


# --- framer ------------------------------------------------------------------------------
def test_framer_counts_bad_crc_and_keeps_next() -> None:
    bad = bytearray(VECTOR)
    bad[20] ^= 0x10
    f = Dsp1760Framer()
    out = run(f, bytes(bad) + VECTOR, [])
    assert out == [VECTOR]
    assert f.stats.bad_checksums == 1
    assert f.stats.dropped_bytes == 36


def test_framer_false_header_in_garbage() -> None:
    garbage = b"\x00\x01" + HEADER + b"\x13" * 10  # a header whose message is cut by the real one
    f = Dsp1760Framer()
    out = run(f, garbage + VECTOR + HEADER[:3], [7, 7])
    assert out == [VECTOR]
    assert f.stats.bad_checksums == 1
    assert f.stats.dropped_bytes == len(garbage) + 3
    assert f.stats.truncated == 0


def test_framer_truncated_tail() -> None:
    f = Dsp1760Framer()
    out = run(f, VECTOR + VECTOR[:20], [])
    assert out == [VECTOR]
    assert f.stats.truncated == 1 and f.stats.dropped_bytes == 20


