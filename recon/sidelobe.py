"""The sidelobe rule: a return far below the strongest return of its range row is that return's sidelobe.

A forward-scan sonar forms each beam with sidelobes: a strong return (an object's face, a bright seabed patch)
shows in every other beam of the fan at the same range, as an arc a sidelobe level below it (two-way -20 to -35 dB
for DIDSON, ARIS and Oculus lenses and arrays), smeared over the pulse length in range. In the beams beside the
object that arc stands above a dark water column and would be taken for a first return. The rule: per frame and
range row, the threshold is at least the strongest pixel of that row and its neighbours (:data:`SMEAR_ROWS`, the
pulse's smear) less the sidelobe margin, the sidelobe level in grey levels of the log display
(:func:`margin_levels`). A return within the margin of the strongest one is kept: it is brighter than any
sidelobe of it, so it is an echo of its own.

A strong return's smear in its own beam (the pulse, 1-4 bins) lies after it in range, so the first return of that
column (recon.highlight) is the echo's start; the smear adds no point.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

#: rows on each side of a row whose strongest pixel it takes: the pulse's smear of a strong return (1-4 bins of a
#: 512-bin window, issue 36's pulse range) spreads its sidelobe arc over the rows after it
SMEAR_ROWS = 2


def margin_levels(sidelobe_db: float, display_range_db: float) -> float:
    """The sidelobe margin in grey levels: ``|sidelobe_db|`` (two-way sidelobe level, dB re the main lobe) on an
    8-bit log display spanning ``display_range_db`` dB over 255 levels."""
    return 255.0 * abs(float(sidelobe_db)) / float(display_range_db)


def row_peaks(images: NDArray[np.uint8], n_rows: int) -> F64:
    """(F, n_rows) the strongest pixel across the fan of each of the first ``n_rows`` rows of a stack (F, bins,
    beams), over that row and the :data:`SMEAR_ROWS` before it (a strong return's arc smears after it in range)."""
    peak = images[:, :n_rows].max(axis=2)
    out = peak.copy()
    for k in range(1, SMEAR_ROWS + 1):  # a running max over the rows before each row (SMEAR_ROWS passes)
        np.maximum(out[:, k:], peak[:, :-k], out=out[:, k:])
    return out.astype(np.float64)


def sidelobe_thresholds(thr: F64, images: NDArray[np.uint8], n_rows: int, margin: float) -> F64:
    """``thr`` (F, bins) raised, in the first ``n_rows`` rows, to each row's peak (:func:`row_peaks`) less
    ``margin`` grey levels (:func:`margin_levels`): what lies under a strong return's sidelobe arc is no return."""
    out = np.array(thr, dtype=np.float64)
    n = max(0, min(out.shape[1], int(n_rows)))
    out[:, :n] = np.maximum(out[:, :n], row_peaks(images, n) - margin)
    return out
