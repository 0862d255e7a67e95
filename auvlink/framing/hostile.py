"""Hostile inputs for every framer: random garbage and each format's worst-case byte pattern.

A worst-case pattern makes a framer examine as many candidate frames as possible (a sync byte or
start character at every position, headers that pass the cheap checks and fail the expensive ones,
no line end). A linear framer takes time proportional to the input on each of them and keeps at
most :attr:`~auvlink.framing.base.Framer.max_frame` bytes buffered. Used by the framer bound tests
(``tests/test_framer_bounds.py``) and by ``auvlink bench decode``.
"""

from __future__ import annotations

import numpy as np

from auvlink.framing.aris_defs import (
    FRAME_HEADER_SIZE,
    MAX_SAMPLES_PER_BEAM,
    OFF_PING_MODE,
    OFF_SAMPLES_PER_BEAM,
    OFF_SIGNATURE,
    PING_MODE_BEAMS,
    SIGNATURE,
)


def _sonar_header(beams: int) -> bytes:
    """A 1024-byte ARIS frame header that is sane and claims the largest frame of ``beams`` beams."""
    head = bytearray(FRAME_HEADER_SIZE)
    head[OFF_SIGNATURE : OFF_SIGNATURE + 4] = SIGNATURE
    mode = min(m for m, b in PING_MODE_BEAMS.items() if b == beams)
    head[OFF_PING_MODE : OFF_PING_MODE + 4] = mode.to_bytes(4, "little")
    head[OFF_SAMPLES_PER_BEAM : OFF_SAMPLES_PER_BEAM + 4] = MAX_SAMPLES_PER_BEAM.to_bytes(4, "little")
    return bytes(head)


#: format -> (what, pattern): the pattern repeated is the hostile stream
WORST_PATTERNS: dict[str, list[tuple[str, bytes]]] = {
    "pd6": [("':' with no line end", b":"), ("':' CR, no LF", b":\r")],
    "dsp3000": [("digits, no line end", b"0"), ("empty lines", b"\r\n")],
    "paro": [("'*' with no line end", b"*"), ("'*0' lines", b"*0\r\n")],
    "pd0": [("0x7F7F", b"\x7f"), ("0x7F runs of 10, a zero", b"\x7f" * 10 + b"\x00"),
            ("plausible headers, 64 KiB claimed, bad sums", b"\x7f\x7f\xfe\xff\x00\x01\x08\x00")],
    "dsp1760": [("headers, bad CRC", b"\xfe\x81\xff\x55")],
    "keller": [("F48 address pairs", b"\x01\x30"), ("F73 address pairs", b"\x01\x49")],
    "can": [("markers A5 5A", b"\xa5\x5a"), ("zero frames, marker in the data", bytes(6) + b"\xa5\x5a")],
    "aris": [("signatures DDF_05", SIGNATURE), ("sane headers claiming 1 MiB", _sonar_header(128))],
    "didson": [("signatures DDF_05", SIGNATURE), ("sane headers claiming 768 KiB", _sonar_header(96))],
}


def pattern_stream(pattern: bytes, size: int) -> bytes:
    """``pattern`` repeated to exactly ``size`` bytes."""
    return (pattern * (size // len(pattern) + 1))[:size]


def garbage(size: int, seed: int = 0) -> bytes:
    """``size`` uniformly random bytes (seeded)."""
    return np.random.default_rng(seed).integers(0, 256, size, dtype=np.uint8).tobytes()


def hostile_streams(fmt: str, size: int) -> list[tuple[str, bytes]]:
    """Random garbage and every worst-case pattern of ``fmt``, each ``size`` bytes long."""
    return [("random garbage", garbage(size)),
            *((what, pattern_stream(p, size)) for what, p in WORST_PATTERNS.get(fmt, []))]
