"""Checks of a rendered plot's pixels: a PNG that opens, of a plot's size, with data drawn in colour.

A matplotlib figure with axes, ticks and labels but no data is black, grey and white; every series the
project draws uses a colour of the tab palette (tab:blue, tab:orange, tab:green ...), so a plot whose data
was drawn has coloured pixels and an empty one has none.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

MIN_SIDE_PX = 100  # the smallest figure the reports save (dpi 90, a few inches) is several hundred px a side
SATURATION = 60  # max - min of R, G, B (0..255): grey and anti-aliased black text stay below ~30
MIN_COLOURED_PX = 50  # a single short line of 1 px width at dpi 90 is already ~100 px


def coloured_pixels(path: Path) -> int:
    """How many pixels of the image at ``path`` are coloured (not black, grey or white)."""
    with Image.open(path) as img:
        rgb = np.asarray(img.convert("RGB"), dtype=np.int16)
    return int(((rgb.max(axis=2) - rgb.min(axis=2)) > SATURATION).sum())


def assert_plot_drawn(path: Path) -> None:
    """Fail unless ``path`` is a PNG of at least MIN_SIDE_PX a side with data drawn in colour."""
    with Image.open(path) as img:
        assert img.format == "PNG", f"{path.name}: {img.format}, not a PNG"
        assert min(img.size) >= MIN_SIDE_PX, f"{path.name}: {img.size} px is too small for a plot"
    n = coloured_pixels(path)
    assert n >= MIN_COLOURED_PX, f"{path.name}: {n} coloured pixels: no data drawn"
