"""Sort decoded samples by what they measure: navigation inputs and sonar frames, as small events.

An event is ``(t_ns, seq, kind, payload)``; ``kind`` is ``dvl``, ``gyro``, ``depth``, ``gnss`` (a GGA fix,
:class:`auvlink.pipeline.georef.GnssPayload`) or ``sonar``.
Samples of other formats (the CAN navigation bus, Keller requests) give no event. The order key
``(t_ns, seq)`` is the host receive time then the arrival order, so a log replays in the order the
live run saw.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from auvlink.records import Sample


class Event(NamedTuple):
    t_ns: int
    seq: int
    kind: str
    payload: Any


class DvlPayload(NamedTuple):
    velocity: tuple[float, float, float]
    valid: bool
    altitude: float
    heading: float
    pitch: float
    roll: float
    frame: str


class SonarPayload(NamedTuple):
    device: str
    image: NDArray[np.uint8]
    window: tuple[float, float]
    azimuths: NDArray[np.float64]


class Router:
    """Turns samples into events; pairs Keller read requests with their responses."""

    def __init__(self) -> None:
        self.seq = 0
        self.gyro_kind = "rate"
        self.counts: dict[str, int] = {}
        self._keller_request: dict[int, Any] = {}
        self._gga_devices: set[str] = set()

    def route(self, s: Sample) -> Event | None:
        self.counts[s.device] = self.counts.get(s.device, 0) + 1
        payload = self._payload(s.format, s.record, s.device)
        if payload is None:
            return None
        self.seq += 1
        return Event(s.t_host_ns, self.seq, payload[0], payload[1])

    def _payload(self, fmt: str, r: Any, device: str) -> tuple[str, Any] | None:
        if fmt == "pd0":
            if r.bottom_track is None:
                return None
            v = np.asarray(r.bt_velocity_mps, dtype=np.float64)[:3]
            ranges = np.asarray(r.bt_range_m, dtype=np.float64)
            ok = np.isfinite(ranges)
            alt = float(ranges[ok].mean()) if ok.sum() >= 3 else np.nan
            return "dvl", DvlPayload((float(v[0]), float(v[1]), float(v[2])), bool(np.all(np.isfinite(v))), alt,
                                     r.heading_rad, r.pitch_rad, r.roll_rad, r.coordinate_system)
        if fmt == "dsp1760":
            self.gyro_kind = "delta" if r.mode == "delta" else "rate"
            return "gyro", tuple(float(x) for x in r.gyro)
        if fmt in ("dsp3000", "dsp3000_incremental"):
            self.gyro_kind = "delta" if r.mode == "incremental" else "rate"
            return "gyro", (0.0, 0.0, float(r.value) if r.valid else np.nan)
        if fmt == "paro":
            p = getattr(r, "pressure_pa", None)
            return ("depth", float(p)) if p is not None and np.isfinite(p) else None
        if fmt == "keller":
            return self._keller(r)
        if fmt == "nmea":
            from auvlink.codecs.nmea import GgaFix
            from auvlink.pipeline.georef import gnss_payload

            if isinstance(r, GgaFix):
                self._gga_devices.add(device)
            fix = gnss_payload(r, device in self._gga_devices)
            return None if fix is None else ("gnss", fix)
        if fmt in ("didson", "aris"):
            return "sonar", SonarPayload(device, np.asarray(r.image),
                                         (float(r.window_start_m), float(r.window_length_m)),
                                         np.asarray(r.azimuths_rad, dtype=np.float64))
        return None

    def _keller(self, r: Any) -> tuple[str, Any] | None:
        from auvlink.codecs import keller

        if isinstance(r, keller.KellerReadRequest):
            self._keller_request[r.address] = r
        elif isinstance(r, keller.KellerReadResponse):
            req = self._keller_request.pop(r.address, None)
            if req is not None:
                p = keller.pair(req, r).pressure_pa
                if p is not None and np.isfinite(p):
                    return "depth", float(p)
        return None
