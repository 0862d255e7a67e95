"""A whole mission's samples, kept for the batch path: the navigation inputs and the sonar frames.

The samples go through the same :class:`~auvlink.pipeline.nav_inputs.NavAdaptor` as the streaming
engine's; times are host receive times in s relative to the mission's first event (``t0_ns``), as
in the engine, so float64 keeps sub-microsecond resolution over long missions.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from auvlink.pipeline.nav_inputs import Event, NavAdaptor, SonarPayload, depth_samples, dvl_samples, gyro_samples
from auvlink.records import Sample
from recon.nav import DepthSamples, DvlSamples, GyroSamples
from recon.sonar_geometry import DEFAULT_BEAMS, DEFAULT_BINS

F64 = NDArray[np.float64]


@dataclass
class SonarFrames:
    """Sonar frames of one device: times (s), images (F, bins, beams) uint8, window per frame."""

    times: list[float] = field(default_factory=list)
    images: list[NDArray[np.uint8]] = field(default_factory=list)
    window: tuple[float, float] | None = None  # (start, length) m of the first frame
    azimuths: NDArray[np.float64] | None = None

    def add(self, t: float, frame: SonarPayload) -> None:
        self.times.append(t)
        self.images.append(frame.image)
        if self.window is None:
            self.window, self.azimuths = frame.window, frame.azimuths

    def stack(self) -> tuple[F64, NDArray[np.uint8]]:
        if not self.times:
            return np.zeros(0), np.zeros((0, DEFAULT_BINS, DEFAULT_BEAMS), np.uint8)  # no frames: the default image
        return np.asarray(self.times), np.stack(self.images)


@dataclass
class MissionData:
    """Everything the batch pipeline needs, accumulated sample by sample (:meth:`add`)."""

    adaptor: NavAdaptor = field(default_factory=NavAdaptor)
    t0_ns: int | None = None  # host time of the first event
    nav: dict[str, list[Event]] = field(default_factory=lambda: {"dvl": [], "gyro": [], "depth": []})
    sonar: SonarFrames = field(default_factory=SonarFrames)

    @property
    def counts(self) -> dict[str, int]:
        """Samples seen per device."""
        return self.adaptor.counts

    def add(self, s: Sample) -> None:
        """Route one decoded sample through the adaptor."""
        ev = self.adaptor.route(s)
        if ev is None:
            return
        if self.t0_ns is None:
            self.t0_ns = ev.t_ns
        if ev.kind == "sonar":
            self.sonar.add((ev.t_ns - self.t0_ns) * 1e-9, ev.payload)
        else:
            self.nav[ev.kind].append(ev)

    def n(self, kind: str) -> int:
        """Navigation samples of ``kind`` (``dvl``, ``gyro``, ``depth``)."""
        return len(self.nav[kind])

    def nav_inputs(self) -> tuple[DvlSamples, GyroSamples, DepthSamples]:
        """(DvlSamples, GyroSamples, DepthSamples) for :func:`recon.nav.dead_reckon` (empty arrays for a
        kind without samples)."""
        t0 = self.t0_ns or 0
        return (dvl_samples(self.nav["dvl"], t0), gyro_samples(self.nav["gyro"], t0, self.adaptor.gyro_kind),
                depth_samples(self.nav["depth"], t0))
