"""Helpers shared by the framer tests: feed a stream in given chunks, check frames were kept in order."""

from __future__ import annotations

from auvlink.framing.base import Framer


def run(framer: Framer, stream: bytes, cuts: list[int]) -> list[bytes]:
    """Feed ``stream`` in chunks of the sizes in ``cuts`` (then the rest), flush, return every frame."""
    out: list[bytes] = []
    pos = 0
    for c in cuts:
        out += framer.feed(stream[pos : pos + c])
        pos += c
    out += framer.feed(stream[pos:])
    out += framer.flush()
    return out


def is_subsequence(expected: list[bytes], got: list[bytes]) -> bool:
    """True when every frame of ``expected`` appears in ``got``, in the same order."""
    it = iter(got)
    return all(any(x == y for y in it) for x in expected)
