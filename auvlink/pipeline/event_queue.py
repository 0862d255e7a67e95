"""The engine's input: decoded samples routed to events and released in time order below a watermark.

:meth:`EventQueue.put` routes a sample (:class:`~auvlink.pipeline.nav_inputs.NavAdaptor`; samples no stage
consumes are dropped) and buffers its event; the first event's receive time is mission time 0 unless the run gave
one. :meth:`EventQueue.release` hands over every event older than a watermark (live: every driver has handed over
everything it received before it; replay: the time of the sample being read), sorted by ``(receive time,
arrival)``, so what the engine computes depends on the samples alone, never on how they were grouped.
"""

from __future__ import annotations

from auvlink.pipeline.nav_inputs import Event, NavAdaptor
from auvlink.records import Sample


class EventQueue:
    """Buffered events of one run; ``t0_ns`` (ns since the epoch) is mission time 0."""

    def __init__(self, t0_ns: int | None = None) -> None:
        self.t0_ns = t0_ns
        self.adaptor = NavAdaptor()
        self._buf: list[Event] = []

    def put(self, sample: Sample) -> None:
        """Route ``sample`` and buffer its event (none when no stage consumes it)."""
        ev = self.adaptor.route(sample)
        if ev is not None:
            if self.t0_ns is None:
                self.t0_ns = ev.t_ns
            self._buf.append(ev)

    def __bool__(self) -> bool:
        return bool(self._buf)

    def release(self, watermark_ns: int | None) -> list[Event]:
        """The buffered events received before ``watermark_ns`` (all with None), in ``(t_ns, seq)`` order."""
        if watermark_ns is None:
            out, self._buf = self._buf, []
        else:
            out = [e for e in self._buf if e.t_ns < watermark_ns]
            if len(out) != len(self._buf):
                self._buf = [e for e in self._buf if e.t_ns >= watermark_ns]
            else:
                self._buf = []
        out.sort(key=lambda e: (e.t_ns, e.seq))
        return out

    def seconds(self, t_ns: int) -> float:
        """Mission time (s) of a receive time ``t_ns`` (ns since the epoch)."""
        return (t_ns - (self.t0_ns or 0)) * 1e-9
