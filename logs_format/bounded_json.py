"""JSON from a log, parsed within limits: a size cap and a nesting-depth cap checked before ``json.loads``.

A mission log is outside input: its metadata values and JSON messages may be anything. ``json.loads``
recurses once per nesting level (a 200,000-deep array raises ``RecursionError``) and holds the whole
text, so :func:`loads_bounded` first refuses text longer than :data:`MAX_JSON_BYTES` and text nested
deeper than :data:`MAX_JSON_DEPTH` (measured by :func:`nesting_depth`, one vectorized scan of the
brackets outside strings), each with :class:`JsonLimitError` (a ``ValueError``) saying which limit.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np

#: the deepest JSON auvlink writes is 6 levels (vehicle_config.config.devices[i].mounting.xyz);
#: 64 leaves room for other writers and stays far below Python's recursion limit (1000)
MAX_JSON_DEPTH = 64
#: the largest value auvlink writes is a scene's objects: 10,000 objects (auvlink.sim.scene's cap) at
#: ~450 bytes each = 4.5 MB; 16 MiB keeps that with margin and bounds what one value can cost to parse
MAX_JSON_BYTES = 16 << 20
WINDOW = 1 << 20  # bytes scanned per step by nesting_depth

_QUOTE, _BACKSLASH = ord('"'), ord("\\")
_OPENS = np.zeros(256, dtype=np.int8)
_OPENS[[ord("["), ord("{")]] = 1
_OPENS[[ord("]"), ord("}")]] = -1


class JsonLimitError(ValueError):
    """JSON text over :data:`MAX_JSON_BYTES` or nested deeper than :data:`MAX_JSON_DEPTH`."""


def nesting_depth(text: str | bytes) -> int:
    """The deepest nesting of ``[`` / ``{`` in JSON ``text``, brackets inside strings not counted.

    A quote preceded by an odd run of backslashes is escaped (it does not end the string). The text is
    scanned :data:`WINDOW` bytes at a time (memory stays small whatever the size)."""
    raw = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else bytes(text)
    if raw.count(b"[") + raw.count(b"{") == 0:
        return 0
    deepest, depth, inside, run = 0, 0, False, 0  # carried across windows: level, in a string, backslashes
    for start in range(0, len(raw), WINDOW):
        buf = np.frombuffer(raw, dtype=np.uint8, count=min(WINDOW, len(raw) - start), offset=start)
        idx = np.arange(buf.size, dtype=np.int64)
        backslash = buf == _BACKSLASH
        last_plain = np.maximum.accumulate(np.where(backslash, -1, idx))  # last non-backslash at or before i
        run_before = np.empty(buf.size, dtype=np.int64)  # backslashes right before position i
        run_before[0] = run
        run_before[1:] = np.where(last_plain[:-1] < 0, idx[:-1] + 1 + run, idx[:-1] - last_plain[:-1])
        quote = (buf == _QUOTE) & (run_before % 2 == 0)
        inside_at = (np.cumsum(quote) % 2 == 1) ^ inside  # in a string (a bracket is never a quote itself)
        levels = depth + np.cumsum(np.where(inside_at, 0, _OPENS[buf]).astype(np.int64))
        deepest = max(deepest, int(levels.max()))
        depth, inside = int(levels[-1]), bool(inside_at[-1])
        run = int(run_before[-1] + 1) if backslash[-1] else 0
    return deepest


def check_json_limits(text: str | bytes, *, max_depth: int = MAX_JSON_DEPTH, max_bytes: int = MAX_JSON_BYTES) -> None:
    """:class:`JsonLimitError` when ``text`` is longer than ``max_bytes`` or nested deeper than ``max_depth``."""
    size = len(text.encode("utf-8", "surrogatepass")) if isinstance(text, str) else len(text)
    if size > max_bytes:
        raise JsonLimitError(f"{size} bytes of JSON (limit {max_bytes})")
    depth = nesting_depth(text)
    if depth > max_depth:
        raise JsonLimitError(f"JSON nested {depth} levels deep (limit {max_depth})")


def loads_bounded(text: str | bytes, *, max_depth: int = MAX_JSON_DEPTH, max_bytes: int = MAX_JSON_BYTES) -> Any:
    """``json.loads(text)`` after :func:`check_json_limits`; a ``ValueError`` for text that is not JSON
    (``json.JSONDecodeError``, ``UnicodeDecodeError``) or over a limit (:class:`JsonLimitError`)."""
    check_json_limits(text, max_depth=max_depth, max_bytes=max_bytes)
    return json.loads(text)
