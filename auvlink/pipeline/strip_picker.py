"""The sonar frames the report shows: one per object, picked from the frames seen lately.

Every frame the engine receives enters a ring of the last ``ring_frames``; when an object is reported, the frame
nearest :data:`STRIP_AFTER_FIRST_S` after its first highlight return is kept (at most ``strip_frames``), with the
vehicle's pose at that time, unless navigation did not cover it or it is kept already.
"""

from __future__ import annotations

from collections import deque

import numpy as np
import numpy.typing as npt

from auvlink.pipeline.results import StripFrame
from recon.nav_stream import CausalNavigator

#: s: the strip frame of an object is the one this long after its first highlight return: at the survey speed
#: (1.5 m/s) the vehicle has closed 1.2 m, so the object lies inside the range window, not on its far edge
STRIP_AFTER_FIRST_S = 0.8


class StripPicker:
    """The ring of recent frames (mission time s, image) and the frames kept (:attr:`frames`)."""

    def __init__(self, strip_frames: int = 6, ring_frames: int = 200) -> None:
        self.frames: list[StripFrame] = []
        self._ring: deque[tuple[float, npt.NDArray[np.uint8]]] = deque(maxlen=ring_frames)
        self._max = strip_frames

    def remember(self, t: float, image: npt.NDArray[np.uint8]) -> None:
        """A frame received at mission time ``t`` (s)."""
        self._ring.append((t, image))

    def pick(self, t_first: float, nav: CausalNavigator) -> None:
        """Keep the frame of an object whose first return came at ``t_first`` (s), posed by ``nav``."""
        if len(self.frames) >= self._max or not self._ring:
            return
        ts = np.array([t for t, _ in self._ring])
        i = int(np.argmin(np.abs(ts - (t_first + STRIP_AFTER_FIRST_S))))
        t, img = self._ring[i]
        if not nav.covered(t)[0] or any(s.t == t for s in self.frames):
            return
        pos, rot = nav.pose_at(t)
        self.frames.append(StripFrame(t, img, pos, rot, nav.altitude_at(t)))
