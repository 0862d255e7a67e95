"""Medians and percentiles equal to numpy's, bit for bit, computed faster for recon's per-frame statistics.

- Over the last axis of uint8 stacks (:func:`median_u8`, :func:`median_mad_u8`): a stable sort of 8- or 16-bit
  integers is a radix sort in numpy, while ``np.median`` of float64 partitions. The answers are exact: the median of
  integers is a multiple of 1/2 and the median of their absolute deviations from it a multiple of 1/4. A short last
  axis (up to :data:`NETWORK_MAX`) goes through a sorting network instead (Batcher's odd-even merge sort, only the
  comparators the two middle outputs depend on), each comparator an element-wise minimum and maximum over whole
  planes of the stack, where the radix sort loops over its many short rows one at a time.
- Across a stack of equal-shape uint8 arrays (:func:`median_stack_u8`): an odd-even transposition sort by
  element-wise minima and maxima (k rounds over k arrays), each step one pass over whole arrays, where ``np.median``
  over the stack's first axis partitions every element's few values one lane at a time.
- Of grey levels that are medians of bytes (multiples of 1/2, :func:`split_medians_halves`): one count of twice
  their values (511 levels) per group, each median read off its cumulative counts.
- Per row over a mask (:func:`masked_percentile`): ``np.nanpercentile(np.where(valid, x, nan), q, axis=1)`` in one
  sort instead of one Python-level call per row, with numpy's "linear" method's own arithmetic (virtual index
  ``(m - 1) q``, its two neighbours, numpy's two-sided lerp).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

#: the longest last axis whose median :func:`median_u8` takes through the sorting network: on recon's (64, 512, 32)
#: stacks of central beams the network takes 0.9 ms to the radix sort's 4.3 ms, on (64, 387, 96) rows of the whole fan
#: 6.1 ms to its 4.9 ms (this 2-core machine, numpy 2)
NETWORK_MAX = 48


@functools.cache
def _median_network(n: int) -> tuple[tuple[int, int], ...]:
    """The comparators (low wire, high wire), in order, of Batcher's odd-even merge sort of ``n`` wires (comparators
    past the last wire dropped: as if padded with maxima) that the middle two outputs depend on."""
    pairs: list[tuple[int, int]] = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    need, keep = {(n - 1) // 2, n // 2}, []
    for lo, hi in reversed(pairs):  # backwards: a comparator counts when a needed wire leaves it
        if lo in need or hi in need:
            keep.append((lo, hi))
            need |= {lo, hi}
    return tuple(reversed(keep))


def _middle_sum(sorted_last: NDArray[np.integer]) -> NDArray[np.int32]:
    """Sum of the two middle values (the one middle value twice for an odd count) along the sorted last axis."""
    n = sorted_last.shape[-1]
    return sorted_last[..., (n - 1) // 2].astype(np.int32) + sorted_last[..., n // 2]


def _twice_median_u8(x: NDArray[np.uint8]) -> NDArray[np.int32]:
    """Twice the median along the last axis of a uint8 array (an integer, 0..510)."""
    n = x.shape[-1]
    if n > NETWORK_MAX:
        return _middle_sum(np.sort(x, axis=-1, kind="stable"))
    w = list(np.asarray(x, np.uint8).reshape(-1, n).T.copy())  # n contiguous planes, one per wire
    for lo, hi in _median_network(n):
        low = np.minimum(w[lo], w[hi])
        np.maximum(w[lo], w[hi], out=w[hi])
        w[lo] = low
    return (w[(n - 1) // 2].astype(np.int32) + w[n // 2]).reshape(x.shape[:-1])


def median_u8(x: NDArray[np.uint8]) -> F64:
    """``np.median(x, axis=-1)`` of a uint8 array (float64; the last axis must not be empty)."""
    return _twice_median_u8(x).astype(np.float64) / 2.0


def median_mad_u8(x: NDArray[np.uint8]) -> tuple[F64, F64]:
    """``np.median(x, axis=-1)`` and the median of ``|x - median|`` along the last axis (float64 each).

    One sort: the ``j`` values nearest the median are ``j`` consecutive values of the sorted row, so the ``j``-th
    smallest deviation is the least, over those windows, of the larger deviation at a window's two ends (in twice
    the grey levels, integers: exact). Along the windows the lower end's deviation never grows and the upper end's
    never falls, so that least is at the first window whose ends sum to at least twice the median (the upper end's
    deviation there) or at the window before it (the lower end's)."""
    n = x.shape[-1]
    s = np.sort(x, axis=-1, kind="stable")
    twice_med = _middle_sum(s)  # 0..510
    s16 = s.astype(np.int16)
    m = twice_med.astype(np.int16)[..., None]
    never = np.int16(1024)  # above any deviation (twice the grey levels: 0..510)
    dev_sum = np.zeros(twice_med.shape, np.int32)  # the two middle deviations (twice the grey levels), summed
    for j in ((n - 1) // 2 + 1, n // 2 + 1):
        w = n - j + 1  # windows of j sorted values
        upper = np.add(s16[..., :w], s16[..., j - 1 :]) >= m  # False then True along the windows
        c = np.where(upper[..., -1], np.argmax(upper, axis=-1), w)[..., None]  # the first window of upper ends
        low = m - 2 * np.take_along_axis(s16, np.maximum(c - 1, 0), axis=-1)
        high = 2 * np.take_along_axis(s16, np.minimum(c + j - 1, n - 1), axis=-1) - m
        dev_sum += np.minimum(np.where(c >= 1, low, never), np.where(c < w, high, never))[..., 0]
    return twice_med.astype(np.float64) / 2.0, dev_sum.astype(np.float64) / 4.0


def median_stack_u8(arrays: Sequence[NDArray[np.uint8]]) -> F64:
    """``np.median(np.stack(arrays), axis=0)`` of one or more equal-shape uint8 arrays (float64; module docstring):
    the middle two of each element's sorted values averaged, exact (a multiple of 1/2)."""
    s = [np.array(a, dtype=np.uint8) for a in arrays]  # copies, sorted in place across the list
    k = len(s)
    if k == 0:
        raise ValueError("median of no arrays")
    for r in range(k):  # odd-even transposition: after k rounds the list is sorted element by element
        for i in range(r % 2, k - 1, 2):
            lo = np.minimum(s[i], s[i + 1])
            np.maximum(s[i], s[i + 1], out=s[i + 1])
            s[i] = lo
    return (s[(k - 1) // 2].astype(np.float64) + s[k // 2]) / 2.0


def split_medians_halves(x: NDArray[np.floating], first: NDArray[np.bool_]) -> tuple[float, float]:
    """``np.median(x[first])`` and ``np.median(x[~first])`` (module docstring) of ``x`` in 0..255 in steps of 1/2
    (medians of uint8 values: :func:`median_stack_u8`), ``first`` of its shape; neither part may be empty."""
    keys = (np.asarray(x) * 2).astype(np.intp) + np.where(first, 0, 511)
    counts = np.bincount(keys.ravel(), minlength=1022).reshape(2, 511)
    out = []
    for c in counts:
        cum, n = np.cumsum(c), int(c.sum())
        lo, hi = np.searchsorted(cum, [(n - 1) // 2, n // 2], side="right")  # the two middle values' twice
        out.append((int(lo) + int(hi)) / 4.0)
    return out[0], out[1]


def masked_percentile(x: F64, valid: NDArray[np.bool_], pct: float) -> F64:
    """Per row of (R, n) ``x``, the ``pct`` percentile of the entries where ``valid`` (numpy's "linear" method,
    as ``np.nanpercentile`` of the others set to NaN); NaN for rows with none."""
    q = np.true_divide(pct, 100)
    m = valid.sum(axis=1)
    s = np.sort(np.where(valid, x, np.inf), axis=1)
    virtual = (m - 1) * q
    prev = np.floor(virtual).astype(np.intp)
    nxt = np.minimum(prev + 1, m - 1)
    prev, nxt = np.clip(prev, 0, None), np.clip(nxt, 0, None)
    a = np.take_along_axis(s, prev[:, None], axis=1)[:, 0]
    b = np.take_along_axis(s, nxt[:, None], axis=1)[:, 0]
    t = virtual - np.floor(virtual)
    with np.errstate(invalid="ignore", over="ignore"):  # rows with no entry: inf - inf, replaced by NaN below
        diff = b - a
        out = np.where(t >= 0.5, b - diff * (1 - t), a + diff * t)
    return np.where(m > 0, out, np.nan)
