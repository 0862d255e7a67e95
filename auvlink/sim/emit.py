"""The simulated vehicle on the wire: measurements -> raw frames through the real encoders, in time order.

Devices (the names of ``examples/virtual_ports.toml``) and what each sends:

========  =========  ================================================================================
dvl       pd0        one ensemble per ping (:func:`auvlink.sim.dvl.pd0_ensemble`)
gyro      dsp1760    one 36-byte message per sample, rate mode, sequence modulo 128
pressure  paro       one ``*0001<psi>`` line per sample, or (``keller``) an F48 initialise request and
                     answer at t = 0, then per sample an F73 read-P1 request and, ``keller_latency_s``
                     later, its response (as a tap on the RS-485 line sees them)
can       can        DVL_BT_VELOCITY, DVL_ALTITUDE (per ping), GYRO_RATE, ATTITUDE (``can_hz``),
                     PRESSURE, DEPTH (per pressure sample): 16-byte raw frames of the navigation DBC
gnss      nmea       per fix (a scene with ``[gnss]``): GGA, RMC and ZDA sentences (:mod:`auvlink.sim.gnss`;
                     fix quality 0 and empty while the antenna is under water)
sonar     didson     one frame per sonar pose: :class:`~auvlink.sim.sonar_render.SonarRenderer` image,
                     the scene's window, the frame time (us) and the head's heading/pitch/roll
          oculus     (a scene whose ``[sonar] model`` is an Oculus) one SimplePingResult V2 per pose
                     (:mod:`auvlink.sim.oculus_ping`): the image from the transducer to the window's end
          aris       (an ARIS 1800 or 3000) one ARIS frame per pose (:mod:`auvlink.sim.aris_frame`): the
                     window the ARIS samples, the frame time (us), the head's heading/pitch/roll
========  =========  ================================================================================

No byte is built by hand: every frame is ``encode(build(...))`` of its codec (CAN records are
built with every signal given, so :func:`auvlink.codecs.can_nav.encode` alone quantizes them).

An :data:`Event` is ``(t_ns, sub-stream, index, device, raw, t_sensor_ns)``: host time = mission
start + t, the sensor time where the format has a clock. :func:`block_events` returns the events
whose time falls in ``[t0, t1)``, sorted by ``(t_ns, sub-stream, index)``; since every event's time
and bytes depend only on its own index, any split of a run into blocks gives the same sequence.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from auvlink.codecs import can_nav, didson, dsp1760, keller, paro
from auvlink.codecs import pd0 as pd0_codec
from auvlink.sim import gnss as gnss_sim
from auvlink.sim.aris_frame import frame_message
from auvlink.sim.dvl import pd0_ensemble
from auvlink.sim.oculus_ping import ping_message, sonar_format
from auvlink.sim.sensors import Measurements, pressure_to_depth
from auvlink.sim.sonar_render import SonarRenderer

#: device name -> wire format (the pressure device is ``paro`` or ``keller`` per the settings)
DEVICES = ("dvl", "gyro", "pressure", "can", "sonar", "gnss")
Event = tuple[int, int, int, str, bytes, int | None]
Encoder = Callable[[Measurements, int], tuple[bytes, int | None]]


def device_formats(m: Measurements, sonar: str = "didson") -> dict[str, str]:
    """Device name -> wire format; ``sonar`` the sonar's (:func:`sonar_format`)."""
    out = {"dvl": "pd0", "gyro": "dsp1760", "pressure": m.sensors.pressure, "can": "can", "sonar": sonar}
    if m.gnss is not None:
        out["gnss"] = "nmea"
    return out


def _ns(x: float) -> int:
    return round(x * 1e9)


@functools.cache
def _can_id(name: str) -> int:
    return int(can_nav.database().get_message_by_name(name).frame_id)


def _can(name: str, **signals: float) -> bytes:
    return can_nav.encode(can_nav.CanNavRecord(_can_id(name), name, signals))


# --- per-sample encoders: (measurements, index) -> (raw, sensor time ns) -------------------------
def _dvl(m: Measurements, k: int) -> tuple[bytes, int | None]:
    start = m.sensors.start_ns * 1e-9
    ens = pd0_ensemble(m.dvl, k, start, m.sensors.sound_speed)
    t = pd0_codec.sensor_time(ens)
    return pd0_codec.encode(ens), None if t is None else _ns(t)


def _gyro(m: Measurements, k: int) -> tuple[bytes, int | None]:
    g = m.gyro
    msg = dsp1760.build(g.rate[k], g.accel[k], sequence=k, temperature_c=g.temperature_c)
    return dsp1760.encode(msg), None


