"""Feed a stream to a framer in given chunks (the format-specific framer tests; generic ones: test_conformance)."""

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


