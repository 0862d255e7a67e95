"""Which sonar frames the engine reconstructs: those with navigation, outside dives, climbs and line-end turns.

Diving or climbing, the seabed sweeps through the beam with no survey geometry. Turning at the end of a line,
the fan sweeps sideways over seabed the seabed fit ahead does not know, and the onset correction cannot follow it
(false objects in every turn on rough, sloped seabeds). Both are skipped and counted.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from auvlink.pipeline.engine_config import EngineConfig

TURN_WINDOW_S = 0.5  # s: the heading rate of a frame is its heading change over this time before it

F64 = npt.NDArray[np.float64]


class Navigation(Protocol):
    def covered(self, t: F64) -> npt.NDArray[np.bool_]: ...

    def pose_at(self, t: F64) -> tuple[F64, Rotation]: ...


def turn_rate(nav: Navigation, times: F64, rot: Rotation) -> F64:
    """|heading rate| (rad/s) at ``times`` (s) whose attitudes are ``rot``: the heading change over the
    ``TURN_WINDOW_S`` before each (0 where the navigation does not reach that far back)."""
    earlier = times - TURN_WINDOW_S
    known = nav.covered(earlier)
    rate = np.zeros(times.size)
    if known.any():
        _, r0 = nav.pose_at(earlier[known])
        d = rot[known].as_euler("ZYX")[:, 0] - r0.as_euler("ZYX")[:, 0]
        rate[known] = np.abs((d + np.pi) % (2 * np.pi) - np.pi) / TURN_WINDOW_S
    return rate


def survey_frames(nav: Navigation, times: F64, config: EngineConfig, counts: dict[str, int]) -> npt.NDArray[np.bool_]:
    """Mask of the frames at ``times`` (mission s) to reconstruct; adds to ``counts`` the frames without navigation
    (``frames_without_navigation``), pitched past ``max_pitch_deg`` (``frames_pitched``) and turning faster than
    ``max_turn_rate_deg_s`` (``frames_turning``)."""
    ok = nav.covered(times)
    counts["frames_without_navigation"] = counts.get("frames_without_navigation", 0) + int((~ok).sum())
    if ok.any():
        _, rot = nav.pose_at(times[ok])
        steep = np.abs(rot.as_euler("ZYX")[:, 1]) > np.radians(config.max_pitch_deg)
        counts["frames_pitched"] = counts.get("frames_pitched", 0) + int(steep.sum())
        turning = turn_rate(nav, times[ok], rot) > np.radians(config.max_turn_rate_deg_s)
        turning &= ~steep
        counts["frames_turning"] = counts.get("frames_turning", 0) + int(turning.sum())
        ok[np.flatnonzero(ok)[steep | turning]] = False
    return np.asarray(ok, dtype=bool)
