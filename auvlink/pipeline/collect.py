"""Sort decoded samples by what they measure, into the arrays navigation and recon take.

Times are host receive times (one clock for every device) in seconds relative to the mission's
first sample (``t0_ns``), so float64 keeps sub-microsecond resolution over long missions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from auvlink.records import Sample

F64 = NDArray[np.float64]


@dataclass
class SonarFrames:
    """Sonar frames of one device: times (s), images (F, bins, beams) uint8, window per frame."""

    times: list[float] = field(default_factory=list)
    images: list[NDArray[np.uint8]] = field(default_factory=list)
    window: tuple[float, float] | None = None  # (start, length) m of the first frame
    azimuths: NDArray[np.float64] | None = None

    def stack(self) -> tuple[F64, NDArray[np.uint8]]:
        if not self.times:
            return np.zeros(0), np.zeros((0, 512, 96), np.uint8)
        return np.asarray(self.times), np.stack(self.images)


@dataclass
class MissionData:
    """Everything the batch pipeline needs, accumulated sample by sample."""

    t0_ns: int | None = None
    dvl_t: list[float] = field(default_factory=list)
    dvl_v: list[Any] = field(default_factory=list)
    dvl_frame: str = "instrument"
    dvl_alt: list[float] = field(default_factory=list)
    dvl_att: list[tuple[float, float, float]] = field(default_factory=list)
    gyro_t: list[float] = field(default_factory=list)
    gyro_v: list[Any] = field(default_factory=list)
    gyro_kind: str = "rate"
    depth_t: list[float] = field(default_factory=list)
    depth_p: list[float] = field(default_factory=list)
    sonar: SonarFrames = field(default_factory=SonarFrames)
    counts: dict[str, int] = field(default_factory=dict)
    _keller_request: dict[int, Any] = field(default_factory=dict)

    def rel(self, t_host_ns: int) -> float:
        if self.t0_ns is None:
            self.t0_ns = t_host_ns
        return (t_host_ns - self.t0_ns) * 1e-9

    def add(self, s: Sample) -> None:
        """Route one decoded sample by its wire format."""
        self.counts[s.device] = self.counts.get(s.device, 0) + 1
        t = self.rel(s.t_host_ns)
        fmt, r = s.format, s.record
        if fmt == "pd0":
            self._pd0(t, r)
        elif fmt == "dsp1760":
            self.gyro_t.append(t)
            self.gyro_v.append(r.gyro)
            self.gyro_kind = "delta" if r.mode == "delta" else "rate"
        elif fmt in ("dsp3000", "dsp3000_incremental"):
            self.gyro_t.append(t)
            self.gyro_v.append((0.0, 0.0, r.value if r.valid else np.nan))
            self.gyro_kind = "delta" if r.mode == "incremental" else "rate"
        elif fmt == "paro":
            p = getattr(r, "pressure_pa", None)
            if p is not None and np.isfinite(p):
                self.depth_t.append(t)
                self.depth_p.append(float(p))
        elif fmt == "keller":
            self._keller(t, r)
        elif fmt in ("didson", "aris"):
            self.sonar.times.append(t)
            self.sonar.images.append(np.asarray(r.image))
            if self.sonar.window is None:
                self.sonar.window = (float(r.window_start_m), float(r.window_length_m))
                self.sonar.azimuths = np.asarray(r.azimuths_rad, dtype=np.float64)

    def _pd0(self, t: float, r: Any) -> None:
        bt = r.bottom_track
        if bt is None:
            return
        v = np.asarray(r.bt_velocity_mps, dtype=np.float64)[:3]
        ranges = np.asarray(r.bt_range_m, dtype=np.float64)
        self.dvl_t.append(t)
        self.dvl_v.append(v)
        self.dvl_frame = r.coordinate_system
        ok = np.isfinite(ranges)
        self.dvl_alt.append(float(ranges[ok].mean()) if ok.sum() >= 3 else np.nan)
        self.dvl_att.append((r.heading_rad, r.pitch_rad, r.roll_rad))

    def _keller(self, t: float, r: Any) -> None:
        from auvlink.codecs import keller

        if isinstance(r, keller.KellerReadRequest):
            self._keller_request[r.address] = r
        elif isinstance(r, keller.KellerReadResponse):
            req = self._keller_request.pop(r.address, None)
            if req is None:
                return
            reading = keller.pair(req, r)
            p = reading.pressure_pa
            if p is not None and np.isfinite(p):
                self.depth_t.append(t)
                self.depth_p.append(float(p))

    def nav_inputs(self) -> tuple[Any, Any, Any]:
        """(DvlSamples, GyroSamples, DepthSamples) for :func:`recon.nav.dead_reckon`."""
        from recon.nav import DepthSamples, DvlSamples, GyroSamples

        att = np.asarray(self.dvl_att, dtype=np.float64).reshape(-1, 3)
        vel = np.asarray(self.dvl_v, dtype=np.float64).reshape(-1, 3)
        dvl = DvlSamples(t=np.asarray(self.dvl_t), velocity=vel, frame=self.dvl_frame,  # type: ignore[arg-type]
                         valid=np.all(np.isfinite(vel), axis=1), altitude=np.asarray(self.dvl_alt),
                         heading=att[:, 0], pitch=att[:, 1], roll=att[:, 2])
        gyro = GyroSamples(t=np.asarray(self.gyro_t), value=np.asarray(self.gyro_v, dtype=np.float64),
                           kind=self.gyro_kind)  # type: ignore[arg-type]
        depth = DepthSamples(t=np.asarray(self.depth_t), pressure_pa=np.asarray(self.depth_p))
        return dvl, gyro, depth
