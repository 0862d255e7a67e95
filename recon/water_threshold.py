"""Per range row, the grey level that the background before the seabed onset rarely exceeds (a constant false
alarm rate threshold, measured on the frames themselves).

What a column holds before its seabed onset is background: receiver noise, which grows along range with the
time-varied gain, and the seabed's faint returns through the beam's pattern beyond its edge, all under the
survey's gain and the display's floor (often most pixels at 0). None of that is known in advance, so the
threshold is measured per batch of frames, per range row, from the pixels before each column's onset pooled
over the batch's frames and beams and over :data:`POOL_ROWS` neighbouring rows (a 256-level histogram per row).

The quantile sought (a false alarm once in ``1 / PFA`` pixels) cannot be read directly: an object before the
onset fills up to a few in a thousand of those pixels. It is extrapolated from the bulk instead, with the tail of
log-compressed speckle: the display maps the echo intensity to grey levels on a dB scale, and the intensity of
fully developed speckle (and of receiver noise) is exponential, so a grey level ``g`` is exceeded with probability
``exp(-exp((g - b) / c))`` (a double-exponential tail; ``b`` the level of the mean intensity, ``c`` grey levels per
neper). ``ln(-ln(1 - q))`` is then linear in the ``q`` quantile: the 75 % and 95 % quantiles fix the line, which
is read at ``1 - PFA``. On the ARIS sample in ``../shared/data`` (100-row bands of its 6 frames, 29 k pixels each)
this extrapolation puts the 1 - 1e-3 quantile within -13..+0 grey levels of the measured one (within -4 where the
band is homogeneous), an exponential tail in grey levels 7-14 levels above it in every band. Rows with
fewer than :data:`MIN_SAMPLES` background pixels take the nearest nearer row's threshold (the background grows
along range, so that row's is the lower bound).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: rows pooled around each row (+-8: 0.33 m of a 10 m / 512-bin window, within which TVG and pattern barely change)
POOL_ROWS = 17
#: background pixels a row's quantiles need (the 99 % quantile from at least 10 pixels above it)
MIN_SAMPLES = 1000
#: the quantiles behind the extrapolation (module docstring): the bulk, clear of the few per cent of objects
Q_LOW, Q_HIGH = 0.75, 0.95
#: false alarms per background pixel: with ~300 rows x 96 beams before the onset, ~3 pixels a frame, and the return
#: rule's second bin (recon.highlight) leaves ~0.1 a frame
PFA = 1e-4
#: frames the background histogram remembers (time constant): 10 s at 10 frames/s, a pass over an object is 1-3 s
WINDOW_FRAMES = 100


def _exceeded(p: float) -> float:
    """``ln(-ln p)``: the level (nepers, above the log of the mean intensity) that log-compressed speckle exceeds
    with probability ``p`` (module docstring: ``ln E`` of an exponential ``E`` has the CDF ``1 - exp(-e^x)``)."""
    return math.log(-math.log(p))


#: nepers: the MAD of ``ln E``, ``E`` exponential (log-compressed speckle), the root ``d`` of
#: ``exp(-exp(m - d)) - exp(-exp(m + d)) = 1/2`` with ``m = ln ln 2`` as scipy's ``brentq`` finds it on [1e-9, 10]
#: (tests/test_water_threshold_constants.py solves it again; a literal keeps scipy.optimize out of start-up)
LOG_SPECKLE_MAD = 0.7670492513257081


#: MADs above the median at which log-compressed speckle is exceeded with probability PFA: ``ln(-ln PFA) -
#: ln(ln 2)`` nepers over the MAD's 0.767 nepers, 3.37 for 1e-4 (a Gaussian's 4 robust sigmas are 5.93 MADs: on a
#: 60 dB display 36 grey levels above the speckle's 1e-4 level)
SPECKLE_MADS = (_exceeded(PFA) - _exceeded(0.5)) / LOG_SPECKLE_MAD


def speckle_upper(med: F64, mad: F64) -> F64:
    """The grey level that log-compressed speckle (module docstring) of median ``med`` and MAD ``mad`` grey levels
    (any shape) exceeds with probability :data:`PFA`."""
    return np.asarray(np.asarray(med, np.float64) + SPECKLE_MADS * np.asarray(mad, np.float64), np.float64)


def _quantile_rows(cum: NDArray[np.float64], q: float) -> F64:
    """Per row, the lowest grey level whose cumulative count reaches ``q`` of the row's total."""
    total = cum[:, -1:]
    return np.asarray(np.argmax(cum >= q * total, axis=1), dtype=np.float64)


