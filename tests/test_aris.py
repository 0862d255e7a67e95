"""ARIS codec, file reader and sonar-frame framer: real recording facts, round trips, fuzz."""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import numpy as np
import pytest
from framer_helpers import run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.codecs import aris
from auvlink.decode_file import decode_bytes
from auvlink.errors import DecodeError
from auvlink.framing.aris import ArisFramer
from auvlink.framing.aris_defs import (
    FILE_HEADER_DTYPE,
    FRAME_HEADER_DTYPE,
    PING_MODE_BEAMS,
    SIGNATURE_U32,
    beam_azimuths_rad,
    beam_table_name,
    beam_tables,
    offset,
)

SOUND_SPEED = 1435.93


def make_frame(ping_mode: int = 1, samples: int = 8, index: int = 0, seed: int = 0) -> bytes:
    """A small synthetic ARIS frame (header zeros but the fields that matter, random image)."""
    rng = np.random.default_rng(seed)
    h = np.zeros(1, FRAME_HEADER_DTYPE)
    h["FrameIndex"], h["Version"] = index, SIGNATURE_U32
    h["PingMode"], h["SamplesPerBeam"] = ping_mode, samples
    h["FrameTime"] = 1_700_000_000_000_000 + 100_000 * index
    h["SoundSpeed"], h["SamplePeriod"], h["SampleStartDelay"] = 1500.0, 10, 2000
    img = rng.integers(0, 256, PING_MODE_BEAMS[ping_mode] * samples, dtype=np.uint8)
    return h.tobytes() + img.tobytes()


# --- the real recording ------------------------------------------------------------------
@pytest.fixture(scope="module")
def sample(shared_data: Path) -> bytes:
    return (shared_data / "aris" / "sample.aris").read_bytes()


def test_sample_facts(sample: bytes) -> None:
    assert sample[:4] == bytes.fromhex("44444605")
    result = aris.read_file(sample)
    header, frames = result  # unpacks as (file header, frames)
    assert header is not None and result.problems == []
    assert result.stats == {"frames": 6, "bytes_in": len(sample), "dropped_bytes": 0, "bad_checksums": 0,
                            "truncated": 0}
    assert header.version == SIGNATURE_U32 and header.frame_count == 6
    assert header.num_raw_beams == 48 and header.samples_per_channel == 2000
    assert len(frames) == 6
    for i, f in enumerate(frames):
        assert f.frame_index == i
        assert (f.ping_mode, f.beam_count, f.samples_per_beam) == (1, 48, 2000)
        assert f.image.shape == (2000, 48)
        assert f.sound_speed == pytest.approx(SOUND_SPEED, abs=0.01)
        assert f.sample_period == pytest.approx(14e-6)
        assert f.sample_start_delay == pytest.approx(4593e-6)
        assert f.samples_reordered and f.large_lens
        assert f.field("Version") == SIGNATURE_U32
    times = [f.time for f in frames]
    assert all(b > a for a, b in itertools.pairwise(times))
    assert times[0] == pytest.approx(1371198079.122519, abs=1e-6)  # 2013-06-14 UTC


def test_sample_geometry(sample: bytes) -> None:
    f = aris.read_file(sample).frames[0]
    start = 4593e-6 * f.sound_speed / 2
    step = 14e-6 * f.sound_speed / 2
    assert f.window_start_m == pytest.approx(start) and start == pytest.approx(3.2976, abs=1e-4)
    assert f.window_length_m == pytest.approx(2000 * step)
    np.testing.assert_allclose(f.ranges_m, start + step * np.arange(2000))
    assert f.ranges_m[-1] == pytest.approx(23.3906, abs=1e-3)
    # LargeLens = 1 and 48 beams: the SDK telephoto table, +-7.339 deg, increasing to starboard
    center = beam_tables()["ARIS_Telephoto_48"]
    np.testing.assert_allclose(f.azimuths_rad, np.deg2rad(-center[::-1]))
    assert np.rad2deg(f.azimuths_rad[[0, -1]]) == pytest.approx([-7.339, 7.339])
    assert np.all(np.diff(f.azimuths_rad) > 0)


def test_sample_round_trip_and_zero_copy(sample: bytes) -> None:
    result = aris.read_file(sample)
    assert aris.encode_file(result.header, result.frames) == sample
    flat = np.frombuffer(sample, np.uint8)
    size = 1024 + 48 * 2000
    for i, f in enumerate(result.frames):
        start = 1024 + i * size
        raw = sample[start : start + size]
        assert aris.encode(f) == raw
        assert aris.encode(aris.decode(raw)) == raw
        assert aris.decode(raw) == f
        assert np.shares_memory(f.image, flat)  # a view of the file bytes
        # image[m, j] is SDK beam (47 - j) of sample row m
        for m, j in ((0, 0), (5, 47), (1999, 10)):
            assert f.image[m, j] == sample[start + 1024 + m * 48 + (47 - j)]


