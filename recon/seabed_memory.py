"""The seabed samples recon has seen so far, and the seabed models it fits from them.

Two stores, both world NED m: the **plane samples** (the DVL's bottom points and the sparse sonar seabed
returns, every :data:`PLANE_FRAME_STEP`-th frame, beams :data:`PLANE_BEAM_SPACING_DEG` apart) behind the tiled planes
of :mod:`recon.seabed`, and the **texture grid** (:class:`recon.seabed_texture.SeabedCells`: per-cell sums of
the dense seabed returns, beams :data:`TEXTURE_BEAM_SPACING_DEG` apart in every frame, the DVL points, and the
highlight points where ``texture.highlights`` says so) behind :func:`recon.seabed_texture.fit_textured`.
:meth:`SeabedMemory.fit` is the model of a poll (:class:`recon.reconstructor.Reconstructor`, and
:mod:`classify.training.clutter_synth`, which runs recon's seabed removal on synthesized patches): tiled planes
from the plane samples around the box, and on them the texture grid. Memory grows with the samples kept (plane
samples are a sparse subset) and with the area surveyed (the grid's cells), not with the frames.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from auvlink.sonar import DIDSON
from recon.errors import ReconError
from recon.seabed import SeabedConfig, SeabedModel
from recon.seabed_texture import SeabedCells, TextureConfig, TexturedSeabed, fit_textured

F64 = NDArray[np.float64]

#: sonar seabed returns of every n-th frame feed the tiled planes: at the DIDSON's 10 frames/s and 1.5 m/s, a
#: row of plane samples every 0.75 m along track, far denser than the planes' 6 m tiles need
PLANE_FRAME_STEP = 5
#: ... of the beams about this far apart (deg): a sample every 1.2 deg across the fan, 0.2 m at 10 m (every 4th
#: beam of the DIDSON; :func:`beam_step`)
PLANE_BEAM_SPACING_DEG = 1.2
#: seabed returns of every frame, of the beams about this far apart (deg), feed the texture grid: 0.1 m at 10 m
#: range, finer than its 0.5 m cells (every 2nd beam of the DIDSON)
TEXTURE_BEAM_SPACING_DEG = 0.6


def beam_step(azimuths: F64, spacing_deg: float) -> int:
    """Every how many beams of a fan (azimuths in rad, port first) samples lie ``spacing_deg`` apart: the spacing
    over the fan's mean beam spacing, rounded, at least 1 (so any beam count gives as many samples per degree)."""
    n = int(azimuths.shape[0])
    if n < 2:
        return 1
    mean_deg = float(np.degrees(abs(azimuths[-1] - azimuths[0]))) / (n - 1)
    return max(1, round(spacing_deg / mean_deg)) if mean_deg > 0 else 1


_DIDSON_AZIMUTHS = np.radians(np.asarray(DIDSON.bearings_deg, dtype=np.float64))
#: the strides on the DIDSON's fan (every 4th and every 2nd of its 96 beams): the classifier's synthesis
#: (classify.training.seabed_returns), which renders DIDSON scans, samples the seabed as recon does with them
PLANE_BEAM_STEP = beam_step(_DIDSON_AZIMUTHS, PLANE_BEAM_SPACING_DEG)
TEXTURE_BEAM_STEP = beam_step(_DIDSON_AZIMUTHS, TEXTURE_BEAM_SPACING_DEG)


class SeabedMemory:
    """Plane samples and texture grid (module docstring); ``texture.enabled`` False keeps no grid."""

    def __init__(self, seabed: SeabedConfig, texture: TextureConfig) -> None:
        self.seabed_config, self.texture_config = seabed, texture
        self.cells = SeabedCells(texture.cell)  # filled only with the texture grid on
        self._planes: list[F64] = []
        self.n_planes = 0  # rows in the plane samples (summing them per frame grew with the mission)
        self._cols: tuple[F64, F64, F64] | None = None  # (samples, their north, their east) for the box test

    def __bool__(self) -> bool:
        return self.n_planes > 0

    def add(self, points: ArrayLike) -> None:
        """Seabed points for both stores (the DVL's bottom points)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self.add_planes(p)
        self.add_texture(p)

    def add_planes(self, points: ArrayLike) -> None:
        """Samples for the tiled planes only."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if p.shape[0]:
            self._planes.append(p)
            self.n_planes += p.shape[0]

    def add_texture(self, points: ArrayLike) -> None:
        """Samples for the texture grid only (ignored with the grid off)."""
        if self.texture_config.enabled:
            self.cells.add(points)

    def add_highlights(self, points: ArrayLike) -> None:
        """The first returns before the onset (crests, and objects): texture samples too when ``texture.highlights``
        (off by default: :class:`recon.seabed_texture.TextureConfig`)."""
        if self.texture_config.highlights:
            self.add_texture(points)

    @property
    def points(self) -> F64:
        """Every plane sample so far (n, 3)."""
        if len(self._planes) > 1:  # keep one array: later calls do not concatenate again
            self._planes = [np.concatenate(self._planes)]
        return self._planes[0] if self._planes else np.zeros((0, 3))

    def _columns(self, sb: F64) -> tuple[F64, F64]:
        """North and east of the plane samples ``sb`` as contiguous columns (kept while ``sb`` is the same array:
        the box test of :meth:`within` reads them instead of strided rows)."""
        if self._cols is None or self._cols[0] is not sb:
            self._cols = (sb, np.ascontiguousarray(sb[:, 0]), np.ascontiguousarray(sb[:, 1]))
        return self._cols[1], self._cols[2]

    def within(self, lo: ArrayLike, hi: ArrayLike, points: F64 | None = None) -> F64 | None:
        """Plane samples (of ``points``, default all) with ``lo <= (N, E) <= hi``; None when fewer than a fit
        needs (``seabed.min_points``)."""
        sb = self.points if points is None else points
        n, e = self._columns(sb)
        (n0, e0), (n1, e1) = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        near = sb[(n >= n0) & (n <= n1) & (e >= e0) & (e <= e1)]
        return near if near.shape[0] >= self.seabed_config.min_points else None

    def depth_at(self, xy: ArrayLike, radius: float = 8.0) -> F64:
        """Depth (m, NED) of the seabed fitted under each horizontal position ``xy`` ``(n, 2)`` from the plane
        samples within ``radius`` m; NaN where there are too few."""
        q = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        out = np.full(q.shape[0], np.nan)
        if q.shape[0] == 0 or self.n_planes < self.seabed_config.min_points:
            return out
        sb = self.points
        for i, c in enumerate(q):  # one small fit per object (a handful per poll)
            near = self.within(c - radius, c + radius, sb)
            if near is None:
                continue
            try:
                out[i] = float(SeabedModel.fit(near, self.seabed_config).depth_at(c[None])[0])
            except ReconError:
                continue
        return out

    def fit(self, lo: F64, hi: F64) -> TexturedSeabed | SeabedModel | None:
        """The seabed over the box ``lo``-``hi`` (north, east m): tiled planes from the plane samples within two
        tiles of it and, with the grid on, the texture grid over the box and ``context_m`` around it; None when
        too few samples lie there."""
        pad = self.seabed_config.tile * 2.0
        near = self.within(lo - pad, hi + pad)
        if near is None:
            return None
        try:
            coarse = SeabedModel.fit(near, self.seabed_config)
        except ReconError:
            return None
        tc = self.texture_config
        if not tc.enabled:
            return coarse
        m = max(tc.context_m, tc.window_m + tc.cell)
        return fit_textured(self.cells, coarse, lo - m, hi + m, tc)