def _paro(m: Measurements, k: int) -> tuple[bytes, int | None]:
    return paro.encode(paro.build_reading(float(m.pressure.pressure_pa[k]))), None


def _keller_init_request(m: Measurements, k: int) -> tuple[bytes, int | None]:
    return keller.encode(keller.KellerInitRequest(m.sensors.keller_address)), None


def _keller_init_response(m: Measurements, k: int) -> tuple[bytes, int | None]:
    return keller.encode(keller.KellerInitResponse(m.sensors.keller_address)), None


def _keller_request(m: Measurements, k: int) -> tuple[bytes, int | None]:
    return keller.encode(keller.KellerReadRequest(m.sensors.keller_address, keller.CH_P1)), None


def _keller_response(m: Measurements, k: int) -> tuple[bytes, int | None]:
    resp = keller.build_pressure_response(m.sensors.keller_address, float(m.pressure.pressure_pa[k]))
    return keller.encode(resp), None


def _can_gyro(m: Measurements, k: int) -> tuple[bytes, int | None]:
    g = m.gyro
    j = min(len(g.t) - 1, round(float(m.ahrs.t[k]) * m.sensors.gyro_hz))
    return _can("GYRO_RATE", rate_z=float(g.rate[j, 2]), counter=k % 256, valid=1), None


def ahrs_euler(heading: float, pitch: float, roll: float) -> tuple[float, float, float]:
    """The attitude as an AHRS reports it: pitch in [-pi/2, pi/2] (noise past the vertical is the same
    attitude with heading and roll turned by pi, as ZYX Euler angles give it), heading in [0, 2 pi]."""
    if abs(pitch) > math.pi / 2.0:
        heading, pitch, roll = (float(v) for v in Rotation.from_euler("ZYX", [heading, pitch, roll]).as_euler("ZYX"))
    return min(heading % (2.0 * math.pi), 2.0 * math.pi), pitch, roll


def _can_attitude(m: Measurements, k: int) -> tuple[bytes, int | None]:
    a = m.ahrs
    heading, pitch, roll = ahrs_euler(float(a.heading[k]), float(a.pitch[k]), float(a.roll[k]))
    return _can("ATTITUDE", heading=heading, pitch=pitch, roll=roll, counter=k % 256, valid=1), None


def _can_dvl_velocity(m: Measurements, k: int) -> tuple[bytes, int | None]:
    d = m.dvl
    if not d.valid[k]:
        return _can("DVL_BT_VELOCITY", vx=0.0, vy=0.0, vz=0.0, counter=k % 256, valid=0), None
    vx, vy, vz = (float(v) for v in d.velocity_body[k])
    return _can("DVL_BT_VELOCITY", vx=vx, vy=vy, vz=vz, counter=k % 256, valid=1), None


def _can_dvl_altitude(m: Measurements, k: int) -> tuple[bytes, int | None]:
    d = m.dvl
    ok = bool(d.valid[k])
    return _can("DVL_ALTITUDE", altitude=float(d.altitude[k]) if ok else 0.0,
                fom=m.noise.dvl.velocity_sigma, counter=k % 256, valid=int(ok)), None


def _can_pressure(m: Measurements, k: int) -> tuple[bytes, int | None]:
    p = m.pressure
    return _can("PRESSURE", pressure=float(p.pressure_pa[k]), temperature_c=p.temperature_c,
                counter=k % 256), None


def _can_depth(m: Measurements, k: int) -> tuple[bytes, int | None]:
    depth = float(pressure_to_depth(m.pressure.pressure_pa[k]))
    return _can("DEPTH", depth=depth, counter=k % 256, valid=1), None


def _gga(m: Measurements, k: int) -> tuple[bytes, int | None]:
    assert m.gnss is not None
    return gnss_sim.gga_frame(m.gnss, k, m.sensors.start_ns * 1e-9), None


def _rmc(m: Measurements, k: int) -> tuple[bytes, int | None]:
    assert m.gnss is not None
    raw, utc = gnss_sim.rmc_frame(m.gnss, k, m.sensors.start_ns * 1e-9)
    return raw, _ns(utc)


def _zda(m: Measurements, k: int) -> tuple[bytes, int | None]:
    assert m.gnss is not None
    raw, utc = gnss_sim.zda_frame(m.gnss, k, m.sensors.start_ns * 1e-9)
    return raw, _ns(utc)


