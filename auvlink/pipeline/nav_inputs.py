"""The one adaptor from decoded samples to what navigation and reconstruction take (live, replay, batch).

:class:`NavAdaptor` turns each :class:`~auvlink.records.Sample` into a small :class:`Event`
``(t_ns, seq, kind, payload)``, ``kind`` one of ``dvl``, ``gyro``, ``depth`` or ``sonar``:

=====================================  ======  ==============================================================
wire format (record)                   kind    payload
=====================================  ======  ==============================================================
``pd0`` (RDI ensemble with bottom      dvl     :class:`DvlPayload`: bottom-track velocity (m/s, in the
track; others give no event)                   ensemble's coordinate system), valid, altitude = mean of the
                                               beam ranges (m; NaN with fewer than 3), heading/pitch/roll (rad)
``dsp1760``                            gyro    body rates (rad/s) or increments (rad), (3,)
``dsp3000``, ``dsp3000_incremental``   gyro    ``(0, 0, z)`` rate (rad/s) or increment (rad); NaN if invalid
``paro``                               depth   absolute pressure (Pa)
``keller``                             depth   pressure (Pa) of a F73 response, paired with its request
``didson``, ``aris``                   sonar   :class:`SonarPayload`: image (bins, beams) uint8, window (m),
                                               beam azimuths (rad)
``oculus`` (SimplePingResult; the      sonar   :class:`SonarPayload`: the image (16/32-bit: its top 8 bits),
fire echo and status give none)                window ``(0, range lines x range resolution)``, the bearing table
``nmea`` (GGA; RMC from a receiver     gnss    :class:`auvlink.pipeline.georef.GnssPayload`: WGS84 lat/lon
that sends no GGA; ZDA none)                   (deg, NaN without a fix), height (m), fix quality, HDOP
=====================================  ======  ==============================================================

Every other format (the CAN navigation bus, PD6 lines, the DSP-3000 integrated angle) gives no event:
:data:`ROUTES` is the table above, :data:`CONSUMED_FORMATS` its formats, and replay decodes only the
channels of these formats. The order key ``(t_ns, seq)`` is the host receive time, then the arrival
order, so a log replays in the order the live run saw; a sonar frame's time is its ping's, mapped to the host clock
(:class:`auvlink.pipeline.sensor_clock.SensorClock`: a burst of frames keeps the pings' spacing), its receive
time kept in its payload. :func:`nav_inputs` turns a run of events into
the arrays of :mod:`recon.nav` (times in s relative to a mission origin ``t0_ns``, so float64 keeps
sub-microsecond resolution over long missions); the streaming engine calls it per block, the batch
path once.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from auvlink.codecs import keller, oculus
from auvlink.pipeline.sensor_clock import SensorClock
from auvlink.records import Sample
from recon.errors import GeometryError
from recon.frames import VelocityFrame
from recon.nav import DepthSamples, DvlSamples, GyroSamples

#: wire format -> (event kind, the :class:`NavAdaptor` method that makes the payload); the one table of
#: what the pipeline's stages consume
ROUTES: dict[str, tuple[str, str]] = {
    "pd0": ("dvl", "_pd0"), "dsp1760": ("gyro", "_dsp1760"), "dsp3000": ("gyro", "_dsp3000"),
    "dsp3000_incremental": ("gyro", "_dsp3000"), "paro": ("depth", "_paro"), "keller": ("depth", "_keller"),
    "didson": ("sonar", "_sonar"), "aris": ("sonar", "_sonar"), "oculus": ("sonar", "_oculus"),
    "nmea": ("gnss", "_nmea")}
#: wire formats of sonar frames
SONAR_FORMATS: tuple[str, ...] = tuple(f for f, (kind, _) in ROUTES.items() if kind == "sonar")
#: every wire format a pipeline stage consumes; samples of any other format give no event
CONSUMED_FORMATS: frozenset[str] = frozenset(ROUTES)
#: the wire formats of navigation samples (what a navigation-only consumer decodes)
NAV_FORMATS: frozenset[str] = CONSUMED_FORMATS - frozenset(SONAR_FORMATS)
#: PD0 coordinate systems navigation takes (``beam`` velocities need the beam geometry: not supported)
PD0_FRAMES: dict[str, VelocityFrame] = {"instrument": "instrument", "ship": "ship", "earth": "earth"}

GyroKind = Literal["rate", "delta"]


class Event(NamedTuple):
    t_ns: int  # host receive time, ns (a sonar frame: its ping's time on the host clock, SensorClock)
    seq: int  # arrival order (1, 2, ...) among the events of one adaptor
    kind: str  # dvl | gyro | depth | sonar | gnss
    payload: Any  # DvlPayload | (3,) gyro tuple | pressure Pa | SonarPayload


class DvlPayload(NamedTuple):
    velocity: tuple[float, float, float]  # m/s, in ``frame``
    valid: bool
    altitude: float  # m
    heading: float  # rad
    pitch: float  # rad
    roll: float  # rad
    frame: str  # the PD0 coordinate system (instrument, ship, earth, beam)


class SonarPayload(NamedTuple):
    device: str
    image: NDArray[np.uint8]  # (range bins, beams)
    window: tuple[float, float]  # (start, length) m
    azimuths: NDArray[np.float64]  # (beams,) rad
    received_ns: int = 0  # host receive time, ns (the event's time is the ping's: SensorClock)


class NavInputs(NamedTuple):
    """The :mod:`recon.nav` inputs of a run of events (None for a kind that had no event)."""

    dvl: DvlSamples | None
    gyro: GyroSamples | None
    depth: DepthSamples | None


class NavAdaptor:
    """Samples -> events (see the module docstring); pairs Keller read requests with their responses.

    ``gyro_kind`` is ``rate`` or ``delta`` as the last gyro sample said; ``counts`` the samples seen per device.
    """

    def __init__(self) -> None:
        self.seq = 0
        self.gyro_kind: GyroKind = "rate"
        self.counts: dict[str, int] = {}
        self._keller_request: dict[int, keller.KellerReadRequest] = {}
        self._gga_devices: set[str] = set()
        #: device -> the clock that times its sonar frames by their pings (:mod:`auvlink.pipeline.sensor_clock`)
        self.sonar_clocks: dict[str, SensorClock] = {}
        self._routes: dict[str, tuple[str, Callable[[Any, str], Any]]] = {
            fmt: (kind, getattr(self, method)) for fmt, (kind, method) in ROUTES.items()}

    def route(self, s: Sample) -> Event | None:
        """The event of ``s``, or None when no stage consumes it."""
        self.counts[s.device] = self.counts.get(s.device, 0) + 1
        route = self._routes.get(s.format)
        if route is None:
            return None
        kind, make = route
        payload = make(s.record, s.device)
        if payload is None:
            return None
        self.seq += 1
        if kind == "sonar":
            clock = self.sonar_clocks.setdefault(s.device, SensorClock())
            t_ns = clock.host_ns(s.t_host_ns, ping_time_s(s))
            return Event(t_ns, self.seq, kind, payload._replace(received_ns=s.t_host_ns))
        return Event(s.t_host_ns, self.seq, kind, payload)

    def nav_inputs(self, events: Sequence[Event], t0_ns: int) -> NavInputs:
        """:func:`nav_inputs` with this adaptor's gyro kind."""
        return nav_inputs(events, t0_ns, self.gyro_kind)

    # ------------------------------------------------------------------ per format
    @staticmethod
    def _pd0(r: Any, device: str) -> DvlPayload | None:
        if r.bottom_track is None:
            return None
        v = np.asarray(r.bt_velocity_mps, dtype=np.float64)[:3]
        ranges = np.asarray(r.bt_range_m, dtype=np.float64)
        ok = np.isfinite(ranges)
        alt = float(ranges[ok].mean()) if ok.sum() >= 3 else np.nan
        return DvlPayload((float(v[0]), float(v[1]), float(v[2])), bool(np.all(np.isfinite(v))), alt,
                          r.heading_rad, r.pitch_rad, r.roll_rad, r.coordinate_system)

    def _dsp1760(self, r: Any, device: str) -> tuple[float, ...]:
        self.gyro_kind = "delta" if r.mode == "delta" else "rate"
        return tuple(float(x) for x in r.gyro)

    def _dsp3000(self, r: Any, device: str) -> tuple[float, ...]:
        self.gyro_kind = "delta" if r.mode == "incremental" else "rate"
        return (0.0, 0.0, float(r.value) if r.valid else np.nan)

    @staticmethod
    def _paro(r: Any, device: str) -> float | None:
        p = getattr(r, "pressure_pa", None)
        return float(p) if p is not None and np.isfinite(p) else None

    def _keller(self, r: Any, device: str) -> float | None:
        if isinstance(r, keller.KellerReadRequest):
            self._keller_request[r.address] = r
        elif isinstance(r, keller.KellerReadResponse):
            req = self._keller_request.pop(r.address, None)
            if req is not None:
                p = keller.pair(req, r).pressure_pa
                if p is not None and np.isfinite(p):
                    return float(p)
        return None

    def _nmea(self, r: Any, device: str) -> Any:
        from auvlink.codecs.nmea import GgaFix
        from auvlink.pipeline.georef import gnss_payload

        if isinstance(r, GgaFix):
            self._gga_devices.add(device)
        return gnss_payload(r, device in self._gga_devices)

    @staticmethod
    def _sonar(r: Any, device: str) -> SonarPayload:
        return SonarPayload(device, np.asarray(r.image), (float(r.window_start_m), float(r.window_length_m)),
                            np.asarray(r.azimuths_rad, dtype=np.float64))


    @staticmethod
    def _oculus(r: Any, device: str) -> SonarPayload | None:
        if not isinstance(r, oculus.OculusPing):
            return None
        image = np.asarray(r.image)
        if image.dtype != np.uint8:  # 16/32-bit samples: the top byte, the scale of an 8-bit ping
            image = (image >> (8 * (image.dtype.itemsize - 1))).astype(np.uint8)
        return SonarPayload(device, image, (0.0, r.n_ranges * float(r.range_resolution_m)),
                            np.asarray(r.bearings_rad, dtype=np.float64))


