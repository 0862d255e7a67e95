"""Sonar frames for viewers: every ``every_s`` of mission time one frame rendered as a fan picture (PNG),
its highlight returns marked, kept for ``results.mcap`` (:mod:`auvlink.pipeline.results_mcap`).

The picture is the fan of :mod:`logs_format.fan` (x starboard, y forward in the sonar's plane, far
range at the top, square pixels) at most ``height_px`` pixels high, a palette PNG: grey levels
0..254 through the inferno colour map (255 shown as 254), the inferno black outside the fan; each
highlight-extension return (the first return above the expected seabed of a beam,
:attr:`recon.reconstructor.Reconstructor.last_returns`) is a cyan cross (palette index 255).
Memory stays bounded: past ``max_frames`` every other kept frame is dropped and the interval doubles.
A recorder is an engine ``on_frames`` observer (:class:`auvlink.pipeline.engine.Engine`).
"""

from __future__ import annotations

import io
import math

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from auvlink.pipeline.fan_palette import palette
from auvlink.pipeline.results import FanFrame
from logs_format.fan import FanGrid, fan_grid, render_fan
from recon.sonar_geometry import SonarGeometry

MARK = (0, 255, 255)  # cyan, palette index 255
_CROSS = ((0, 0), (-1, 0), (1, 0), (0, -1), (0, 1))


def _lut() -> NDArray[np.uint8]:
    """The palette: inferno for 0..254, :data:`MARK` at 255 (256 x 3 uint8; :mod:`auvlink.pipeline.fan_palette`)."""
    return palette(MARK)


def fan_px_per_m(geometry: SonarGeometry, height_px: int) -> float:
    """Pixels per metre that make the fan ``height_px`` high (or the range-bin size, if finer)."""
    r0, r1 = float(geometry.ranges.min()), float(geometry.ranges.max())
    a = np.abs(geometry.azimuths).max(initial=0.0)
    depth = max(r1 - r0 * math.cos(a), 1e-3)
    return min(height_px / depth, 1.0 / max(geometry.bin_size, 1e-6))


def returns_pixels(grid: FanGrid, ranges: NDArray[np.float64], azimuths: NDArray[np.float64],
                   beams: NDArray[np.int64], rows: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Picture (row, column) of the cells (range row, beam) of one frame."""
    r, th = ranges[rows], azimuths[beams]
    x, y = r * np.sin(th), r * np.cos(th)
    col = np.floor((x - grid.x_min) * grid.px_per_m).astype(np.int64)
    row = np.floor((grid.y_max - y) * grid.px_per_m).astype(np.int64)
    return row, col


def render_png(image: NDArray[np.uint8], grid: FanGrid, lut: NDArray[np.uint8],
               marks: tuple[NDArray[np.int64], NDArray[np.int64]] | None = None) -> bytes:
    """The fan picture of ``image`` as a palette PNG (``lut``: :func:`_lut`), ``marks`` (picture rows,
    columns) as crosses."""
    fan = render_fan(image, grid)
    idx = np.minimum(np.asarray(fan.filled(0), dtype=np.uint8), 254)
    idx[~grid.inside] = 0
    if marks is not None and marks[0].size:
        h, w = grid.rows.shape
        for dr, dc in _CROSS:
            rr, cc = marks[0] + dr, marks[1] + dc
            ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
            idx[rr[ok], cc[ok]] = 255
    pic = Image.frombytes("P", (idx.shape[1], idx.shape[0]), np.ascontiguousarray(idx).tobytes())
    pic.putpalette(lut.reshape(-1).tolist())
    buf = io.BytesIO()
    pic.save(buf, format="PNG", compress_level=6)
    return buf.getvalue()


class FanRecorder:
    """Keeps one rendered frame every ``every_s`` s of mission time (see the module docstring)."""

    def __init__(self, every_s: float = 1.0, height_px: int = 256, max_frames: int = 2000) -> None:
        if every_s <= 0 or height_px < 16 or max_frames < 2:
            raise ValueError("every_s must be > 0, height_px >= 16, max_frames >= 2")
        self.every_s = every_s
        self.height_px = height_px
        self.max_frames = max_frames
        self.frames: list[FanFrame] = []
        self._next = -math.inf
        self._grid: tuple[bytes, FanGrid] | None = None
        self._lut = _lut()  # now: live makes its recorder before the ports open (no stall on the first frame)

    def _grid_for(self, g: SonarGeometry) -> FanGrid:
        key = g.ranges.tobytes() + g.azimuths.tobytes()
        if self._grid is None or self._grid[0] != key:
            self._grid = (key, fan_grid(g.ranges, g.azimuths, fan_px_per_m(g, self.height_px)))
        return self._grid[1]

    def __call__(self, geometry: SonarGeometry, times: NDArray[np.float64], images: NDArray[np.uint8],
                 returns: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]) -> None:
        fi, bi, ri = returns
        for k, t in enumerate(np.asarray(times, dtype=np.float64)):
            if t < self._next:
                continue
            self._next = float(t) + self.every_s
            grid = self._grid_for(geometry)
            sel = fi == k
            marks = returns_pixels(grid, geometry.ranges, geometry.azimuths, bi[sel], ri[sel])
            self.frames.append(FanFrame(float(t), render_png(images[k], grid, self._lut, marks), int(sel.sum())))
            if len(self.frames) > self.max_frames:
                self.frames = self.frames[::2]
                self.every_s *= 2
