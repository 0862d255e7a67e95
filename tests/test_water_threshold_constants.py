"""recon.water_threshold's speckle constant is the root scipy's brentq finds (a literal keeps scipy.optimize out of
the replay's start-up)."""

from __future__ import annotations

import math

from scipy.optimize import brentq

from recon.water_threshold import LOG_SPECKLE_MAD, PFA, SPECKLE_MADS


def test_log_speckle_mad_is_brentqs_root() -> None:
    med = math.log(-math.log(0.5))
    root = brentq(lambda d: math.exp(-math.exp(med - d)) - math.exp(-math.exp(med + d)) - 0.5, 1e-9, 10.0)
    assert float(root) == LOG_SPECKLE_MAD  # bit for bit: the thresholds depend on it
    assert SPECKLE_MADS == (math.log(-math.log(PFA)) - med) / float(root)
