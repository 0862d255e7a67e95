"""The framers' one-whole-frame fast path (``Framer._whole``, used by replay) returns exactly what the
general path returns: same frames, same counters, same bytes left buffered, for whole frames, damaged
frames, frames with garbage around them and arbitrary chunking."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.framing.base import Framer


def _frames() -> dict[str, list[bytes]]:
    from auvlink.codecs import can_nav, didson, dsp1760, dsp3000, paro, pd0_build
    from auvlink.codecs import pd0 as pd0_codec

    rng = np.random.default_rng(3)
    return {
        "dsp1760": [dsp1760.encode(dsp1760.build((1e-4 * i, 2e-5, -1e-4), (0.1, 0.0, -9.8), sequence=i))
                    for i in range(3)],
        "can": [can_nav.encode(can_nav.build(n)) for n in can_nav.message_names()[:3]],
        "paro": [paro.encode(paro.build_reading(101325.0 + 1e3 * i)) for i in range(3)],
        "dsp3000": [dsp3000.encode(dsp3000.build(0.01 * i - 0.5)) for i in range(3)],
        "pd0": [pd0_codec.encode(pd0_build.build(i, 1.7e9 + i, bt_velocity_mps=(0.5, 0.1, 0.0, 0.01),
                                                  bt_range_m=(5.0, 5.1, 5.2, 5.3), n_cells=4))
                for i in range(3)],
        "didson": [didson.encode(didson.build(rng.integers(0, 256, (64, 96), dtype=np.uint8), 1.0, 10.0,
                                              frame_index=i)) for i in range(2)],
    }


FRAMES = _frames()
FORMATS = sorted(FRAMES)


def _pair(fmt: str) -> tuple[Framer, Framer]:
    """A framer with the fast path and one with it switched off (the general path only)."""
    fast = formats.get(fmt).framer()
    slow = formats.get(fmt).framer()
    slow._whole = lambda data: None  # type: ignore[method-assign]
    return fast, slow


def _same(fmt: str, pieces: list[bytes], final: bool = True) -> list[bytes]:
    fast, slow = _pair(fmt)
    got_fast = [f for p in pieces for f in fast.feed(p)]
    got_slow = [f for p in pieces for f in slow.feed(p)]
    assert got_fast == got_slow
    assert fast.buffered == slow.buffered
    if final:
        got_fast += fast.flush()
        got_slow += slow.flush()
        assert got_fast == got_slow
    assert fast.stats.as_dict() == slow.stats.as_dict()
    assert all(type(f) is bytes for f in got_fast)
    return got_fast


@pytest.mark.parametrize("fmt", FORMATS)
def test_one_frame_per_feed_takes_the_fast_path_without_a_copy(fmt: str) -> None:
    framer = formats.get(fmt).framer()
    calls: list[int] = []
    whole: Callable[[bytes], bytes | None] = framer._whole

    def spy(data: bytes) -> bytes | None:
        out = whole(data)
        calls.append(out is not None)
        return out

    framer._whole = spy  # type: ignore[method-assign,assignment]
    for raw in FRAMES[fmt]:
        out = framer.feed(raw)
        assert out == [raw] and out[0] is raw  # the message's bytes themselves
    assert calls == [True] * len(FRAMES[fmt])
    assert framer.stats.frames == len(FRAMES[fmt])
    assert framer.stats.bytes_in == sum(map(len, FRAMES[fmt]))
    assert framer.stats.dropped_bytes == framer.stats.bad_checksums == 0
    assert framer.buffered == 0
    assert _same(fmt, FRAMES[fmt]) == FRAMES[fmt]


@pytest.mark.parametrize("fmt", FORMATS)
def test_damaged_and_surrounded_frames_match_the_general_path(fmt: str) -> None:
    raw = FRAMES[fmt][0]
    cases = [
        raw[:-1],  # cut short
        raw + b"\x00",  # a byte too many
        b"\x55" + raw,  # garbage before
        raw + raw,  # two frames in one message
        raw[: len(raw) // 2],  # half, then the rest
        b"",
    ]
    for k in range(0, len(raw), max(1, len(raw) // 7)):  # one flipped bit in several places
        bad = bytearray(raw)
        bad[k] ^= 0x10
        cases.append(bytes(bad))
    for case in cases:
        _same(fmt, [case, *FRAMES[fmt][1:]])
        _same(fmt, [case], final=False)
    _same(fmt, [raw[: len(raw) // 2], raw[len(raw) // 2 :], raw])  # a frame split over two messages


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(fmt=st.sampled_from(FORMATS), data=st.data())
def test_any_chunking_and_bit_flips_match_the_general_path(fmt: str, data: st.DataObject) -> None:
    stream = bytearray(b"".join(FRAMES[fmt]))
    for _ in range(data.draw(st.integers(0, 3))):
        stream[data.draw(st.integers(0, len(stream) - 1))] ^= 1 << data.draw(st.integers(0, 7))
    cuts = sorted(data.draw(st.lists(st.integers(0, len(stream)), max_size=6)))
    pieces = [bytes(stream[a:b]) for a, b in zip([0, *cuts], [*cuts, len(stream)], strict=True)]
    _same(fmt, pieces)


def test_replayed_sonar_image_is_a_view_of_the_logged_frame(tmp_path: Path) -> None:
    """Replay of a one-frame-per-message log: the framer hands on the message's bytes and the DIDSON
    image is a zero-copy view of them; the frames and their decode equal the originals."""
    from auvlink.codecs import didson
    from logs_format import MissionLogWriter, Replay

    path = tmp_path / "sonar.mcap"
    frames = FRAMES["didson"] + FRAMES["didson"][:1]
    with MissionLogWriter(path, flush_interval=0) as log:
        for i, raw in enumerate(frames):
            log("sonar", "didson", 1_700_000_000_000_000_000 + i * 100_000_000, raw)
    logged: list[bytes] = []
    with Replay(path) as rep:
        messages = rep.reader.messages

        def spy(*args: Any, **kwargs: Any) -> Any:
            for msg in messages(*args, **kwargs):
                logged.append(msg.data)
                yield msg

        rep.reader.messages = spy  # type: ignore[method-assign]
        samples = list(rep.samples())
        stats = rep.stats()["sonar"]
    assert [s.raw for s in samples] == frames
    for s, raw, data in zip(samples, frames, logged, strict=True):
        assert s.raw is data  # no copy between the log reader and the sample
        assert np.shares_memory(np.frombuffer(data, np.uint8), s.record.image)
        assert s.record == didson.decode(raw)
    assert stats["framer_frames"] == len(frames) and stats["framer_dropped_bytes"] == 0


@pytest.mark.parametrize("sane", [False, True])
def test_sonar_frame_with_a_signature_inside_matches_the_general_path(sane: bool) -> None:
    """The image bytes spell the frame signature (a false header, or a sane one: the frame was cut)."""
    raw = bytearray(FRAMES["didson"][0])
    for at in (2000, len(raw) - 4, 1024, 13):
        bad = bytearray(raw)
        if sane:
            bad[at - 12 : at - 12 + 1024] = raw[:1024]  # a whole sane header inside the body
        else:
            bad[at : at + 4] = b"DDF\x05"
        _same("didson", [bytes(bad)])
        _same("didson", [bytes(bad), FRAMES["didson"][1]])


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=64), st.integers(0, 70), st.integers(-1, 70))
def test_has_signature_is_bytes_find(data: bytes, start: int, at: int) -> None:
    from auvlink.framing.aris import has_signature

    if 0 <= at <= len(data):
        data = data[:at] + b"DDF\x05" + data[at:]
    assert has_signature(data, start) == (data.find(b"DDF\x05", start) >= 0)
