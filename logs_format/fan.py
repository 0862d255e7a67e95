"""Sonar image (range bin x beam) -> fan-shaped picture with correct range/azimuth geometry.

A return at range r and azimuth theta (+ to starboard) lies at x = r sin(theta) (starboard) and
y = r cos(theta) (forward) in the sonar's horizontal plane. The picture is a grid of square pixels
in (x, y), far range at the top; each pixel takes the nearest range bin and the nearest beam of
the device's own beam-angle table. The pixel -> (row, column) lookup is computed once per
geometry and reused for every frame of a channel.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from logs_format.profile import LogError

_RANGE_NAMES = ("ranges", "ranges_m", "range_m", "range")
_AZIMUTH_NAMES = ("azimuths", "azimuths_rad", "bearings_rad", "azimuth", "beam_angles", "beam_angles_rad")


def _attr(record: Any, names: tuple[str, ...]) -> np.ndarray | None:
    for name in names:
        value = getattr(record, name, None)
        if value is not None:
            return np.asarray(value() if callable(value) else value, dtype=np.float64)
    return None


def sonar_geometry(record: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(image[range, beam], ranges_m, azimuths_rad)`` of a decoded sonar frame, or None."""
    image = getattr(record, "image", None)
    if image is None:
        return None
    image = np.asarray(image)
    if image.ndim != 2:
        return None
    ranges = _attr(record, _RANGE_NAMES)
    azimuths = _attr(record, _AZIMUTH_NAMES)
    if ranges is None or azimuths is None:
        return None
    if ranges.shape != (image.shape[0],) or azimuths.shape != (image.shape[1],):
        raise LogError(f"sonar geometry {ranges.shape}/{azimuths.shape} does not fit image {image.shape}")
    return image, ranges, azimuths


@dataclass(frozen=True)
class FanGrid:
    """The lookup from picture pixels to image cells, and the picture's extent in metres."""

    rows: np.ndarray  # (H, W) range-bin index per pixel (-1 outside the fan)
    cols: np.ndarray  # (H, W) beam index per pixel
    x_min: float
    x_max: float
    y_min: float
    y_max: float
    px_per_m: float

    @property
    def inside(self) -> np.ndarray:
        return self.rows >= 0

    def describe(self) -> str:
        return (f"fan image: x (starboard) {self.x_min:.3f}..{self.x_max:.3f} m, "
                f"y (forward) {self.y_min:.3f}..{self.y_max:.3f} m, {self.px_per_m:.3f} px/m, "
                "far range at top")


def fan_grid(ranges: np.ndarray, azimuths: np.ndarray, px_per_m: float | None = None) -> FanGrid:
    """The pixel lookup for a frame geometry (about one pixel per range bin by default)."""
    r0, r1 = float(ranges.min()), float(ranges.max())
    a0, a1 = float(azimuths.min()), float(azimuths.max())
    n = len(ranges)
    dr = (r1 - r0) / max(n - 1, 1) if n > 1 else 1.0
    dr = dr or 1.0
    if px_per_m is None:
        px_per_m = 1.0 / dr
    x_min = min(r1 * np.sin(a0), r0 * np.sin(a0))
    x_max = max(r1 * np.sin(a1), r0 * np.sin(a1))
    y_min = r0 * min(np.cos(a0), np.cos(a1))
    y_max = r1 if a0 <= 0 <= a1 else r1 * max(np.cos(a0), np.cos(a1))
    w = max(1, int(np.ceil((x_max - x_min) * px_per_m)))
    h = max(1, int(np.ceil((y_max - y_min) * px_per_m)))
    x = x_min + (np.arange(w) + 0.5) / px_per_m
    y = y_max - (np.arange(h) + 0.5) / px_per_m
    xx, yy = np.meshgrid(x, y)
    r = np.hypot(xx, yy)
    theta = np.arctan2(xx, yy)
    r_edge = dr / 2
    a_order = np.argsort(azimuths)
    a_sorted = azimuths[a_order]
    da = (a1 - a0) / max(len(azimuths) - 1, 1) / 2
    inside = (r >= r0 - r_edge) & (r <= r1 + r_edge) & (theta >= a0 - da) & (theta <= a1 + da)
    r_order = np.argsort(ranges)
    rows = r_order[_nearest(ranges[r_order], r)]
    cols = a_order[_nearest(a_sorted, theta)]
    rows = np.where(inside, rows, -1).astype(np.int32)
    cols = np.where(inside, cols, 0).astype(np.int32)
    return FanGrid(rows, cols, float(x_min), float(x_max), float(y_min), float(y_max), float(px_per_m))


def _nearest(sorted_values: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Index of the nearest value of ``sorted_values`` for each query."""
    if len(sorted_values) == 1:
        return np.zeros(q.shape, dtype=np.intp)
    i = np.clip(np.searchsorted(sorted_values, q), 1, len(sorted_values) - 1)
    left = sorted_values[i - 1]
    right = sorted_values[i]
    return np.where(np.abs(q - left) <= np.abs(right - q), i - 1, i)


def render_fan(image: np.ndarray, grid: FanGrid) -> np.ma.MaskedArray:
    """The fan picture of ``image`` (masked outside the fan)."""
    rows = np.where(grid.inside, grid.rows, 0)
    picture = image[rows, grid.cols]
    return np.ma.masked_array(picture, mask=~grid.inside)


def save_fan_png(path: str | Path, image: np.ndarray, grid: FanGrid, vmax: float | None = None,
                 cmap: str = "inferno") -> None:
    """Write the fan picture as a PNG (matplotlib; geometry in the PNG's Description field)."""
    import matplotlib  # lazy: matplotlib loads only when a PNG is written, not with every logs_format import

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    picture = render_fan(image, grid).astype(np.float64)
    top = float(vmax if vmax is not None else max(float(np.max(image)), 1.0))
    cm = plt.get_cmap(cmap).with_extremes(bad="black")
    plt.imsave(str(path), picture, cmap=cm, vmin=0.0, vmax=top, origin="upper",
               metadata={"Description": grid.describe()})
