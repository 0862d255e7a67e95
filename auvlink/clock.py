"""One monotonic host clock per process, mapped to UTC once.

``now_ns()`` is ``time.monotonic_ns()`` shifted so that it reads UTC nanoseconds since the UNIX
epoch at the moment the process first asked: it never jumps with NTP, yet logs show wall time.
"""

from __future__ import annotations

import os
import time

_OFFSET_NS = time.time_ns() - time.monotonic_ns()


def now_ns() -> int:
    """Host receive time: monotonic, in UTC nanoseconds since the epoch."""
    return time.monotonic_ns() + _OFFSET_NS


def process_age_s() -> float | None:
    """Seconds since this process started (the kernel's start time, ``/proc/self/stat`` field 22, in clock ticks
    since boot, against ``CLOCK_BOOTTIME``: 10 ms resolution at the usual 100 ticks/s); None where there is no
    ``/proc`` (not Linux)."""
    try:
        with open("/proc/self/stat", encoding="ascii") as f:
            stat = f.read()
        ticks = int(stat.rsplit(")", 1)[1].split()[19])  # fields after "comm)": state is field 3, starttime 22
        return time.clock_gettime(time.CLOCK_BOOTTIME) - ticks / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, AttributeError):
        return None