def ping_time_s(s: Sample) -> float | None:
    """The sonar's own time of a frame's ping (s, the sonar clock's origin): a DIDSON's or ARIS's frame time, an
    Oculus V2 ping's start time since power-up (a V1 ping's counter has no stated unit: None)."""
    r = s.record
    if isinstance(r, oculus.OculusPing):
        return float(r.ping_start_time) if r.header.msg_version == 2 else None
    return s.t_sensor


def _times(events: Sequence[Event], t0_ns: int) -> NDArray[np.float64]:
    """Event times in s since ``t0_ns``."""
    return np.array([(e.t_ns - t0_ns) * 1e-9 for e in events], dtype=np.float64)


def velocity_frame(pd0_coordinate_system: str) -> VelocityFrame:
    """The :mod:`recon.frames` name of a PD0 coordinate system (GeometryError for ``beam``)."""
    frame = PD0_FRAMES.get(pd0_coordinate_system)
    if frame is None:
        raise GeometryError(f"the DVL reports velocities in {pd0_coordinate_system!r} coordinates; navigation "
                            f"takes {', '.join(PD0_FRAMES)}: set the DVL's coordinate transformation (EX command)")
    return frame


def dvl_samples(events: Sequence[Event], t0_ns: int) -> DvlSamples:
    """DVL events -> :class:`recon.nav.DvlSamples` (frame: the last event's; ``instrument`` with none)."""
    pl: list[DvlPayload] = [e.payload for e in events]
    return DvlSamples(t=_times(events, t0_ns), velocity=np.array([x.velocity for x in pl], np.float64).reshape(-1, 3),
                      frame=velocity_frame(pl[-1].frame) if pl else "instrument",
                      valid=np.array([x.valid for x in pl], bool), altitude=np.array([x.altitude for x in pl]),
                      heading=np.array([x.heading for x in pl]), pitch=np.array([x.pitch for x in pl]),
                      roll=np.array([x.roll for x in pl]))


