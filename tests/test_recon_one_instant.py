"""A cluster seen at one instant (one ping, or a burst of pings a stalled link stamped on arrival) is no object."""

from __future__ import annotations

import numpy as np

from recon.cluster import make_object
from recon.object_stage import ONE_INSTANT_S, persistent


def test_clusters_seen_at_one_instant_are_counted_and_dropped() -> None:
    rng = np.random.default_rng(0)
    pts = rng.normal(0.0, 0.3, (200, 3))
    burst = make_object(0, pts, 100.0 + rng.uniform(0.0, 0.0015, 200))  # a burst's frames within 1.5 ms
    ping = make_object(1, pts, np.full(200, 100.0))  # one ping
    seen = make_object(2, pts, np.repeat(100.0 + np.arange(20) / 10.0, 10))  # 20 pings at 10 Hz
    fast = make_object(3, pts, np.repeat([100.0, 100.0 + ONE_INSTANT_S], 100))  # two pings at the fastest rate
    rejected = {"too_wide": 0}
    assert [o.id for o in persistent(rejected, [burst, ping, seen, fast])] == [2, 3]
    assert rejected == {"too_wide": 0, "one_instant": 2}
    assert persistent(rejected, []) == [] and rejected["one_instant"] == 2
