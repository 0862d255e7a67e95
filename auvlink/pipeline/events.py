"""Port events folded into counts: what ``summary.json`` lists stays small whatever a device does.

An event (``{"t_ns", "device", "kind", ...detail}``) folds into the latest entry of the same device and kind
when the rest of it is the same: the same text fields, whatever the measurements (:data:`MEASURED`: gap and
silence lengths, frame times and ordinals) and the peer's address (a client reconnecting comes from a new
port each time). The entry keeps its first event's fields and gains ``count``, ``last_t_ns`` and ``last``
(the measurements of the latest). At most :data:`MAX_ENTRIES` entries are kept; an event that would make
another is counted in :attr:`EventFolder.dropped` and listed as one closing ``events_dropped`` entry.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from typing import Any

#: entries kept in summary.json: two per kind (lost / reopened, silent / resumed, ...) for a vehicle's
#: 64 devices (auvlink.config's cap) are 128 only when every device fails in every way at once; 200 holds that
MAX_ENTRIES = 200
#: detail that varies from one occurrence to the next without making it another event
MEASURED = frozenset({"t_ns", "gap_s", "silent_s", "frame_t_ns", "sample_index", "peer"})
#: an entry's own fields (not compared)
FOLDED = frozenset({"count", "last_t_ns", "last"})
#: the log's events channel gets every occurrence up to this many of one entry, then the powers of two
LOG_EVERY_UP_TO = 10


def _identity(ev: dict[str, Any]) -> tuple[tuple[str, str], ...]:
    return tuple(sorted((k, repr(v)) for k, v in ev.items() if k not in MEASURED and k not in FOLDED))


class EventFolder:
    """Port events folded into counted entries (see the module docstring); thread-safe."""

    def __init__(self, max_entries: int = MAX_ENTRIES) -> None:
        self.max_entries = max_entries
        self.entries: list[dict[str, Any]] = []
        self.dropped = 0
        self._first_dropped_ns: int | None = None
        self._last_dropped_ns: int | None = None
        self._latest: dict[tuple[str, str], int] = {}  # (device, kind) -> index of its latest entry
        self._lock = threading.Lock()

    def add(self, ev: dict[str, Any]) -> int:
        """Fold ``ev`` in; returns the count of the entry it went to (1: a new entry, 0: dropped)."""
        where = (str(ev.get("device", "")), str(ev.get("kind", "")))
        t_ns = int(ev.get("t_ns", 0))
        with self._lock:
            i = self._latest.get(where)
            if i is not None and _identity(self.entries[i]) == _identity(ev):
                entry = self.entries[i]
                entry["count"] += 1
                entry["last_t_ns"] = t_ns
                entry["last"] = {k: v for k, v in ev.items() if k in MEASURED and k != "t_ns"}
                return int(entry["count"])
            if len(self.entries) >= self.max_entries:
                self.dropped += 1
                self._first_dropped_ns = self._first_dropped_ns if self._first_dropped_ns is not None else t_ns
                self._last_dropped_ns = t_ns
                return 0
            self._latest[where] = len(self.entries)
            self.entries.append({**ev, "count": 1, "last_t_ns": t_ns})
            return 1

    def to_list(self) -> list[dict[str, Any]]:
        """The entries (copies), and an ``events_dropped`` entry closing them when some were dropped."""
        with self._lock:
            out = [dict(e) for e in self.entries]
            if self.dropped:
                out.append({"t_ns": self._first_dropped_ns, "device": "", "kind": "events_dropped",
                            "count": self.dropped, "last_t_ns": self._last_dropped_ns,
                            "dropped": self.dropped})
        return out

    @staticmethod
    def logs(ev: dict[str, Any], count: int) -> bool:
        """Whether the log's events channel gets this occurrence: every frame drop (replay skips exactly
        those frames), the first :data:`LOG_EVERY_UP_TO` of an entry, then its powers of two."""
        if ev.get("kind") == "frame_dropped":
            return True
        return 0 < count <= LOG_EVERY_UP_TO or (count > 0 and (count & (count - 1)) == 0)

    def __iter__(self) -> Iterator[dict[str, Any]]:
        return iter(self.to_list())

    def __len__(self) -> int:
        return len(self.entries) + bool(self.dropped)
