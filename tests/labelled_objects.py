"""Objects for the engine's classification tests: box-like clouds as recon reports them, and a loaded labeller."""

from __future__ import annotations

import numpy as np

from auvlink.pipeline.object_labels import ObjectLabeller
from recon.cluster import DetectedObject

SEABED_DEPTH_M = 20.0  # NED z of the seabed under every object


def box_object(oid: int, n: int, lo: tuple[float, float, float], hi: tuple[float, float, float], seed: int = 0,
               step_m: float = 10.0) -> DetectedObject:
    """Object ``oid``: ``n`` points uniform in the box ``lo``-``hi`` (NED m), moved ``step_m * oid`` north."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(lo, hi, size=(n, 3)) + [step_m * oid, 0.0, 0.0]
    return DetectedObject(id=oid, centroid=pts.mean(axis=0), extent=np.ptp(pts, axis=0), points=pts, n_points=n,
                          t_first=0.0, t_last=1.0, seabed_depth=SEABED_DEPTH_M)


def loaded_labeller() -> ObjectLabeller:
    """The engine's labeller with the shipped model loaded."""
    lab = ObjectLabeller(True, None)
    lab.load()
    return lab
