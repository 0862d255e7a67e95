"""The fan pictures' palette constant is matplotlib's inferno, sampled as the report always did."""

from __future__ import annotations

import numpy as np
from matplotlib import colormaps

from auvlink.pipeline.fan_frames import MARK, _lut


def test_palette_is_matplotlibs_inferno() -> None:
    ref = (np.asarray(colormaps["inferno"](np.linspace(0.0, 1.0, 255)))[:, :3] * 255).round().astype(np.uint8)
    lut = _lut()
    assert lut.shape == (256, 3) and lut.dtype == np.uint8
    assert np.array_equal(lut[:255], ref)
    assert tuple(lut[255]) == MARK
