"""DIDSON-class live frames: build/encode/decode round trips, geometry, zero copy, framer."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import aris, didson
from auvlink.decode_file import decode_bytes
from auvlink.errors import DecodeError, EncodeError
from auvlink.framing.aris import DidsonFramer

RNG = np.random.default_rng(7)


def image(samples: int = 512) -> np.ndarray:
    return RNG.integers(0, 256, size=(samples, 96), dtype=np.uint8)


def test_build_encode_decode() -> None:
    img = image()
    f = didson.build(img, window_start_m=1.0, window_length_m=10.0, sound_speed=1480.0, frame_index=42,
                     time=1_700_000_000.25, heading=math.radians(350.0), pitch=-0.1, roll=0.02)
    raw = didson.encode(f)
    assert len(raw) == 1024 + 96 * 512
    assert raw[12:16] == b"DDF\x05"
    g = didson.decode(raw)
    assert g == f and isinstance(g, didson.DidsonFrame)
    assert didson.encode(g) == raw
    np.testing.assert_array_equal(g.image, img)
    assert (g.frame_index, g.ping_mode, g.beam_count, g.samples_per_beam) == (42, 3, 96, 512)
    assert g.time == pytest.approx(1_700_000_000.25, abs=1e-6) and g.sonar_time == g.time
    assert g.sound_speed == 1480.0
    assert g.heading == pytest.approx(math.radians(350.0)) and g.pitch == pytest.approx(-0.1)
    assert g.roll == pytest.approx(0.02)
    assert g.samples_reordered
    assert didson.build(img, 1.0, 10.0).heading is None  # NaN in the header


def test_geometry() -> None:
    f = didson.build(image(), window_start_m=2.5, window_length_m=10.0)
    assert f.window_start_m == 2.5 and f.window_length_m == 10.0
    np.testing.assert_allclose(f.ranges_m, 2.5 + np.arange(512) * 10.0 / 512)
    assert f.range_resolution_m == pytest.approx(10.0 / 512)
    az = f.azimuths_rad
    assert len(az) == 96
    assert az[0] == pytest.approx(math.radians(-14.5)) and az[-1] == pytest.approx(math.radians(14.5))
    np.testing.assert_allclose(np.diff(az), math.radians(29.0 / 95))
    # the integer-microsecond ARIS fields are filled too (rounded) for ARIS tools
    assert f.field("SampleStartDelay") == round(2 * 2.5 / 1500.0 * 1e6)
    assert f.field("SamplePeriod") == round(2 * 10.0 / (1500.0 * 512) * 1e6)


def test_image_orientation_on_the_wire() -> None:
    img = np.zeros((4, 96), np.uint8)
    img[:, 0] = 200  # port-most column
    raw = didson.encode(didson.build(img, 1.0, 4.0))
    rows = np.frombuffer(raw, np.uint8, offset=1024).reshape(4, 96)
    assert np.all(rows[:, 95] == 200) and rows[:, :95].max() == 0  # SDK beam 95 = port-most
    as_aris = aris.decode(raw)  # the same bytes are a valid ARIS frame (96-beam table azimuths)
    np.testing.assert_array_equal(as_aris.image, img)
    assert as_aris.azimuths_rad[0] < 0 < as_aris.azimuths_rad[-1]


def test_decode_is_zero_copy() -> None:
    raw = didson.encode(didson.build(image(), 1.0, 10.0))
    f = didson.decode(raw)
    assert np.shares_memory(f.image, np.frombuffer(raw, np.uint8))
    assert not f.image.flags.writeable


def test_build_rejects_bad_input() -> None:
    with pytest.raises(EncodeError, match="96 beams"):
        didson.build(np.zeros((512, 48), np.uint8), 1.0, 10.0)
    with pytest.raises(EncodeError, match="uint8"):
        didson.build(np.zeros((512, 96), np.float32), 1.0, 10.0)
    with pytest.raises(EncodeError, match="uint8"):
        didson.build(np.full((8, 96), 300), 1.0, 10.0)
    assert didson.build(np.full((8, 96), 255, np.int64), 1.0, 10.0).image.dtype == np.uint8
    for kwargs in ({"window_length_m": 0.0}, {"window_start_m": -1.0}, {"sound_speed": math.nan}):
        args = {"window_start_m": 1.0, "window_length_m": 10.0} | kwargs
        with pytest.raises(EncodeError):
            didson.build(image(8), args["window_start_m"], args["window_length_m"],
                         sound_speed=args.get("sound_speed", 1500.0))
    with pytest.raises(EncodeError):
        didson.build(image(8), 1.0, 10.0, frame_index=-1)


def test_decode_rejects_non_didson() -> None:
    f48 = aris.decode(b"".join([_aris_48_header(4), bytes(48 * 4)]))
    with pytest.raises(DecodeError, match="96"):
        didson.decode(aris.encode(f48))
    framer = DidsonFramer()
    assert framer.feed(aris.encode(f48)) == [] and framer.flush() == []


def _aris_48_header(samples: int) -> bytes:
    raw = bytearray(didson.encode(didson.build(image(samples), 1.0, 1.0))[:1024])
    raw[436:440] = (1).to_bytes(4, "little")  # ping mode 1: 48 beams
    return bytes(raw)


@settings(max_examples=80, suppress_health_check=[HealthCheck.too_slow])
@given(
    samples=st.integers(1, 16),
    window_start=st.floats(0.0, 50.0),
    window_length=st.floats(0.5, 60.0),
    sound_speed=st.floats(1400.0, 1600.0),
    frame_index=st.integers(0, 2**32 - 1),
    time=st.floats(0.0, 4e9),
    angles=st.tuples(*[st.none() | st.floats(-math.pi, math.pi)] * 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_build_round_trip(samples: int, window_start: float, window_length: float, sound_speed: float,
                          frame_index: int, time: float, angles: tuple[float | None, ...], seed: int) -> None:
    img = np.random.default_rng(seed).integers(0, 256, (samples, 96), dtype=np.uint8)
    f = didson.build(img, window_start, window_length, sound_speed, frame_index, time, *angles)
    raw = didson.encode(f)
    g = didson.decode(raw)
    assert g == f
    assert didson.encode(g) == raw
    assert g.window_start_m == pytest.approx(window_start, rel=1e-6)
    assert g.window_length_m == pytest.approx(window_length, rel=1e-6)
    assert g.time == pytest.approx(time, abs=1e-6)
    assert g.frame_index == frame_index and g.sound_speed == pytest.approx(sound_speed, rel=1e-6)
    for got, want in zip((g.heading, g.pitch, g.roll), angles, strict=True):
        assert (got is None) if want is None else got == pytest.approx(want, abs=1e-6)


def test_stream_through_registry() -> None:
    fmt = formats.get("didson")
    assert fmt.encoding == "soundmetrics.didson" and fmt.read_file is None
    frames = [didson.build(image(64), 1.0, 10.0, frame_index=i, time=1.7e9 + 0.1 * i) for i in range(5)]
    stream = b"\xff" * 33 + b"".join(didson.encode(f) for f in frames) + b"\x00" * 100
    got: list[didson.DidsonFrame] = []
    res = decode_bytes(stream, fmt, got.append)
    assert got == frames and res.decode_errors == 0
    assert res.framer["dropped_bytes"] == 133 and res.framer["truncated"] == 0
    assert res.t_first == pytest.approx(1.7e9) and res.t_last == pytest.approx(1.7e9 + 0.4)
    assert fmt.to_json is not None and fmt.to_json(got[0])["beams"] == 96


