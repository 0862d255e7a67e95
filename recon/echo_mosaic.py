"""How much brighter than the seabed each patch of it echoes: a mosaic of the seabed band, for placing objects.

Beyond the seabed onset the sonar sees the seabed and whatever lies on it through the same part of its beam at a
given range, so a reflector's grey level there, less the level of the seabed across the fan at that range (the
median over the beams of the range row: an object fills a few beams, the seabed the rest), is how much brighter
it echoes than the seabed (grey levels: dB on the log display; pattern, gain, TVG and spreading cancel). That is
what :mod:`recon.pattern_fall` needs to place its highlight returns, which are seen before the onset through the
pattern's tail, where its brightness cannot be read (the column behind a return holds the object's top at grazing
incidence, dimmer than its face).

:class:`EchoMosaic` averages those excesses per horizontal cell of the world (``CELL_M``, the cells of
:class:`recon.seabed_texture.SeabedCells`) over every frame that saw the cell: per frame, blocks of the image beyond
each beam's onset (half a cell of range x :data:`BEAM_BLOCK` beams, their brightest pixel: few positions to
compute, a reflector in part of a block still counted), each placed where its range meets the seabed plane the
onset stage predicts with (its elevation solved as in :func:`recon.beam_edge.frame_edges`).
:meth:`EchoMosaic.excess` gives a finalized object its brightness: the brightest cell mean (of :data:`MIN_LOOKS`
blocks or more) over its points' box widened by :data:`LAYOVER_M` (an object's echo, placed on the seabed plane at
its range, lands nearer the sonar than its footprint).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from recon.beam_edge import plane_elevation, plane_terms
from recon.seabed_texture import SeabedCells
from recon.sonar_geometry import SonarGeometry
from recon.target_envelope import CLUSTER_BLUR_M

F64 = NDArray[np.float64]

#: m: mosaic cell (the texture grid's half: recon.seabed_texture.TextureConfig.cell is 0.5 m; the smallest object
#: spans at least two of them across, recon.target_envelope.LOWEST_OBJECT_M's half pipe 0.6 m wide)
CELL_M = 0.25
#: beams per image block: the across-fan resolution of the densest fans (0.3 deg) is 2.6 cm per beam at
#: 5 m, so two beams stay well inside a cell at the ranges objects are seen
BEAM_BLOCK = 2
#: blocks a cell needs to count (one block holds the speckle of a single ping)
MIN_LOOKS = 3
#: m the object's box is widened by: the cluster blur's half (recon.target_envelope.CLUSTER_BLUR_M: the drift
#: between passes), which also holds the layover of a 0.5 m high top seen at 35 deg (0.7 m)
LAYOVER_M = 0.5 * CLUSTER_BLUR_M


class EchoMosaic:
    """Per-cell mean excess of the seabed band's echo over its range row's level (module docstring)."""

    def __init__(self, cell: float = CELL_M) -> None:
        self.cells = SeabedCells(cell)

    def add(self, images: NDArray[np.uint8], geometry: SonarGeometry, onset: F64, pos: F64, rot: Rotation,
            point: F64, normal: F64) -> None:
        """Take frames (F, bins, beams) with each beam's onset range (F, beams, m), the poses and the seabed plane
        each frame was predicted with (``point``, unit ``normal`` into the water, (F, 3) each)."""
        f, n_bins, n_beams = images.shape
        rb = max(1, round(0.5 * self.cells.cell / geometry.bin_size))
        nr, nb = n_bins // rb, n_beams // BEAM_BLOCK
        if f == 0 or nr == 0 or nb == 0:
            return
        cut = images[:, : nr * rb, : nb * BEAM_BLOCK].reshape(f, nr, rb, nb, BEAM_BLOCK)
        blocks = cut.max(axis=(2, 4)).astype(np.float64)  # each block's brightest pixel: a reflector in part of it
        excess = blocks - np.median(blocks, axis=2, keepdims=True)  # (F, R, B): over the row's level across the fan
        r = geometry.ranges[: nr * rb].reshape(nr, rb).mean(axis=1)  # (R,)
        az = geometry.azimuths[: nb * BEAM_BLOCK].reshape(nb, BEAM_BLOCK).mean(axis=1)  # (B,)
        first = onset[:, : nb * BEAM_BLOCK].reshape(f, nb, BEAM_BLOCK).max(axis=2)  # (F, B): past every beam's onset
        height, a, b = plane_terms(geometry, rot, pos, point, normal, az)
        g = height[:, None, None] / r[None, :, None]  # (F, R, 1)
        beyond = (r[None, :, None] >= first[:, None, :]) & (g <= np.hypot(a, b)[:, None, :]) & np.isfinite(g)
        fi, ri, bi = np.nonzero(beyond)
        if fi.size == 0:
            return
        phi = plane_elevation(a[fi, bi], b[fi, bi], g[fi, ri, 0])
        dirs = geometry.directions_body(phi, az[bi])  # (n, 3) in B
        p_b = r[ri, None] * dirs + geometry.mounting.lever
        world = np.einsum("nij,nj->ni", rot.as_matrix().reshape(-1, 3, 3)[fi], p_b) + pos[fi]
        self.cells.add(np.column_stack([world[:, :2], excess[fi, ri, bi]]))

    def excess(self, points: F64) -> float:
        """An object's brightness over the seabed (grey levels) from its points (N, 3): the brightest cell mean
        over their box widened by :data:`LAYOVER_M`; NaN where no cell there has :data:`MIN_LOOKS` looks."""
        p = np.asarray(points, np.float64).reshape(-1, 3)
        if p.shape[0] == 0 or len(self.cells) == 0:
            return float("nan")
        _, sums = self.cells.grid(p[:, :2].min(axis=0) - LAYOVER_M, p[:, :2].max(axis=0) + LAYOVER_M)
        seen = sums[..., 0] >= MIN_LOOKS
        if not seen.any():
            return float("nan")
        return float((sums[..., 1][seen] / sums[..., 0][seen]).max())
