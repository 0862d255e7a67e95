"""A mission's deadline, checked by the mission itself at safe points (cooperative cancellation).

:func:`deadline` sets, for the block it wraps and the thread running it, the monotonic time after which
:func:`check` raises :class:`MissionTimeout`; the replay loop (:func:`auvlink.pipeline.process.run_log`) calls
:func:`check` at every engine advance (each 0.1-1 s of mission time), between two frame blocks, where no
import, thread start or file write is under way. Deadlines nest (the earliest one holds); a thread without
one never raises.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager


class MissionTimeout(BaseException):
    """A mission ran past its ``--mission-timeout``. A BaseException (as KeyboardInterrupt): the pipeline's
    handlers of a bad frame (``except Exception``) must not take it for one and go on."""


_local = threading.local()


def _current() -> float:
    return float(getattr(_local, "deadline", float("inf")))


@contextmanager
def deadline(seconds: float) -> Iterator[None]:
    """:func:`check` raises in this thread once ``seconds`` have passed in the block (the earliest of nested
    deadlines holds); the thread's earlier deadline is back afterwards."""
    before = _current()
    _local.deadline = min(before, time.monotonic() + float(seconds))
    try:
        yield
    finally:
        _local.deadline = before


def check() -> None:
    """Raise :class:`MissionTimeout` when this thread's deadline has passed (a no-op without one)."""
    if time.monotonic() > _current():
        raise MissionTimeout
