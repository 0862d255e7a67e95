"""The simulated ARIS on the wire: a rendered image as the frame an ARIS Explorer 1800 or 3000 sends.

:func:`frame_message` builds the :class:`auvlink.codecs.aris.ArisFrame` of one rendered image and encodes it with
the real encoder (:func:`auvlink.codecs.aris.encode`). The image is the renderer's (range samples x beams, uint8,
row 0 at the window's start, column 0 the port-most beam: the decoder's orientation; the encoder writes the SDK
beam order, beam 0 starboard-most). The header fields it fills, with their facts from the codec's field table
(:data:`auvlink.framing.aris_defs.FRAME_HEADER_FIELDS`, transcribed from aris-file-sdk ``FrameHeader.h``) and the
codec's notes (:mod:`auvlink.codecs.aris`):

* ``SampleStartDelay`` and ``SamplePeriod`` (integer microseconds) with ``SoundSpeed`` (m/s) place the rows: row
  m lies at ``SampleStartDelay*1e-6*SoundSpeed/2 + m*SamplePeriod*1e-6*SoundSpeed/2`` m (the SDK's
  ``SampleRange``); ``SamplesPerBeam`` rows (the model's samples per beam), ``SampleRate`` = 1e6 /
  ``SamplePeriod`` Hz. Whole microseconds cannot say every window: :func:`sampled_window` gives the window an
  ARIS samples for a configured one, and :func:`aris_scene` makes it the scene's, so the renderer draws the rows
  the frame says.
* ``PingMode`` gives the beam count (aris-file-sdk ``FrameFuncs.c``, :data:`auvlink.framing.aris_defs.PING_MODE_BEAMS`):
  the first ping mode of the model's beam count (1: 48, 3: 96, 6: 64, 9: 128 beams).
* ``TheSystemType`` 0 = ARIS 1800, 1 = ARIS 3000; ``FrequencyHiLow`` 1 = high, 0 = low; ``LargeLens`` 0 (the
  standard lens, whose SDK beam tables are the description's bearings, :func:`auvlink.sonar.aris_bearings`).
* ``ReorderedSamples`` 1: samples already in [sample][beam] order, as a ``.aris`` recording holds them (the
  decoder reads raw, unreordered frames as they are).
* ``FrameIndex``; ``FrameTime`` and ``sonarTimeStamp`` (us since the UNIX epoch); ``FrameRate`` (frames/s),
  ``CyclePeriod`` (us between pings); ``TransmitEnable`` 1; ``WaterTemp`` (degC); ``Heading``, ``Pitch``,
  ``Roll`` (deg: the head's attitude, as the DIDSON frame of :func:`auvlink.codecs.didson.build` carries it).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from auvlink.codecs import aris
from auvlink.framing.aris_defs import FRAME_HEADER_DTYPE, PING_MODE_BEAMS, SIGNATURE_U32
from auvlink.sim.oculus_ping import sonar_format
from auvlink.sim.scene import Scene
from auvlink.sonar import SonarDescription

#: ARIS model -> ``TheSystemType`` (aris-file-sdk FrameHeader.h: 0 ARIS 1800, 1 ARIS 3000, 2 ARIS 1200)
SYSTEM_TYPES: dict[str, int] = {"aris1800": 0, "aris3000": 1}
#: most microseconds a u32 header field holds (FrameHeader.h: SamplePeriod, SampleStartDelay are uint32)
_U32_MAX = 0xFFFFFFFF


def ping_mode(description: SonarDescription) -> int:
    """The ping mode of the description's beam count: the first of the SDK's modes that send it."""
    modes = [mode for mode, beams in sorted(PING_MODE_BEAMS.items()) if beams == description.n_beams]
    if not modes:
        raise ValueError(f"aris frame: no ARIS ping mode sends {description.n_beams} beams")
    return modes[0]


def _f32(x: float) -> float:
    """``x`` as the header's float32 holds it (the sound speed every range is computed with)."""
    return float(np.float32(x))


def sampled_delays_us(start_m: float, length_m: float, samples: int, sound_speed: float) -> tuple[int, int]:
    """``(SampleStartDelay, SamplePeriod)`` in whole microseconds for a window (m) of ``samples`` rows at
    ``sound_speed`` (m/s): the two-way travel time to the start, and per row, rounded (a period of 1 us at least)."""
    c = _f32(sound_speed)
    delay = round(2.0 * start_m / c * 1e6)
    period = max(1, round(2.0 * length_m / (c * samples) * 1e6))
    if not (0 <= delay <= _U32_MAX and period <= _U32_MAX):
        raise ValueError(f"aris frame: window {start_m} + {length_m} m does not fit the header's microseconds")
    return delay, period


