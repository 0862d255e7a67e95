"""Conformance of every registered wire format: golden values, exact round trips, fuzz, framer chunking.

Parametrized over :func:`auvlink.formats.names` itself, so a format added to the registry is tested
here at once, and fails until ``tests/conformance_table.py`` has its entry and golden file:

- golden: the format's framer cuts the golden stream into the known number of frames, and chosen
  frames decode to known values (``to_json``, SI units);
- round trip: ``encode(decode(x)) == x`` on every golden frame, and ``decode`` of that again equal;
- codec fuzz: garbage, bit flips, truncations and extensions of real frames raise nothing but
  :class:`~auvlink.errors.DecodeError` (its subclasses included);
- framer fuzz: random bytes never raise and every byte is accounted for (framed or dropped); golden
  frames among garbage, decoys (the format's worst-case false starts) and damaged frames are all found,
  in order, for any chunking;
- chunking: any split of a golden stream gives the same frames and the same counters as one feed.

Framer time and buffer bounds are tested in ``tests/test_framer_bounds.py``.
"""

from __future__ import annotations

import bisect
import itertools
import json
import math
from collections.abc import Sequence
from functools import cache
from pathlib import Path
from typing import Any

import pytest
from conformance_table import TABLE, Entry, Golden
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from auvlink import formats
from auvlink.errors import DecodeError
from auvlink.formats import WireFormat

