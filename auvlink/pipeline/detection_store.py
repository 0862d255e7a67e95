"""The detections of a run in the world frame W: new objects appended, later passes replacing them by id.

A detection is handed on located with the georeference's shift D -> W at its time (the start anchor, uncorrected);
:meth:`DetectionStore.finalize` moves every one to the corrected track at the end of the mission (the closure
error distributed, :meth:`auvlink.pipeline.georef.Georef.finalize`).
"""

from __future__ import annotations

import numpy as np

from auvlink.pipeline.georef import Georef
from auvlink.pipeline.results import Detection


class DetectionStore:
    """:attr:`detections` in the order first reported."""

    def __init__(self, georef: Georef) -> None:
        self.georef = georef
        self.detections: list[Detection] = []
        self._index: dict[int, int] = {}  # detection id -> its place in self.detections
        self._applied: dict[int, np.ndarray] = {}  # detection id -> the D -> W shift it was handed on with

    @property
    def reported(self) -> dict[int, int]:
        """Detection id -> place in :attr:`detections` (the ids reported so far)."""
        return self._index

    def put(self, det: Detection, shift: np.ndarray) -> bool:
        """Locate ``det`` in W with ``shift`` (D -> W, m) and add it (True), or replace the detection of its id
        (False)."""
        self._applied[det.id] = shift
        self.georef.locate(det, None)
        k = self._index.get(det.id)
        if k is None:  # a new object
            self._index[det.id] = len(self.detections)
            self.detections.append(det)
            return True
        self.detections[k] = det  # a later pass fused into it (recon.fusion): the update replaces it, same id
        return False

    def finalize(self, epoch_s: float) -> None:
        """End of the mission: every detection to the corrected track (mission time 0 at ``epoch_s``)."""
        self.georef.finalize(self.detections, self._applied, epoch_s)
