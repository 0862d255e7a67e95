"""One monotonic host clock per process, mapped to UTC once.

``now_ns()`` is ``time.monotonic_ns()`` shifted so that it reads UTC nanoseconds since the UNIX
epoch at the moment the process first asked: it never jumps with NTP, yet logs show wall time.
"""

from __future__ import annotations

import time

_OFFSET_NS = time.time_ns() - time.monotonic_ns()


def now_ns() -> int:
    """Host receive time: monotonic, in UTC nanoseconds since the epoch."""
    return time.monotonic_ns() + _OFFSET_NS