def gyro_samples(events: Sequence[Event], t0_ns: int, kind: GyroKind) -> GyroSamples:
    """Gyro events -> :class:`recon.nav.GyroSamples` of ``kind`` (``rate``: rad/s, ``delta``: rad)."""
    return GyroSamples(t=_times(events, t0_ns), value=np.array([e.payload for e in events], np.float64).reshape(-1, 3),
                       kind=kind)


def depth_samples(events: Sequence[Event], t0_ns: int) -> DepthSamples:
    """Depth events -> :class:`recon.nav.DepthSamples` (absolute pressure, Pa)."""
    return DepthSamples(t=_times(events, t0_ns), pressure_pa=np.array([e.payload for e in events], np.float64))


def nav_inputs(events: Sequence[Event], t0_ns: int, gyro_kind: GyroKind = "rate") -> NavInputs:
    """The navigation events of ``events`` (in their order; sonar events ignored) as :mod:`recon.nav` inputs."""
    dvl = [e for e in events if e.kind == "dvl"]
    gyro = [e for e in events if e.kind == "gyro"]
    depth = [e for e in events if e.kind == "depth"]
    return NavInputs(dvl_samples(dvl, t0_ns) if dvl else None,
                     gyro_samples(gyro, t0_ns, gyro_kind) if gyro else None,
                     depth_samples(depth, t0_ns) if depth else None)
