"""recon.exact_stats: the same bits as numpy's median and nanpercentile, on recon's inputs and on any floats."""

from __future__ import annotations

import warnings

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from recon.exact_stats import (
    NETWORK_MAX,
    masked_percentile,
    median_mad_u8,
    median_stack_u8,
    median_u8,
    split_medians_halves,
)

shapes = st.tuples(st.integers(1, 5), st.integers(1, 40))


@settings(max_examples=200, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 4), st.integers(0, 6), st.integers(1, 50))))
def test_byte_medians_are_numpys(x: np.ndarray) -> None:
    ref = np.median(x.astype(np.float64), axis=-1)
    np.testing.assert_array_equal(median_u8(x), ref)
    med, mad = median_mad_u8(x)
    np.testing.assert_array_equal(med, ref)
    np.testing.assert_array_equal(mad, np.median(np.abs(x - ref[..., None]), axis=-1))


def test_byte_medians_every_length() -> None:
    """Every last-axis length on both sides of NETWORK_MAX (the sorting network and the radix sort), with ties."""
    rng = np.random.default_rng(2)
    for n in range(1, NETWORK_MAX + 12):
        for shape in ((n,), (7, n), (3, 0, n), (2, 5, n)):
            x = rng.integers(0, 256, shape).astype(np.uint8)
            x[..., ::3] = x[..., ::3] // 64 * 64
            np.testing.assert_array_equal(median_u8(x), np.median(x.astype(np.float64), axis=-1))


@settings(max_examples=200, deadline=None)
@given(arrays(np.uint8, st.tuples(st.integers(1, 13), st.integers(0, 6), st.integers(1, 20))))
def test_stack_medians_are_numpys(x: np.ndarray) -> None:
    np.testing.assert_array_equal(median_stack_u8(list(x)), np.median(x, axis=0))


@settings(max_examples=200, deadline=None)
@given(st.data(), st.tuples(st.integers(1, 30), st.integers(1, 12)))
def test_split_medians_are_numpys(data: st.DataObject, shape: tuple[int, int]) -> None:
    x = data.draw(arrays(np.int16, shape, elements=st.integers(0, 510))).astype(np.float32) / 2
    first = data.draw(arrays(np.bool_, shape))
    if first.all() or not first.any():
        return
    assert split_medians_halves(x, first) == (float(np.median(x[first])), float(np.median(x[~first])))


@settings(max_examples=300, deadline=None)
@given(st.data(), shapes, st.sampled_from([5.0, 50.0, 90.0, 37.3, 0.0, 100.0]))
def test_masked_percentile_is_nanpercentile(data: st.DataObject, shape: tuple[int, int], pct: float) -> None:
    finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
    x = data.draw(arrays(np.float64, shape, elements=finite))
    valid = data.draw(arrays(np.bool_, shape))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows
        ref = np.nanpercentile(np.where(valid, x, np.nan), pct, axis=1)
    np.testing.assert_array_equal(masked_percentile(x, valid, pct), ref)


def test_grey_level_profiles() -> None:
    """Recon's case: medians of grey-level profiles (multiples of 1/2) over a prefix or suffix of each row."""
    rng = np.random.default_rng(5)
    prof = rng.integers(0, 256, (50, 300)) / 2.0
    h = rng.integers(0, 300, 50)
    prefix = np.arange(300)[None, :] < h[:, None]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for mask, pct in ((prefix, 50.0), (~prefix, 90.0)):
            np.testing.assert_array_equal(masked_percentile(prof, mask, pct),
                                          np.nanpercentile(np.where(mask, prof, np.nan), pct, axis=1))