def test_sample_through_framer_and_registry(sample: bytes) -> None:
    framer = ArisFramer()
    raws = run(framer, sample[1024:], [4096] * 140)
    assert len(raws) == 6 and framer.stats.dropped_bytes == 0 and framer.stats.truncated == 0
    fmt = formats.get("aris")
    assert fmt.encoding == "soundmetrics.aris" and fmt.read_file is aris.read_file
    got: list[aris.ArisFrame] = []
    res = decode_bytes(sample, fmt, got.append)
    assert res.records == 6 and not res.problems and res.t_first == pytest.approx(got[0].time)
    js = fmt.to_json(got[0]) if fmt.to_json else {}
    assert js["beams"] == 48 and js["samples"] == 2000
    json.dumps(js)


def test_damaged_file_keeps_good_frames(sample: bytes) -> None:
    size = 1024 + 48 * 2000
    f = [sample[1024 + i * size : 1024 + (i + 1) * size] for i in range(6)]
    bad_header = bytearray(f[2])
    bad_header[436] = 77  # unknown ping mode: this frame is lost, the others stay
    data = sample[:1024] + f[0] + b"junk" * 10 + f[1] + bytes(bad_header) + f[3] + f[4] + f[5][:5000]
    result = aris.read_file(data)
    assert [x.frame_index for x in result.frames] == [0, 1, 3, 4]
    assert result.stats["truncated"] == 1
    assert any("40 bytes at offset" in p for p in result.problems)
    assert any("truncated" in p for p in result.problems)
    with pytest.raises(DecodeError):
        aris.read_file(b"not an aris file" * 100)
    bare = aris.read_file(sample[1024:])  # a bare frame stream, e.g. exported from a log
    assert bare.header is None and len(bare.frames) == 6 and not bare.problems
    assert aris.encode_file(None, bare.frames) == sample[1024:]


# --- layout and tables -------------------------------------------------------------------
def test_field_offsets_match_sdk() -> None:
    frame_offsets = {"FrameTime": 4, "Version": 12, "WindowStart": 52, "Latitude": 172, "VehicleTime": 268,
                     "Tmatrix": 356, "SampleRate": 420, "PingMode": 436, "SamplePeriod": 452,
                     "SoundSpeed": 464, "SamplesPerBeam": 468, "SampleStartDelay": 476, "LargeLens": 480,
                     "ReorderedSamples": 516, "Pressure": 524, "Uptime": 700, "GoTime": 708,
                     "SystemVariant": 732}
    for name, off in frame_offsets.items():
        assert offset(FRAME_HEADER_DTYPE, name) == off, name
    for name, off in {"SN": 44, "strHeaderID": 80, "UserID1": 336, "FileSize": 424, "LargeLens": 452}.items():
        assert offset(FILE_HEADER_DTYPE, name) == off, name
    assert FRAME_HEADER_DTYPE.itemsize == FILE_HEADER_DTYPE.itemsize == 1024


def test_beam_tables() -> None:
    tables = beam_tables()
    sizes = {"ARIS1800_1200_48": 48, "ARIS1800_96": 96, "ARIS3000_64": 64, "ARIS3000_128": 128,
             "ARIS_Telephoto_48": 48, "ARIS_Telephoto_96": 96}
    assert {k: len(v) for k, v in tables.items()} == sizes
    for name, center in tables.items():
        assert np.all(np.diff(center) > 0), name
        assert center[0] < 0 < center[-1], name  # SDK beam 0 (starboard-most) has a negative angle
    assert beam_table_name(48) == "ARIS1800_1200_48" and beam_table_name(96, True) == "ARIS_Telephoto_96"
    assert beam_table_name(128, True) == "ARIS3000_128"
    assert set(PING_MODE_BEAMS.values()) == {48, 64, 96, 128}
    az = beam_azimuths_rad(96)
    assert az[0] == pytest.approx(np.deg2rad(-13.8759)) and az[-1] == pytest.approx(np.deg2rad(13.749))
    with pytest.raises(ValueError):
        az[0] = 0.0  # shared, read-only


@pytest.mark.parametrize("ping_mode", sorted(PING_MODE_BEAMS))
def test_every_ping_mode(ping_mode: int) -> None:
    raw = make_frame(ping_mode, samples=3)
    f = aris.decode(raw)
    beams = PING_MODE_BEAMS[ping_mode]
    assert f.image.shape == (3, beams) == (3, len(f.azimuths_rad))
    assert f.azimuths_rad is aris.ping_mode_azimuths_rad(ping_mode)
    assert aris.encode(f) == raw
    assert f.ranges_m[0] == pytest.approx(2000e-6 * 1500 / 2)
    assert f.range_resolution_m == pytest.approx(0.0075)


