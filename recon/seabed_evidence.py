"""Recon's seabed stage: what a batch of frames tells about the seabed, into :class:`recon.seabed_memory.SeabedMemory`.

Three kinds of evidence, all world NED m: the DVL's bottom points (pulled from the pose source: a navigator's
``take_seabed_points`` up to the batch's last frame, or a trajectory's ``seabed_points`` once), the sonar's
seabed returns at the onset (:func:`add_seabed_returns`: beams :data:`~recon.seabed_memory.TEXTURE_BEAM_SPACING_DEG`
apart into the texture grid, beams :data:`~recon.seabed_memory.PLANE_BEAM_SPACING_DEG` apart of every
:data:`~recon.seabed_memory.PLANE_FRAME_STEP`-th frame into the tiled planes' samples) and the highlight points
(the texture grid: seabed the onset search put before the onset).
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from recon.highlight import project
from recon.onset_stage import FrameOnsets
from recon.seabed_band import BandConfig
from recon.seabed_memory import (
    PLANE_BEAM_SPACING_DEG,
    PLANE_FRAME_STEP,
    TEXTURE_BEAM_SPACING_DEG,
    SeabedMemory,
    beam_step,
)
from recon.sonar_geometry import SonarGeometry

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


@runtime_checkable
class StreamingSeabedSource(Protocol):
    """A navigator that hands out the DVL's seabed points as they come (:class:`recon.nav_stream.CausalNavigator`)."""

    def take_seabed_points(self, until: float = np.inf, max_pitch: float = np.inf) -> F64: ...


@runtime_checkable
class BatchSeabedSource(Protocol):
    """A whole trajectory's DVL seabed points at once (:class:`recon.trajectory.Trajectory`)."""

    def seabed_points(self) -> F64: ...


def pull_dvl_points(poses: object, until: float, max_pitch: float) -> F64 | None:
    """The DVL seabed points ``poses`` has for frames up to ``until`` (s) that recon has not taken yet, leaving out
    those while the vehicle pitched more than ``max_pitch`` (rad); None from a source that streams none."""
    if isinstance(poses, StreamingSeabedSource):
        return poses.take_seabed_points(until=until, max_pitch=max_pitch)
    return None


def initial_dvl_points(poses: object, seabed_points: ArrayLike | None) -> ArrayLike | None:
    """``seabed_points`` when given, else all of a trajectory's DVL seabed points (None for a streaming source)."""
    if seabed_points is None and isinstance(poses, BatchSeabedSource):
        return poses.seabed_points()
    return seabed_points


def add_seabed_returns(memory: SeabedMemory, geometry: SonarGeometry, band: BandConfig, margin_m: float,
                       texture: bool, frames_before: int, onsets: FrameOnsets, returns: tuple[I64, I64, I64],
                       pos: F64, rot: Rotation) -> None:
    """The seabed returns of a batch (``onsets.seabed``) as seabed samples (module docstring). Left out: returns
    more than ``band.sample_lead_m`` before the corrected onset (an object's front, a high crest) and columns
    whose highlight return ``returns`` (frame, beam, row) came before the seabed return (the seabed return is then
    not the column's first: it lies under the seabed). ``frames_before`` numbers the batch's frames for the
    every-n-th-frame choice; ``texture`` False feeds no texture grid."""
    sf, sb, sr = onsets.seabed
    if sf.size == 0:
        return
    fi, bi, ri = returns
    onset = onsets.onset
    first = np.full((onset.shape[0], geometry.n_beams), geometry.n_bins, np.int64)
    first[fi, bi] = ri
    near = geometry.ranges[sr] >= onset[sf, sb] - margin_m - band.sample_lead_m
    ok = near & (first[sf, sb] >= sr)
    sf, sb, sr = sf[ok], sb[ok], sr[ok]
    every_frame = (frames_before + np.arange(onset.shape[0])) % PLANE_FRAME_STEP == 0
    dense = (sb % beam_step(geometry.azimuths, TEXTURE_BEAM_SPACING_DEG) == 0) & texture
    sparse = (sb % beam_step(geometry.azimuths, PLANE_BEAM_SPACING_DEG) == 0) & every_frame[sf]
    keep = dense | sparse
    sp = project(geometry, sf[keep], sb[keep], sr[keep], pos, rot, "exact")
    memory.add_texture(sp[dense[keep]])
    memory.add_planes(sp[sparse[keep]])