def water_histogram(images: NDArray[np.uint8], limits: I64) -> F64:
    """(bins, 256) counts of the grey levels of a batch (F, bins, beams) in rows < ``limits`` (F, beams).

    One ``bincount`` of ``row * 256 + grey`` (as numpy's index type, which ``bincount`` reads without a copy); the
    pixels at or past their beam's limit, all in the rows between the least and the greatest limit, are sent to one
    extra bin that is dropped."""
    n_bins = images.shape[1]
    n = int(np.clip(limits.max(initial=0), 0, n_bins))  # rows past every beam's limit hold no water pixel
    lo = int(np.clip(limits.min(initial=0), 0, n))  # rows before every beam's limit are water throughout
    keys = np.empty((images.shape[0], n, images.shape[2]), np.intp)
    np.add(images[:, :n], (np.arange(n, dtype=np.intp) * 256)[None, :, None], out=keys)
    past = np.arange(lo, n)[None, :, None] >= limits[:, None, :]
    keys[:, lo:n][past] = n_bins * 256
    counts = np.bincount(keys.ravel(), minlength=n_bins * 256 + 1)[: n_bins * 256]
    return counts.reshape(n_bins, 256).astype(np.float64)


def histogram_thresholds(hist: F64) -> F64:
    """(bins,) thresholds (grey levels) from per-row histograms (bins, 256) (module docstring); NaN everywhere when
    no row has enough pixels."""
    n_bins = hist.shape[0]
    half = POOL_ROWS // 2
    c = np.cumsum(np.pad(hist, ((half + 1, half), (0, 0))), axis=0)
    pooled = c[POOL_ROWS:] - c[:-POOL_ROWS]  # (bins, 256): rows within +-half
    cum = np.cumsum(pooled, axis=1)
    q_lo, q_hi = _quantile_rows(cum, Q_LOW), _quantile_rows(cum, Q_HIGH)
    y_lo, y_hi, y_pfa = _exceeded(1.0 - Q_LOW), _exceeded(1.0 - Q_HIGH), _exceeded(PFA)
    slope = np.maximum(q_hi - q_lo, 1.0) / (y_hi - y_lo)  # grey levels per unit of ln(-ln(1 - q)); >= 1 level apart
    thr = q_hi + slope * (y_pfa - y_hi)
    ok = cum[:, -1] >= MIN_SAMPLES
    if not ok.any():
        return np.full(n_bins, np.nan)
    last = np.maximum.accumulate(np.where(ok, np.arange(n_bins), -1))  # nearest nearer row with enough pixels
    first = int(np.argmax(ok))
    last = np.where(last < 0, first, last)
    return np.asarray(thr[last], dtype=np.float64)


class WaterThreshold:
    """The background histogram of the last frames (forgetting over :data:`WINDOW_FRAMES`) and its thresholds."""

    def __init__(self, n_bins: int, window: float = WINDOW_FRAMES) -> None:
        self.hist = np.zeros((n_bins, 256))
        self.window = float(window)
        #: the (bins,) thresholds of :attr:`hist` as the last :meth:`update` left it (NaN before any)
        self.thresholds = np.full(n_bins, np.nan)

    def update(self, images: NDArray[np.uint8], limits: I64) -> F64:
        """Add a batch (F, bins, beams) with its onset rows ``limits`` (F, beams); the (bins,) thresholds."""
        self.hist *= np.exp(-images.shape[0] / self.window)
        self.hist += water_histogram(images, limits)
        self.thresholds = histogram_thresholds(self.hist)
        return self.thresholds