def test_decode_errors() -> None:
    raw = make_frame(1, 4)
    wrong_sig = raw[:12] + b"DDF\x04" + raw[16:]
    for bad, why in ((raw[:-1], "header says"), (raw[:500], "shorter"), (wrong_sig, "signature")):
        with pytest.raises(DecodeError, match=why):
            aris.decode(bad)
    b = bytearray(raw)
    b[436] = 13
    with pytest.raises(DecodeError, match="ping mode 13"):
        aris.decode(bytes(b))


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(min_size=1024, max_size=1024), st.sampled_from(sorted(PING_MODE_BEAMS)), st.integers(1, 6),
       st.data())
def test_round_trip_any_header(header: bytes, ping_mode: int, samples: int, data: st.DataObject) -> None:
    h = np.frombuffer(header, FRAME_HEADER_DTYPE).copy()  # random floats, NaNs, padding included
    h["Version"], h["PingMode"], h["SamplesPerBeam"] = SIGNATURE_U32, ping_mode, samples
    image = data.draw(st.binary(min_size=PING_MODE_BEAMS[ping_mode] * samples,
                                max_size=PING_MODE_BEAMS[ping_mode] * samples))
    raw = h.tobytes() + image
    frame = aris.decode(raw)
    assert aris.encode(frame) == raw
    assert aris.decode(aris.encode(frame)) == frame
    assert frame.image.base is not None and not frame.image.flags.owndata


# --- framer ------------------------------------------------------------------------------
def test_framer_cut_frame_does_not_swallow_next() -> None:
    a, b, c = make_frame(1, 10, 0), make_frame(1, 10, 1, seed=1), make_frame(1, 10, 2, seed=2)
    grown = bytearray(a)
    grown[468:472] = (4000).to_bytes(4, "little")  # claims ~190 kB
    framer = ArisFramer()
    out = run(framer, bytes(grown) + b + c, [700, 700, 700])
    assert out == [b, c]
    assert framer.stats.truncated == 1 and framer.stats.dropped_bytes == len(a)
    tail = ArisFramer()
    assert tail.feed(a + b[:-1]) == [a] and tail.flush() == [] and tail.stats.truncated == 1


@pytest.mark.parametrize("field_offset", [12, 436, 468])  # signature, ping mode, samples per beam
def test_framer_every_header_bit_flip(field_offset: int) -> None:
    a, b, c = (make_frame(1, 6, i, seed=i) for i in range(3))
    for bit in range(32):
        damaged = bytearray(a)
        damaged[field_offset + bit // 8] ^= 1 << (bit % 8)
        for cuts in ([], [1100, 300, 50, 2000], [7] * 200):
            framer = ArisFramer()
            out = run(framer, b"\x00" * 5 + bytes(damaged) + b + c, cuts)
            assert out[-2:] == [b, c], (field_offset, bit, cuts)


@pytest.mark.parametrize("damage", ["insert 1 byte", "flip byte 0", "cut 1 byte", "cut 13 bytes", "zero 100 bytes"])
def test_leading_damage_keeps_every_intact_frame(sample: bytes, damage: str) -> None:
    """One damaged byte (or a cut) before the first frame costs no frame: frames are found by their headers."""
    data = {"insert 1 byte": b"\x00" + sample, "flip byte 0": b"\x00" + sample[1:], "cut 1 byte": sample[1:],
            "cut 13 bytes": sample[13:], "zero 100 bytes": bytes(100) + sample[100:]}[damage]
    good = aris.read_file(sample).frames
    result = aris.read_file(data)
    assert [f.frame_index for f in result.frames] == list(range(6))
    assert all(aris.encode(a) == aris.encode(b) for a, b in zip(result.frames, good, strict=True))
    kept = 6 * (1024 + 48 * 2000) + (1024 if result.header is not None else 0)
    assert result.problems and result.stats["dropped_bytes"] == len(data) - kept
    assert (result.header is not None) == (damage == "insert 1 byte")  # an intact header is still found
    res = decode_bytes(data, formats.get("aris"), lambda r: None)  # the `auvlink decode` path
    assert res.records == 6


def test_didson_stream_with_leading_damage_keeps_every_frame() -> None:
    from auvlink.codecs import didson

    rng = np.random.default_rng(1)
    frames = [didson.encode(didson.build(image=rng.integers(0, 256, (32, 96), dtype=np.uint8), frame_index=i,
                                         time=1.7e9 + i, window_start_m=1.0, window_length_m=10.0))
              for i in range(4)]
    stream = b"".join(frames)
    cases = [(b"\x00" + stream, frames), (b"\xff" * 7 + stream, frames), (stream[13:], frames[1:]),
             (b"DDF\x05" * 300 + stream, frames)]
    for data, expected in cases:
        records: list[didson.DidsonFrame] = []
        decode_bytes(data, formats.get("didson"), records.append)
        assert [didson.encode(r) for r in records] == expected