def _substreams(m: Measurements) -> list[tuple[str, np.ndarray, Encoder]]:
    """``(device, emission times, encoder)`` in tie-break order (the sonar is handled apart)."""
    p = m.pressure.t
    pressure: list[tuple[str, np.ndarray, Encoder]]
    if m.sensors.pressure == "keller":  # power-up: F48 initialise (request, answer) before the reads
        t_init = np.zeros(1)
        pressure = [("pressure", t_init, _keller_init_request), ("pressure", t_init, _keller_init_response),
                    ("pressure", p, _keller_request),
                    ("pressure", p + m.sensors.keller_latency_s, _keller_response)]
    else:
        pressure = [("pressure", p, _paro)]
    gnss: list[tuple[str, np.ndarray, Encoder]] = []
    if m.gnss is not None:
        gnss = [("gnss", m.gnss.t, _gga), ("gnss", m.gnss.t, _rmc), ("gnss", m.gnss.t, _zda)]
    return [
        ("gyro", m.gyro.t, _gyro), ("dvl", m.dvl.t, _dvl), *pressure,
        ("can", m.ahrs.t, _can_gyro), ("can", m.ahrs.t, _can_attitude),
        ("can", m.dvl.t, _can_dvl_velocity), ("can", m.dvl.t, _can_dvl_altitude),
        ("can", p, _can_pressure), ("can", p, _can_depth), *gnss,
    ]


def sonar_frame(m: Measurements, k: int, image: np.ndarray, window_start: float,
                window_length: float) -> tuple[bytes, int | None]:
    s = m.sonar
    frame = didson.build(image, window_start, window_length, m.sensors.sound_speed, k,
                         m.sensors.start_ns * 1e-9 + float(s.t[k]), float(s.heading[k]),
                         float(s.pitch[k]), float(s.roll[k]))
    t = didson.sensor_time(frame)
    return didson.encode(frame), None if t is None else _ns(t)


def sonar_message(m: Measurements, k: int, image: np.ndarray, renderer: SonarRenderer) -> tuple[bytes, int | None]:
    """Frame ``k`` in the wire format of the scene's sonar model (DIDSON or ARIS frame with its sensor time, or an
    Oculus ping without one)."""
    fan, sc = renderer.geometry, renderer.scene.sonar
    fmt = sonar_format(sc)
    if fmt == "didson":
        return sonar_frame(m, k, image, sc.window_start, sc.window_length)
    s = m.sonar
    attitude = (float(s.heading[k]), float(s.pitch[k]), float(s.roll[k]))
    if fmt == "aris":
        raw, t = frame_message(fan.description, image, (sc.window_start, sc.window_length), frame_index=k,
                               time_s=m.sensors.start_ns * 1e-9 + float(s.t[k]), sound_speed=m.sensors.sound_speed,
                               fps=sc.fps, attitude_rad=attitude, water_temperature_c=m.sensors.water_temperature_c)
        return raw, _ns(t)
    raw = ping_message(fan.description, image, fan.window_end, ping_id=k, time_s=float(s.t[k]),
                       sound_speed=m.sensors.sound_speed, fps=sc.fps, attitude_rad=attitude)
    return raw, None


def block_events(m: Measurements, t0: float, t1: float, renderer: SonarRenderer | None) -> list[Event]:
    """Every event with mission time in ``[t0, t1)``, sorted (see the module docstring).

    ``renderer`` draws the sonar frames (None: no sonar device).
    """
    start = m.sensors.start_ns
    out: list[Event] = []
    subs = _substreams(m)
    for order, (device, times, enc) in enumerate(subs):
        i0, i1 = np.searchsorted(times, [t0, t1], side="left")
        for k in range(int(i0), int(i1)):
            raw, t_sensor = enc(m, k)
            out.append((start + _ns(float(times[k])), order, k, device, raw, t_sensor))
    if renderer is not None:
        s = m.sonar
        i0, i1 = (int(i) for i in np.searchsorted(s.t, [t0, t1], side="left"))
        if i1 > i0:
            frames = renderer.render_sequence(s.position[i0:i1], Rotation.from_matrix(s.r_wb[i0:i1]),
                                              m.seed, first_frame=i0)
            for k, image in zip(range(i0, i1), frames, strict=True):
                raw, t_sensor = sonar_message(m, k, image, renderer)
                out.append((start + _ns(float(s.t[k])), len(subs), k, "sonar", raw, t_sensor))
    out.sort(key=lambda e: (e[0], e[1], e[2]))
    return out
