"""Sonar images pooled to the sampling recon works at: range rows and beams finer than that, maxed together.

A multibeam imaging sonar such as the Blueprint Oculus sends far finer images than recon needs: 512 beams at a
spacing of a quarter of their own width (M750d: 0.6 deg beams every 0.137 deg) and range lines every 2.5 mm
(4000 lines over a 10 m window), 40x the pixels of a DIDSON frame. Recon's returns, thresholds and beam-edge
estimate are defined on the image's own statistics and metric spans, so a coarser image of the same scene gives
the same points to within its sampling:

- range: groups of ``rows`` lines, so that the window holds at most :data:`MAX_RANGE_ROWS`;
- azimuth: groups of ``beams`` adjacent beams spanning no more than one beam width anywhere in the fan (beams
  closer than their own width see overlapping sectors); the group's azimuth is the mean of its beams'.

Each pooled pixel is the maximum of its group (a return's first bright line and its level survive). The last
group of an axis may be short. Pooling by (1, 1), the DIDSON's and the ARIS's case, returns the frames as they are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from recon.sonar_geometry import SonarGeometry

#: range samples per beam recon works at: the DIDSON and ARIS data sheets' 512 samples over any window
MAX_RANGE_ROWS = 512


@dataclass(frozen=True)
class ImagePooling:
    """Range lines and beams per pooled pixel of a sonar geometry (see the module docstring)."""

    rows: int = 1
    beams: int = 1

    @classmethod
    def for_geometry(cls, geometry: SonarGeometry, beam_width: float | None = None) -> ImagePooling:
        """The pooling of ``geometry``'s frames: rows to :data:`MAX_RANGE_ROWS`, beams to ``beam_width`` (rad,
        the data sheet's -3 dB width of one beam; None: beams kept)."""
        rows = max(1, math.ceil(geometry.n_bins / MAX_RANGE_ROWS))
        beams = 1
        if beam_width is not None and geometry.n_beams > 1:
            spacing = float(np.max(np.diff(geometry.azimuths)))  # a sine-law fan is sparsest at its edges
            beams = max(1, int(beam_width / spacing)) if spacing > 0 else 1
        return cls(rows, beams)

    @property
    def identity(self) -> bool:
        return self.rows == 1 and self.beams == 1

    def geometry(self, geometry: SonarGeometry) -> SonarGeometry:
        """The geometry of the pooled frames: same window start and range bin scale, pooled rows and beams."""
        if self.identity:
            return geometry
        n_rows = math.ceil(geometry.n_bins / self.rows)
        length = geometry.window_length * n_rows * self.rows / geometry.n_bins  # a short last group: same bin size
        az = _group_means(geometry.azimuths, self.beams)
        return replace(geometry, n_bins=n_rows, n_beams=az.size, window_length=length,
                       azimuth_table=tuple(float(a) for a in az))

    def apply(self, frames: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """The pooled stack (F, bins, beams) -> (F, ceil(bins / rows), ceil(beams / beams)), uint8."""
        if self.identity:
            return frames
        f, n_bins, n_beams = frames.shape
        nr, nb = math.ceil(n_bins / self.rows), math.ceil(n_beams / self.beams)
        padded = np.zeros((f, nr * self.rows, nb * self.beams), np.uint8)  # 0: below every return
        padded[:, :n_bins, :n_beams] = frames
        return np.asarray(padded.reshape(f, nr, self.rows, nb, self.beams).max(axis=(2, 4)), np.uint8)


def _group_means(azimuths: NDArray[np.float64], k: int) -> NDArray[np.float64]:
    """Means of consecutive groups of ``k`` azimuths (the last group may be short)."""
    n = azimuths.size
    starts = np.arange(0, n, k)
    return np.add.reduceat(azimuths, starts) / np.diff(np.r_[starts, n])