GOLDEN_DIR = Path(__file__).parent / "golden"
SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
NAMES = formats.names()
FUZZ = settings(max_examples=60, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def entry_of(name: str) -> Entry:
    if name not in TABLE:
        pytest.fail(f"wire format {name!r} is registered but has no conformance entry: add one to "
                    f"tests/conformance_table.py with a golden file under tests/golden/{name}/")
    return TABLE[name]


def golden_path(g: Golden) -> Path:
    if g.path.startswith("shared:"):
        path = SHARED_DATA / g.path.removeprefix("shared:")
        if not SHARED_DATA.is_dir():
            pytest.skip(f"real captures not found at {SHARED_DATA} (clone with ../shared beside it)")
    else:
        path = GOLDEN_DIR / g.path
    assert path.is_file(), f"golden file {path} is missing"
    return path


@cache
def _cut(name: str, path: Path, skip: int) -> tuple[bytes, tuple[bytes, ...], dict[str, int]]:
    stream = path.read_bytes()[skip:]
    framer = formats.get(name).framer()
    frames = framer.feed(stream) + framer.flush()
    return stream, tuple(frames), framer.stats.as_dict()


def cut(name: str, g: Golden) -> tuple[bytes, tuple[bytes, ...], dict[str, int]]:
    """(stream, frames, framer stats) of a golden file, cut in one feed."""
    return _cut(name, golden_path(g), g.skip)


def stream_frames(name: str) -> list[bytes]:
    """Up to ``stream_frames`` golden frames of the format's first golden file (for the fuzzed streams)."""
    e = entry_of(name)
    _, frames, _ = cut(name, e.goldens[0])
    assert frames, f"{name}: the golden stream holds no frame"
    return list(frames[: e.stream_frames])


def feed_in_chunks(fmt: WireFormat, stream: bytes, cuts: Sequence[int]) -> tuple[list[bytes], dict[str, int]]:
    """Feed ``stream`` split at the (sorted) positions ``cuts``, then flush."""
    framer = fmt.framer()
    out: list[bytes] = []
    prev = 0
    for c in [*sorted(cuts), len(stream)]:
        out += framer.feed(stream[prev:c])
        prev = c
    out += framer.flush()
    return out, framer.stats.as_dict()


def is_subsequence(expected: Sequence[bytes], got: Sequence[bytes]) -> bool:
    it = iter(got)
    return all(any(x == y for y in it) for x in expected)


def matches(got: Any, want: Any, g: Golden) -> bool:
    if isinstance(want, dict):
        return isinstance(got, dict) and all(k in got and matches(got[k], v, g) for k, v in want.items())
    if isinstance(want, list | tuple):
        return isinstance(got, list | tuple) and len(got) == len(want) and all(
            matches(a, b, g) for a, b in zip(got, want, strict=True))
    if isinstance(want, bool) or isinstance(got, bool):
        return got is want
    if isinstance(want, float) and isinstance(got, int | float):
        return math.isclose(got, want, rel_tol=g.rel_tol, abs_tol=g.abs_tol)
    return bool(got == want)


def goldens(name: str) -> list[Golden]:
    return list(entry_of(name).goldens)


# --- golden values -----------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_entry_and_golden_files(name: str) -> None:
    e = entry_of(name)
    assert e.goldens and e.decoys, f"{name}: the entry needs a golden file and a decoy pattern"
    fmt = formats.get(name)
    assert fmt.name == name and fmt.to_json is not None, f"{name}: a format needs to_json for its golden values"
    for g in e.goldens:
        if not g.path.startswith("shared:"):
            assert (GOLDEN_DIR / g.path).is_file(), f"golden file tests/golden/{g.path} is missing"
        assert g.expect or g.frames is not None, f"{name}: golden {g.path} names no expected value"


@pytest.mark.parametrize("name", NAMES)
def test_golden_frames_decode_to_known_values(name: str) -> None:
    fmt = formats.get(name)
    assert fmt.to_json is not None
    for g in goldens(name):
        _, frames, stats = cut(name, g)
        if g.frames is not None:
            assert len(frames) == g.frames, f"{name} {g.path}: {len(frames)} frames, expected {g.frames}"
        if g.dropped is not None:
            assert stats["dropped_bytes"] == g.dropped, f"{name} {g.path}: {stats}"
        assert stats["bad_checksums"] == g.bad_checksums, f"{name} {g.path}: {stats}"
        for index, want in g.expect.items():
            got = json.loads(json.dumps(fmt.to_json(fmt.decode(frames[index]))))
            bad = {k: (got.get(k, "<missing>"), v) for k, v in want.items() if not matches(got.get(k), v, g)}
            assert not bad, f"{name} {g.path} frame {index}: (decoded, expected) {bad}"


@pytest.mark.parametrize("name", NAMES)
def test_golden_frames_round_trip_exactly(name: str) -> None:
    fmt = formats.get(name)
    for g in goldens(name):
        _, frames, _ = cut(name, g)
        assert frames
        for k, raw in enumerate(frames):
            rec = fmt.decode(raw)
            again = fmt.encode(rec)
            assert again == raw, f"{name} {g.path} frame {k}: encode(decode(x)) != x"
            if k < 8:
                assert fmt.decode(again) == rec


# --- codec fuzz ----------------------------------------------------------------------------------------
def decode_or_decode_error(fmt: WireFormat, raw: bytes) -> None:
    """``decode`` returns a record or raises DecodeError; anything else escapes and fails the test."""
    try:
        rec = fmt.decode(raw)
    except DecodeError:
        return
    assert rec is not None


@pytest.mark.parametrize("name", NAMES)
@FUZZ
@given(st.binary(max_size=2048))
def test_codec_garbage_raises_only_decode_error(name: str, data: bytes) -> None:
    decode_or_decode_error(formats.get(name), data)


@pytest.mark.parametrize("name", NAMES)
@FUZZ
@given(st.data())
def test_codec_damaged_real_frames_raise_only_decode_error(name: str, data: st.DataObject) -> None:
    fmt = formats.get(name)
    frames = stream_frames(name)
    raw = bytearray(data.draw(st.sampled_from(frames), label="frame"))
    kind = data.draw(st.sampled_from(["flip", "truncate", "extend", "splice"]), label="damage")
    if kind == "flip":
        for _ in range(data.draw(st.integers(1, 3))):
            bit = data.draw(st.integers(0, 8 * len(raw) - 1))
            raw[bit // 8] ^= 1 << (bit % 8)
    elif kind == "truncate":
        del raw[data.draw(st.integers(0, len(raw) - 1)) :]
    elif kind == "extend":
        raw += data.draw(st.binary(min_size=1, max_size=64))
    else:  # a real start, then random bytes (header fields that point anywhere)
        at = data.draw(st.integers(0, min(len(raw), 2048)))
        raw[at : at + 64] = data.draw(st.binary(min_size=64, max_size=64))
    decode_or_decode_error(fmt, bytes(raw))


# --- framer fuzz and chunking -------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
@FUZZ
@given(st.binary(max_size=3000), st.lists(st.integers(0, 3000), max_size=20))
def test_framer_random_bytes_never_raise(name: str, data: bytes, cuts: list[int]) -> None:
    entry_of(name)
    out, stats = feed_in_chunks(formats.get(name), data, [c for c in cuts if c <= len(data)])
    assert sum(map(len, out)) + stats["dropped_bytes"] == len(data) == stats["bytes_in"]
    assert stats["frames"] == len(out)


@st.composite
def noisy_stream(draw: st.DrawFn, name: str) -> tuple[bytes, list[bytes]]:
    """Golden frames with random gaps, decoys and damaged frames between them; returns the intact ones."""
    e = entry_of(name)
    frames = stream_frames(name)
    picks = draw(st.lists(st.integers(0, len(frames) - 1), max_size=6), label="frames")
    gap = st.binary(max_size=40).filter(lambda b: not any(x in b for x in e.gap_excludes))
    parts: list[bytes] = []
    intact: list[bytes] = []
    for k in picks:
        parts.append(draw(st.one_of(gap, st.sampled_from(e.decoys)), label="gap"))
        raw = frames[k]
        if draw(st.integers(0, 4), label="damage?") == 0:
            bit = draw(st.integers(0, 8 * len(raw) - 1), label="bit")
            damaged = bytearray(raw)
            damaged[bit // 8] ^= 1 << (bit % 8)
            parts.append(bytes(damaged))
        else:
            parts.append(raw)
            intact.append(raw)
    parts.append(draw(gap, label="tail"))
    return b"".join(parts), intact


@pytest.mark.parametrize("name", NAMES)
@FUZZ
@given(st.data())
def test_framer_keeps_every_undamaged_frame(name: str, data: st.DataObject) -> None:
    fmt = formats.get(name)
    stream, intact = data.draw(noisy_stream(name), label="stream")
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=25), label="cuts")
    out, stats = feed_in_chunks(fmt, stream, cuts)
    assert is_subsequence(intact, out), f"{name}: an undamaged frame was lost"
    assert sum(map(len, out)) + stats["dropped_bytes"] == len(stream)
    bulk, bulk_stats = feed_in_chunks(fmt, stream, [])
    assert out == bulk and stats == bulk_stats, f"{name}: the chunking changed the frames or the counters"


@pytest.mark.parametrize("name", NAMES)
@FUZZ
@given(st.data())
def test_framer_bit_flip_loses_only_the_damaged_frame(name: str, data: st.DataObject) -> None:
    if not entry_of(name).checksum:
        pytest.skip(f"{name} frames carry no checksum: a damaged frame may pass as a frame")
    frames = stream_frames(name)
    stream = bytearray(b"".join(frames))
    bit = data.draw(st.integers(0, 8 * len(stream) - 1), label="bit")
    stream[bit // 8] ^= 1 << (bit % 8)
    ends = list(itertools.accumulate(map(len, frames)))
    damaged = bisect.bisect_right(ends, bit // 8)
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=10), label="cuts")
    out, stats = feed_in_chunks(formats.get(name), bytes(stream), cuts)
    assert out == frames[:damaged] + frames[damaged + 1 :], f"{name}: bit {bit} (frame {damaged})"
    assert stats["bad_checksums"] + stats["dropped_bytes"] > 0


@pytest.mark.parametrize("name", NAMES)
@FUZZ
@given(st.data())
def test_framer_any_split_of_a_golden_stream_gives_the_same_frames(name: str, data: st.DataObject) -> None:
    fmt = formats.get(name)
    g = entry_of(name).goldens[0]
    stream, frames, stats = cut(name, g)
    stream = stream[: 200_000]  # a prefix: the same property, a bounded cost for the 1 MB captures
    expected, expected_stats = feed_in_chunks(fmt, stream, [])
    if len(stream) == len(cut(name, g)[0]):
        assert tuple(expected) == frames and expected_stats == stats
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=40), label="cuts")
    got, got_stats = feed_in_chunks(fmt, stream, cuts)
    assert got == expected and got_stats == expected_stats


@pytest.mark.parametrize("name", NAMES)
def test_framer_small_feeds_give_the_frames(name: str) -> None:
    fmt = formats.get(name)
    frames = stream_frames(name)[:3]
    stream = b"".join(frames)
    step = max(1, len(stream) // 4000)  # one byte at a time, or 4000 feeds of a sonar frame stream
    got, stats = feed_in_chunks(fmt, stream, range(step, len(stream), step))
    assert got == frames and stats["dropped_bytes"] == 0 and stats["frames"] == len(frames)