def sampled_window(start_m: float, length_m: float, samples: int, sound_speed: float) -> tuple[float, float]:
    """The window (start, length, m) an ARIS samples for a configured one: whole-microsecond delays
    (:func:`sampled_delays_us`) turned back into metres with the header's float32 sound speed."""
    delay, period = sampled_delays_us(start_m, length_m, samples, sound_speed)
    half_c = _f32(sound_speed) / 2.0
    return delay * 1e-6 * half_c, samples * (period * 1e-6 * half_c)


def aris_scene(scene: Scene, sound_speed: float) -> Scene:
    """The scene with an ARIS' window the one it samples at ``sound_speed`` (m/s); any other sonar unchanged."""
    sonar = scene.sonar
    samples = sonar.description.samples
    if sonar_format(sonar) != "aris" or samples is None:
        return scene
    start, length = sampled_window(sonar.window_start, sonar.window_length, samples, sound_speed)
    return replace(scene, sonar=replace(sonar, window_start=start, window_length=length))


def build_frame(description: SonarDescription, image: np.ndarray, window: tuple[float, float], *, frame_index: int,
                time_s: float, sound_speed: float, fps: float, attitude_rad: tuple[float, float, float],
                water_temperature_c: float) -> aris.ArisFrame:
    """The :class:`~auvlink.codecs.aris.ArisFrame` of ``image`` (samples, beams) uint8 over ``window`` (start,
    length, m; one :func:`sampled_window` gives, else ValueError); ``time_s`` s since the UNIX epoch; ``fps``
    frames/s; ``attitude_rad`` the head's heading, pitch, roll (rad); ``water_temperature_c`` degC."""
    system = SYSTEM_TYPES.get(description.model)
    if system is None or description.samples is None:
        raise ValueError(f"aris frame: the {description.model} is not an ARIS model")
    rows, beams = image.shape
    if (rows, beams) != (description.samples, description.n_beams):
        raise ValueError(f"aris frame: image of {rows} x {beams}, the {description.model} sends "
                         f"{description.samples} samples x {description.n_beams} beams")
    delay, period = sampled_delays_us(*window, rows, sound_speed)
    said = sampled_window(*window, rows, sound_speed)
    if not np.allclose(said, window, rtol=0.0, atol=1e-9):
        raise ValueError(f"aris frame: window {window} m is not one an ARIS samples ({said} m): render with "
                         "auvlink.sim.aris_frame.aris_scene")
    h = np.zeros(1, dtype=FRAME_HEADER_DTYPE)[0]
    h["Version"] = SIGNATURE_U32
    h["FrameIndex"] = frame_index
    h["FrameTime"] = h["sonarTimeStamp"] = round(time_s * 1e6)
    h["SampleStartDelay"], h["SamplePeriod"], h["SampleRate"] = delay, period, 1e6 / period
    h["SoundSpeed"], h["SamplesPerBeam"] = sound_speed, rows
    h["PingMode"], h["TheSystemType"], h["LargeLens"] = ping_mode(description), system, 0
    h["FrequencyHiLow"] = 1 if description.frequency_mode == "high" else 0
    h["TransmitEnable"], h["ReorderedSamples"] = 1, 1
    h["FrameRate"], h["CyclePeriod"] = fps, round(1e6 / fps)
    h["WaterTemp"] = water_temperature_c
    for name, angle in zip(("Heading", "Pitch", "Roll"), attitude_rad, strict=True):
        h[name] = math.degrees(angle)
    return aris.ArisFrame(h, np.ascontiguousarray(image, dtype=np.uint8))


def frame_message(description: SonarDescription, image: np.ndarray, window: tuple[float, float], *,
                  frame_index: int, time_s: float, sound_speed: float, fps: float,
                  attitude_rad: tuple[float, float, float], water_temperature_c: float) -> tuple[bytes, float]:
    """One ARIS frame's bytes (:func:`build_frame`, :func:`auvlink.codecs.aris.encode`) and its sensor time (s)."""
    frame = build_frame(description, image, window, frame_index=frame_index, time_s=time_s, sound_speed=sound_speed,
                        fps=fps, attitude_rad=attitude_rad, water_temperature_c=water_temperature_c)
    return aris.encode(frame), aris.sensor_time(frame)
