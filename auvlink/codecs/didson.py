"""DIDSON-class live sonar frames: the ARIS frame layout carrying 96 beams x 512 range samples.

Wire layout (auvlink's DIDSON-class profile of SoundMetrics' DDF_05 frame, aris-file-sdk
``type-definitions/C/FrameHeader.h``): the 1024-byte ARIS frame header (signature ``DDF\\x05`` at
byte 12), then ``SamplesPerBeam`` rows of 96 bytes in the SDK beam order (beam 0 = starboard-most),
exactly what an ARIS 1800 sends in a 96-beam ping mode once reordered. It differs from
:mod:`auvlink.codecs.aris` in three documented ways:

* The window comes from the header's ``WindowStart`` / ``WindowLength`` floats (metres, DIDSON's
  DDF heritage): row m is at ``WindowStart + m * WindowLength / SamplesPerBeam``. :func:`build`
  also fills ``SampleStartDelay`` / ``SamplePeriod`` (integer microseconds, rounded) for ARIS tools.
* Beam azimuths are the DIDSON's of :data:`auvlink.sonar.DIDSON` (linear over its field of view, the
  DIDSON fallback model of ARCHITECTURE.md), not the ARIS 1800 beam table.
* Only 96-beam ping modes (3..5) are accepted; :func:`build` writes ping mode 3.

The decoded ``image`` is (range bin, beam) with column 0 the port-most beam, as for ARIS.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from auvlink.codecs.aris import sensor_time, to_json
from auvlink.codecs.aris_lib import ArisFrame, decode_as, encode_frame
from auvlink.errors import EncodeError
from auvlink.formats import WireFormat
from auvlink.framing.aris import DidsonFramer
from auvlink.framing.aris_defs import FRAME_HEADER_DTYPE, MAX_SAMPLES_PER_BEAM, PING_MODE_BEAMS, SIGNATURE_U32
from auvlink.sonar import DIDSON

#: the ping mode :func:`build` writes (wire: an ARIS 1800 96-beam mode, aris-file-sdk FrameFuncs.c)
PING_MODE = 3
#: beams of every frame (wire: the ping mode's beam count, the DIDSON description's beams)
BEAMS = PING_MODE_BEAMS[PING_MODE]
if BEAMS != DIDSON.n_beams:
    raise ImportError(f"didson: ping mode {PING_MODE} sends {BEAMS} beams, the DIDSON description {DIDSON.n_beams}")
#: azimuth of each image column (rad, + to starboard), column 0 = port-most beam
AZIMUTHS_RAD: npt.NDArray[np.float64] = np.deg2rad(np.asarray(DIDSON.bearings_deg, dtype=np.float64))
AZIMUTHS_RAD.setflags(write=False)
_U32_MAX = 0xFFFFFFFF


@dataclass(frozen=True, eq=False, repr=False)
class DidsonFrame(ArisFrame):
    """A DIDSON-class frame: 96 beams, window from the header floats, linear azimuths."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.beam_count != BEAMS:
            raise EncodeError(
                f"didson: {self.beam_count} beams (ping mode {self.ping_mode}), expected {BEAMS}"
            )

    @property
    def window_start_m(self) -> float:
        return float(self.header["WindowStart"])

    @property
    def window_length_m(self) -> float:
        return float(self.header["WindowLength"])

    @property
    def range_resolution_m(self) -> float:
        return self.window_length_m / self.samples_per_beam

    @functools.cached_property
    def azimuths_rad(self) -> npt.NDArray[np.float64]:
        return AZIMUTHS_RAD


def decode(raw: bytes | bytearray | memoryview) -> DidsonFrame:
    """One raw frame -> :class:`DidsonFrame` (the image is a zero-copy view of ``raw``)."""
    return decode_as(raw, DidsonFrame, fmt="didson")


def encode(frame: ArisFrame) -> bytes:
    """A frame -> raw bytes (header verbatim, image in the SDK beam order)."""
    return encode_frame(frame)


def _image(image: npt.ArrayLike) -> npt.NDArray[np.uint8]:
    img = np.asarray(image)
    if img.ndim != 2 or img.shape[1] != BEAMS or not 1 <= img.shape[0] <= MAX_SAMPLES_PER_BEAM:
        raise EncodeError(f"didson: image must be (range bins, {BEAMS} beams), got shape {img.shape}")
    if img.dtype != np.uint8:
        if img.dtype.kind not in "iu" or (img.size and (img.min() < 0 or img.max() > 255)):
            raise EncodeError(f"didson: image must hold uint8 intensities, got {img.dtype}")
    out = np.array(img, dtype=np.uint8, copy=True)
    out.setflags(write=False)
    return out


def _microseconds(name: str, seconds: float) -> int:
    us = round(seconds * 1e6)
    if not 0 <= us <= _U32_MAX:
        raise EncodeError(f"didson: {name} of {seconds} s does not fit the header (0..{_U32_MAX} us)")
    return us


def build(
    image: npt.ArrayLike,
    window_start_m: float,
    window_length_m: float,
    sound_speed: float = 1500.0,
    frame_index: int = 0,
    time: float = 0.0,
    heading: float | None = None,
    pitch: float | None = None,
    roll: float | None = None,
) -> DidsonFrame:
    """The frame the simulator sends, exactly as a receiver will decode it.

    ``image``: (range bins, 96) uint8, column 0 = port-most beam (usually 512 bins). Window in m,
    sound speed in m/s, ``time`` in s since the UNIX epoch (kept to the microsecond),
    heading/pitch/roll in rad (stored in degrees; NaN when ``None``). Use the returned record's
    ``ranges_m`` / ``azimuths_rad`` (float32 window) for geometry.
    """
    img = _image(image)
    n = img.shape[0]
    for name, v in (("window_start_m", window_start_m), ("window_length_m", window_length_m),
                    ("sound_speed", sound_speed), ("time", time)):
        if not math.isfinite(v) or v < 0 or (v == 0 and name in ("window_length_m", "sound_speed")):
            raise EncodeError(f"didson: {name} = {v} is not a valid value")
    if not 0 <= frame_index <= _U32_MAX:
        raise EncodeError(f"didson: frame_index {frame_index} does not fit a u32")
    arr = np.zeros(1, dtype=FRAME_HEADER_DTYPE)
    h = arr[0]
    h["FrameIndex"] = frame_index
    h["FrameTime"] = h["sonarTimeStamp"] = round(time * 1e6)
    h["Version"] = SIGNATURE_U32
    h["WindowStart"] = window_start_m
    h["WindowLength"] = window_length_m
    period_us = max(1, _microseconds("sample period", 2.0 * window_length_m / (sound_speed * n)))
    h["SamplePeriod"] = period_us
    h["SampleRate"] = 1e6 / period_us
    h["SampleStartDelay"] = _microseconds("sample start delay", 2.0 * window_start_m / sound_speed)
    h["SoundSpeed"] = sound_speed
    h["SamplesPerBeam"] = n
    h["PingMode"] = PING_MODE
    h["FrequencyHiLow"] = 1
    h["TransmitEnable"] = 1
    h["ReorderedSamples"] = 1
    for name, angle in (("Heading", heading), ("Pitch", pitch), ("Roll", roll)):
        h[name] = math.nan if angle is None else math.degrees(angle)
    return DidsonFrame(h, img)


WIRE_FORMAT = WireFormat(
    name="didson",
    encoding="soundmetrics.didson",
    description="DIDSON-class live frames (ARIS frame header + 96 beams x 512 samples)",
    decode=decode,
    encode=encode,
    framer=DidsonFramer,
    sensor_time=sensor_time,
    to_json=to_json,
)
