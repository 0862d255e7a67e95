"""The simulated Oculus on the wire: a rendered image as the SimplePingResult V2 an Oculus M-series sends.

:func:`ping_message` builds the :class:`auvlink.codecs.oculus.OculusPing` of one rendered image and encodes it
with the real encoder. The image is the renderer's (range lines x beams, uint8, row 0 at the transducer: the
:class:`~auvlink.sim.sonar_geometry.RayFan` of an Oculus model samples ``[0, window end)``); the bearing table
is the model's (:attr:`auvlink.sonar.SonarDescription.bearings_deg`, the wire's 0.01 deg); the fire fields
echo what a SimpleFire asks for: the frequency mode, the range (m, the window's end), the gain, the sound speed
and the ping rate code of the frame rate. V2 carries the head's heading, pitch and roll (deg) and the ping
start time (s since power-up: the mission time here).
"""

from __future__ import annotations

import math

import numpy as np

from auvlink.codecs import oculus
from auvlink.codecs.oculus_messages import OculusFire, OculusHeader
from auvlink.framing import oculus_defs as d
from auvlink.sonar import Sonar, SonarDescription

#: the PingRateType codes (liboculus Oculus.h facts, auvlink.codecs.oculus_messages.OculusFire): rate Hz -> code
PING_RATE_CODES: dict[float, int] = {10.0: 0, 15.0: 1, 40.0: 2, 5.0: 3, 2.0: 4}
#: the simulated head's water temperature (degC) and gain (%) reported in every ping (the scene has neither)
TEMPERATURE_C = 10.0
GAIN_PERCENT = 50.0


def sonar_format(sonar: Sonar) -> str:
    """The wire format the simulated sonar speaks: ``oculus`` for an Oculus model, ``aris`` for an ARIS
    (:mod:`auvlink.sim.aris_frame`), ``didson`` for the DIDSON."""
    model = sonar.description.model
    return "oculus" if model.startswith("oculus") else "aris" if model.startswith("aris") else "didson"


def ping_rate_code(fps: float) -> int:
    """The PingRateType code nearest the frame rate (Hz): the sonar pings at one of its fixed rates."""
    rate = min(PING_RATE_CODES, key=lambda r: abs(math.log(r / fps)))
    return PING_RATE_CODES[rate]


def fire_fields(description: SonarDescription, range_m: float, sound_speed: float, fps: float) -> OculusFire:
    """The fire fields of a ping: mode, range in metres, gain, sound speed (m/s), ping rate, beam count flag."""
    flags = d.FLAG_RANGE_AS_METERS | d.FLAG_SIMPLE_RETURN | (d.FLAG_512_BEAMS if description.n_beams >= 512 else 0)
    mode = d.FREQ_MODE_HIGH if description.frequency_mode == "high" else d.FREQ_MODE_LOW
    return OculusFire(master_mode=mode, ping_rate=ping_rate_code(fps), flags=flags, range=range_m,
                      gain_percent=GAIN_PERCENT, speed_of_sound_mps=sound_speed)


def ping_message(description: SonarDescription, image: np.ndarray, range_m: float, *, ping_id: int,
                 time_s: float, sound_speed: float, fps: float, attitude_rad: tuple[float, float, float],
                 depth_pa: float = 0.0) -> bytes:
    """One SimplePingResult V2 message: ``image`` (range lines, beams) uint8 over ``[0, range_m)`` m, row ``m``
    at ``m * range_m / lines``; ``attitude_rad`` the head's heading, pitch, roll; ``depth_pa`` gauge pressure."""
    rows, beams = image.shape
    if beams != description.n_beams:
        raise ValueError(f"oculus ping: image of {beams} beams, the {description.model} sends {description.n_beams}")
    heading, pitch, roll = (math.degrees(a) for a in attitude_rad)
    ping = oculus.OculusPing(
        header=OculusHeader(msg_version=2), fire=fire_fields(description, range_m, sound_speed, fps),
        ping_id=ping_id, status=0, frequency_hz=description.frequency_hz, temperature_c=TEMPERATURE_C,
        pressure_bar=depth_pa * 1e-5, speed_of_sound_mps=sound_speed, ping_start_time=time_s,
        range_resolution_m=range_m / rows, bearings_rad=np.radians(np.asarray(description.bearings_deg)),
        image=np.asarray(image, dtype=np.uint8), heading_deg=heading, pitch_deg=pitch, roll_deg=roll)
    return oculus.encode(ping)
