"""Per-stage timing of the streaming pipeline: every duration kept (bounded), p50 / p99 / max reported."""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

MAX_SAMPLES = 500_000  # per stage; beyond this every other new value is kept (percentiles stay fair)


class StageTimes:
    """Durations (s) per stage name; :meth:`summary` gives count, total, p50, p99 and max in ms."""

    def __init__(self) -> None:
        self._v: dict[str, list[float]] = defaultdict(list)
        self._n: dict[str, int] = defaultdict(int)
        self._total: dict[str, float] = defaultdict(float)

    def add(self, stage: str, seconds: float, count: int = 1) -> None:
        """One duration; ``count`` > 1 records the same per-item duration for ``count`` items."""
        self._n[stage] += count
        self._total[stage] += seconds * count
        vals = self._v[stage]
        if len(vals) < MAX_SAMPLES:
            vals.extend([seconds] * min(count, MAX_SAMPLES - len(vals)))

    def total(self, stage: str) -> float:
        return self._total.get(stage, 0.0)

    def summary(self) -> dict[str, dict[str, Any]]:
        out: dict[str, dict[str, Any]] = {}
        for stage, vals in self._v.items():
            a = np.asarray(vals) * 1e3
            out[stage] = {"count": self._n[stage], "total_s": round(self._total[stage], 4),
                          "p50_ms": round(float(np.percentile(a, 50)), 3) if a.size else None,
                          "p99_ms": round(float(np.percentile(a, 99)), 3) if a.size else None,
                          "max_ms": round(float(a.max()), 3) if a.size else None}
        return out
