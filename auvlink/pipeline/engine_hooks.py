"""What a runner of the engine (:class:`auvlink.pipeline.engine.Engine`) is told as it goes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from auvlink.pipeline.results import Detection
from recon.sonar_geometry import SonarGeometry

#: ``on_frames(geometry, times, images, returns)``: frames just reconstructed (mission times s, (F, bins,
#: beams) uint8) and their highlight returns ((frame, beam, row) arrays, :attr:`Reconstructor.last_returns`)
FramesObserver = Callable[[SonarGeometry, npt.NDArray[np.float64], npt.NDArray[np.uint8],
                           tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]], None]


@dataclass(frozen=True)
class EngineHooks:
    """What a runner learns as the engine goes: ``on_detection`` each detection reported (new or updated),
    ``on_frames`` each group of frames reconstructed; ``clock`` (ns, the drivers' clock) enables end-to-end frame
    latency (live)."""

    on_detection: Callable[[Detection], None] | None = None
    on_frames: FramesObserver | None = None
    clock: Callable[[], int] | None = None
