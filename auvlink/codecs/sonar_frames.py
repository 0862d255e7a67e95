"""The sonar description of a decoded frame, from its own header: DIDSON, ARIS and Oculus.

:func:`describe_frame` gives the :class:`auvlink.sonar.SonarDescription` a frame carries: the model's data
sheet (:func:`auvlink.sonar.describe`) with what the frame itself says put over it: its beam bearings
(deg, + to starboard, port first), its samples per beam or range resolution (m) and, for an Oculus ping, the
frequency it reports (Hz).

- DIDSON-class frames (:mod:`auvlink.codecs.didson`): the ``didson`` model; the header's ``FrequencyHiLow``
  (1 = high) picks the mode.
- ARIS frames (:mod:`auvlink.codecs.aris`): ``TheSystemType`` 0 (ARIS 1800) and 2 (ARIS 1200, described by
  the ARIS 1800's low mode, the same 48-beam table) give ``aris1800``, 1 gives ``aris3000``; the beam count
  picks the mode (the larger count of the model is its high-frequency mode).
- Oculus pings (:mod:`auvlink.codecs.oculus`): the model and mode whose data-sheet frequency and field of
  view are nearest the ping's (a ping at 1.2 MHz over 70 deg is an M750d's high mode, over 130 deg an
  M1200d's low mode).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from auvlink.codecs.aris_lib import ArisFrame
from auvlink.codecs.didson import DidsonFrame
from auvlink.codecs.oculus import OculusPing
from auvlink.errors import DecodeError
from auvlink.sonar import DATA_SHEETS, SonarDescription, describe

#: ARIS TheSystemType -> model of :data:`auvlink.sonar.DATA_SHEETS` (aris-file-sdk FrameHeader.h: 0 ARIS 1800,
#: 1 ARIS 3000, 2 ARIS 1200)
ARIS_SYSTEMS: dict[int, str] = {0: "aris1800", 1: "aris3000", 2: "aris1800"}

SonarFrame = DidsonFrame | ArisFrame | OculusPing


def _bearings_deg(azimuths_rad: npt.NDArray[np.float64]) -> tuple[float, ...]:
    return tuple(float(x) for x in np.degrees(np.asarray(azimuths_rad, dtype=np.float64)))


def _aris(frame: ArisFrame) -> SonarDescription:
    if isinstance(frame, DidsonFrame):
        mode = "high" if int(frame.field("FrequencyHiLow")) == 1 else "low"
        return replace(describe("didson", mode), samples=frame.samples_per_beam)  # the DIDSON's own bearings
    model = ARIS_SYSTEMS.get(frame.system_type)
    if model is None:
        raise DecodeError(f"aris: system type {frame.system_type} is not an ARIS 1200/1800/3000", fmt="aris")
    high = describe(model, "high")
    base = high if frame.beam_count == high.n_beams else describe(model, "low")
    return replace(base, bearings_deg=_bearings_deg(frame.azimuths_rad), samples=frame.samples_per_beam)


def _oculus(ping: OculusPing) -> SonarDescription:
    bearings = _bearings_deg(ping.bearings_rad)
    field = bearings[-1] - bearings[0]

    def mismatch(key: tuple[str, str]) -> float:
        d = describe(*key)
        return abs(math.log(ping.frequency_hz / d.frequency_hz)) + abs(math.log(field / d.field_of_view_deg))

    if not (ping.frequency_hz > 0 and field > 0):
        raise DecodeError(f"oculus: ping {ping.ping_id} has no frequency or no bearing span", fmt="oculus")
    key = min((k for k in DATA_SHEETS if k[0].startswith("oculus")), key=mismatch)
    return replace(describe(*key), frequency_hz=float(ping.frequency_hz), bearings_deg=bearings,
                   range_resolution_m=float(ping.range_resolution_m))


def describe_frame(frame: SonarFrame) -> SonarDescription:
    """The sonar description a decoded DIDSON, ARIS or Oculus frame carries (module docstring)."""
    if isinstance(frame, OculusPing):
        return _oculus(frame)
    return _aris(frame)
