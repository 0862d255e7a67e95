"""Every framer is linear in its input and keeps a bounded buffer, on garbage and its worst pattern.

Not a timed test: the check is the *ratio* of CPU times (``time.process_time``, best of 3) for an
input and one 4 times longer, which a linear framer keeps near 4 and a quadratic one near 16
(the PD6 framer took 40 s for 256 KB of ':' before). The buffer check feeds the stream as a TCP
port would (4 KiB reads) and asserts that no more than the format's largest frame stays buffered.
"""

from __future__ import annotations

import time

import pytest

from auvlink import formats
from auvlink.framing.base import FEED_SLICE
from auvlink.framing.hostile import WORST_PATTERNS, garbage, pattern_stream

CASES = [(fmt, what, pattern) for fmt, pats in WORST_PATTERNS.items() for what, pattern in pats]
SIZE = 64 * 1024  # the short input; the long one is 4x. Both are fed whole (one feed, one slice).


def _cpu_time(fmt: str, data: bytes) -> float:
    best = float("inf")
    for _ in range(3):
        framer = formats.get(fmt).framer()
        t0 = time.process_time()
        framer.feed(data)
        framer.flush()
        best = min(best, time.process_time() - t0)
    return max(best, 1e-4)


@pytest.mark.slow
@pytest.mark.parametrize(("fmt", "what", "pattern"), CASES, ids=[f"{f}-{w}" for f, w, _ in CASES])
def test_worst_pattern_is_linear(fmt: str, what: str, pattern: bytes) -> None:
    assert 4 * SIZE <= FEED_SLICE
    short = _cpu_time(fmt, pattern_stream(pattern, SIZE))
    long = _cpu_time(fmt, pattern_stream(pattern, 4 * SIZE))
    assert long < 8 * short + 0.05, f"{fmt} on {what}: 4x the input took {long / short:.1f}x the time"


@pytest.mark.parametrize("fmt", sorted(WORST_PATTERNS))
def test_buffer_stays_bounded(fmt: str) -> None:
    framer = formats.get(fmt).framer()
    streams = [garbage(64 * 1024)] + [pattern_stream(p, 64 * 1024) for _, p in WORST_PATTERNS[fmt]]
    for data in streams:
        for k in range(0, len(data), 4096):
            framer.feed(data[k : k + 4096])
            assert framer.buffered <= framer.max_frame, f"{fmt}: {framer.buffered} bytes buffered"
    framer.flush()
    assert framer.buffered == 0
    st = framer.stats
    assert st.bytes_in == sum(map(len, streams))
    assert st.dropped_bytes > 0 and st.frames == 0  # nothing here is a frame, and every byte is accounted


def test_a_huge_feed_is_framed_in_slices() -> None:
    """One 3 MiB feed of ':' never holds more than one slice plus a line in the PD6 framer."""
    framer = formats.get("pd6").framer()
    seen: list[int] = []
    extract = framer._extract

    def spy(buf: bytearray, final: bool = False) -> list[bytes]:
        seen.append(len(buf))
        return extract(buf, final)

    framer._extract = spy  # type: ignore[method-assign]
    assert framer.feed(b":" * (3 * FEED_SLICE)) == []
    assert max(seen) <= FEED_SLICE + framer.max_frame and len(seen) == 3
    assert framer.stats.dropped_bytes == 3 * FEED_SLICE - framer.buffered


def _ensemble(nbytes: int, seed: int) -> bytes:
    """A PD0 ensemble of ``nbytes`` + 2 bytes: one data type at offset 8, random payload, a valid sum."""
    body = bytearray(garbage(nbytes, seed))
    body[0:8] = b"\x7f\x7f" + nbytes.to_bytes(2, "little") + b"\x00\x01\x08\x00"
    return bytes(body) + (sum(body) & 0xFFFF).to_bytes(2, "little")


@pytest.mark.slow
@pytest.mark.parametrize("chunk", [1, 777, 4096, 1 << 16])
def test_pd0_long_ensembles_checked_by_prefix_sums(chunk: int) -> None:
    """Ensembles longer than the numpy threshold are summed from the running prefix: same answers."""
    good = [_ensemble(n, n) for n in (3000, 40000, 65000, 2100)]
    bad = bytearray(_ensemble(20000, 1))
    bad[5000] ^= 0xFF
    stream = b"junk" + b"\x7f" * 37 + good[0] + bytes(bad) + good[1] + b"\x7f\x7f" + good[2] + b"\x7f" * 9 + good[3]
    framer = formats.get("pd0").framer()
    got: list[bytes] = []
    for _ in range(2):  # twice: the prefix must start afresh after a flush
        for k in range(0, len(stream), chunk):
            got += framer.feed(stream[k : k + chunk])
            assert framer.buffered <= framer.max_frame
        got += framer.flush()
    assert got == good + good
    assert framer.stats.bad_checksums == 2


def test_decode_keeps_a_bounded_list_of_problems() -> None:
    """20 MB of undecodable CAN frames held 1.25 M problem strings (260 MB); now MAX_PROBLEMS, the rest counted."""
    from auvlink.decode_file import MAX_PROBLEMS, decode_bytes
    from auvlink.framing.can_frames import CanFrame, pack_frame

    n = MAX_PROBLEMS + 1500
    raw = pack_frame(CanFrame(0x123, b"\x01"))  # a valid raw frame whose id the navigation DBC does not know
    res = decode_bytes(raw * n, formats.get("can"), lambda r: None)
    assert res.decode_errors == n and len(res.problems) == MAX_PROBLEMS
    assert res.problems_left_out == n - MAX_PROBLEMS and res.summary()["problems"] == n
    assert res.problems[0].startswith("frame 0:") and res.problems[-1].startswith(f"frame {n - 1}:")
