"""Oculus wire format: golden facts of the real capture, exact round trips, hypothesis, damage, framer."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auvlink.codecs import oculus
from auvlink.codecs.oculus_messages import OculusFire, OculusFireCommand, OculusHeader, OculusStatus
from auvlink.errors import DecodeError
from auvlink.framing.oculus import OculusFramer, message_length
from auvlink.framing.oculus_defs import (
    EXT_FLAG_DATA_32BIT,
    FLAG_RANGE_AS_METERS,
    FLAG_SEND_GAIN,
    HEADER,
    OCULUS_ID_BYTES,
)


@pytest.fixture(scope="module")
def capture(shared_data: Path) -> bytes:
    return (shared_data / "oculus" / "one_ping_8bit.raw").read_bytes()


def test_golden_facts_of_the_capture(capture: bytes) -> None:
    ping = oculus.decode(capture)
    assert isinstance(ping, oculus.OculusPing)
    assert ping.header.msg_version == 0 and len(capture) == 182016
    assert ping.ping_id == 415323
    assert (ping.n_beams, ping.n_ranges) == (256, 703)
    assert math.degrees(ping.bearings_rad[0]) == pytest.approx(-30.0)
    assert math.degrees(ping.bearings_rad[-1]) == pytest.approx(30.0)
    assert ping.frequency_hz == pytest.approx(2098880.6, abs=0.05)
    assert ping.range_resolution_m == 0.0028421889710794315
    assert ping.speed_of_sound_mps == 1490.658551265436
    assert ping.fire.range == 2.0 and ping.fire.flags & FLAG_RANGE_AS_METERS
    assert ping.fire.gain_percent == 50.0
    assert ping.fire.master_mode == 2
    assert ping.image_offset == 2048 and ping.image.dtype == np.uint8 and ping.image.nbytes == 179968
    assert ping.row_gain is None
    assert round(float(ping.image.mean()), 3) == 55.857
    facts = oculus.to_json(ping)
    assert facts["image_size"] == 179968 and facts["bearing_max_deg"] == 30.0


def test_capture_round_trips_exactly(capture: bytes) -> None:
    assert oculus.encode(oculus.decode(capture)) == capture


def _framed(stream: bytes, chunk: int) -> tuple[list[bytes], OculusFramer]:
    framer = OculusFramer()
    frames = [f for k in range(0, len(stream), chunk) for f in framer.feed(stream[k : k + chunk])]
    return frames + framer.flush(), framer


def _other_ping(capture: bytes, ping_id: int) -> bytes:
    ping = oculus.decode(capture)
    assert isinstance(ping, oculus.OculusPing)
    image = np.ascontiguousarray(ping.image[::-1])
    return oculus.encode(oculus.OculusPing(**{**ping.__dict__, "ping_id": ping_id, "image": image}))


@pytest.mark.parametrize("chunk", [1 << 20, 4093, 16])
def test_damage_loses_only_the_damaged_message(capture: bytes, chunk: int) -> None:
    a, b, c = capture, _other_ping(capture, 2), _other_ping(capture, 3)
    cut = a[: len(a) // 2]
    flipped = bytearray(b)
    flipped[5000] ^= 0xFF
    flipped[90000] ^= 0x55
    stream = b"garbage SO\x00" + cut + b"\x01SO junk" + bytes(flipped) + bytes(range(256)) + c + a[:100]
    frames, framer = _framed(stream, chunk)
    assert frames[0] == bytes(flipped) and frames[1] == c and len(frames) == 2
    assert framer.stats.truncated == 2  # the cut message and the cut tail


def test_frame_count_header_is_bounded() -> None:
    header = bytes.fromhex("534f0000000023000000") + (1 << 31).to_bytes(4, "little") + bytes(2)
    framer = OculusFramer()
    assert framer.feed(header + bytes(64)) == [] and framer.buffered <= 1


def test_decode_rejects_bad_messages(capture: bytes) -> None:
    for bad in (capture[:10], capture[:-1], b"XX" + capture[2:], capture[:100] + bytes(len(capture) - 100)):
        with pytest.raises(DecodeError):
            oculus.decode(bad)


_F64 = st.floats(allow_nan=False, allow_infinity=False, width=64)
_U32 = st.integers(0, 2**32 - 1)


@st.composite
def pings(draw: st.DrawFn) -> oculus.OculusPing:
    version = draw(st.sampled_from([0, 1, 2]))
    sample = draw(st.sampled_from([1, 2, 4] if version == 2 else [1, 2]))
    gain = draw(st.booleans())
    beams, rows = draw(st.integers(1, 24)), draw(st.integers(1, 16))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 2 ** (8 * sample), (rows, beams), dtype=f"u{sample}")
    flags = FLAG_RANGE_AS_METERS | (FLAG_SEND_GAIN if gain else 0)
    fire = OculusFire(master_mode=draw(st.sampled_from([1, 2])), ping_rate=draw(st.integers(0, 5)), flags=flags,
                      range=draw(_F64), gain_percent=draw(_F64), speed_of_sound_mps=draw(_F64),
                      ext_flags=EXT_FLAG_DATA_32BIT if sample == 4 else 0)
    table = np.sort(rng.integers(-6500, 6500, beams)).astype(float)
    v2: dict[str, Any] = {"heading_deg": draw(_F64), "pitch_deg": draw(_F64), "roll_deg": draw(_F64),
          "ping_start_time": draw(_F64)} if version == 2 else {"ping_start_time": float(draw(_U32))}
    return oculus.OculusPing(
        header=OculusHeader(draw(st.integers(0, 65535)), 0, version, 0), fire=fire, ping_id=draw(_U32),
        status=draw(_U32), frequency_hz=draw(_F64), temperature_c=draw(_F64), pressure_bar=draw(_F64),
        speed_of_sound_mps=draw(_F64), range_resolution_m=draw(_F64),
        bearings_rad=np.radians(table * 0.01), image=image,
        row_gain=rng.normal(size=rows).astype(np.float32) if gain else None,
        padding=draw(st.binary(max_size=8)), trailer=draw(st.binary(max_size=8)), **v2,
    )


@settings(max_examples=60, deadline=None)
@given(pings())
def test_ping_round_trip(ping: oculus.OculusPing) -> None:
    raw = oculus.encode(ping)
    back = oculus.decode(raw)
    assert isinstance(back, oculus.OculusPing)
    assert back == ping and oculus.encode(back) == raw
    assert np.array_equal(back.image, ping.image) and back.image.dtype == ping.image.dtype
    assert np.allclose(back.bearings_rad, ping.bearings_rad, atol=1e-12)
    frames, _ = _framed(b"\x00SO" + raw + raw, 7)
    assert frames == [raw, raw]


@settings(max_examples=30, deadline=None)
@given(st.sampled_from([1, 2]), st.integers(0, 5), _F64, _F64)
def test_fire_and_status_round_trip(version: int, rate: int, range_m: float, gain: float) -> None:
    cmd = OculusFireCommand(OculusHeader(1, 2, version, 0), OculusFire(ping_rate=rate, range=range_m,
                                                                      gain_percent=gain))
    assert oculus.decode(oculus.encode(cmd)) == cmd
    status = OculusStatus(OculusHeader(7892, 0, 2, 0), 7892, 1, 1042, 5, (1, 2, 3, 4, 5, 6), "192.168.2.3",
                          "255.255.255.0", "192.168.2.10", "00:1a:2b:3c:4d:5e", (gain,) * 8, range_m)
    assert oculus.decode(oculus.encode(status)) == status


def test_whole_message_fast_path_agrees_with_the_general_path(capture: bytes) -> None:
    fast = OculusFramer()
    assert fast.feed(capture)[0] is capture  # one whole message in one feed: no copy
    two = capture[:5000] + capture  # a cut message then a whole one, in one feed: the general path
    general = OculusFramer()
    assert general.feed(two) + general.flush() == [capture] and general.stats.truncated == 1


def _whole_by_scanning(raw: bytes) -> bytes | None:
    """The whole-message check done the plain way: every id inside the message is a header it cannot hold."""
    if message_length(raw, 0) != len(raw):
        return None
    inner = raw.find(OCULUS_ID_BYTES, 1)
    while inner >= 0:
        if message_length(raw, inner) != 0:
            return None
        inner = raw.find(OCULUS_ID_BYTES, inner + 1)
    return raw


@settings(max_examples=300, deadline=None)
@given(payload=st.binary(max_size=120), plants=st.lists(st.tuples(
    st.integers(0, 119), st.sampled_from([0x23, 0x15, 0x80, 0x07, 0x4F53]), st.integers(0, 3), st.integers(0, 200)),
    max_size=4))
def test_whole_message_check_agrees_with_scanning_every_id(payload: bytes, plants: list[tuple[int, int, int, int]]
                                                           ) -> None:
    body = bytearray(payload)
    for pos, msg_id, version, size in plants:  # ids, some with a sane header after them, inside the payload
        head = OCULUS_ID_BYTES + bytes(4) + msg_id.to_bytes(2, "little") + version.to_bytes(2, "little") \
            + size.to_bytes(4, "little")
        body[pos:pos + len(head)] = head
    raw = HEADER.pack({"oculus_id": 0x4F53, "src_device_id": 0, "dst_device_id": 0,
                           "msg_id": 0x23, "msg_version": 2, "payload_size": len(body), "spare": 0}) + bytes(body)
    assert (OculusFramer()._whole(raw) is None) == (_whole_by_scanning(raw) is None)
