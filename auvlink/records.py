"""Envelope around decoded records as drivers and the log hand them on.

Codecs are pure: ``decode(bytes) -> record`` knows nothing of time of arrival. A decoder
(:class:`auvlink.decoder.Decoder`, run by a live driver and by replay) wraps each frame into a
:class:`Sample` carrying the host receive time (``t_host_ns``, one monotonic clock per process, see
:mod:`auvlink.clock`), the sensor's own time when the format has one, the raw bytes exactly as
received, and the decoded record (SI units).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Sample:
    """One frame from one device."""

    device: str
    format: str
    t_host_ns: int
    raw: bytes
    record: Any
    t_sensor: float | None = None  # s since the UNIX epoch (UTC) when the format has a clock

    @property
    def t_host(self) -> float:
        """Host receive time in seconds (same clock as ``t_host_ns``)."""
        return self.t_host_ns * 1e-9
