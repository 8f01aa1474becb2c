"""relief/order.py: percentiles found in brackets are NumPy's, bit for bit, whatever the sample."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tamp_os.relief import order
from tamp_os.relief.order import float32_keys, float32_values, percentiles

pytestmark = pytest.mark.timeout(120)

KINDS = ("uniform", "grey levels", "constant", "two populations", "sorted", "periodic", "heavy tail")


def _sample(kind: str, size: int, seed: int, dtype) -> np.ndarray:
    rng = np.random.default_rng(seed)
    if kind == "uniform":
        values = rng.random(size) * 255
    elif kind == "grey levels":  # ties everywhere, as an 8-bit picture has
        values = rng.integers(0, 256, size).astype(np.float64)
    elif kind == "constant":
        values = np.full(size, 7.0)
    elif kind == "two populations":  # a dark ground and a few bright beads
        values = np.where(rng.random(size) < 0.01, 200.0 + rng.random(size), rng.normal(20, 2, size))
    elif kind == "sorted":  # a gradient: a strided subsample is as far from random as it gets
        values = np.linspace(0, 1000, size)
    elif kind == "periodic":  # stripes with the subsample's own period
        values = (np.arange(size) % order.SUBSAMPLE).astype(np.float64)
    else:
        values = rng.standard_cauchy(size)
    return values.astype(dtype)


@settings(max_examples=60, deadline=None)
@given(kind=st.sampled_from(KINDS), size=st.one_of(st.integers(1, 100), st.integers(order.MIN_BRACKETED - 2, 300_000)), seed=st.integers(0, 2**16),
       dtype=st.sampled_from([np.float32, np.float64, np.uint16]),
       pcts=st.lists(st.floats(0.0, 100.0), min_size=1, max_size=6))
def test_the_percentiles_are_numpys_bit_for_bit(kind, size, seed, dtype, pcts):
    if dtype is np.uint16 and kind in ("heavy tail", "two populations"):
        dtype = np.float32  # negative or fractional values have no uint16 form
    sample = _sample(kind, size, seed, dtype)
    expected = np.percentile(sample, pcts)
    got = percentiles(sample, pcts)
    assert got.dtype == expected.dtype
    np.testing.assert_array_equal(got, expected)


def test_a_bracket_that_misses_its_rank_falls_back_to_the_whole_sample(monkeypatch):
    # Brackets with no margin miss their ranks: the whole sample is partitioned, the answer unchanged.
    missed = []
    whole = order.whole_partition
    monkeypatch.setattr(order, "BRACKET_DEVIATIONS", 0.0)
    monkeypatch.setattr(order, "whole_partition", lambda sample, ranks: missed.append(ranks) or whole(sample, ranks))
    sample = np.random.default_rng(3).random(200_000).astype(np.float32)
    np.testing.assert_array_equal(percentiles(sample, [2.0, 50.0, 98.0]), np.percentile(sample, [2.0, 50.0, 98.0]))
    assert missed


def test_a_large_picture_is_not_partitioned_whole(monkeypatch):
    # The point of the brackets: a picture-sized sample never takes the plain way.
    monkeypatch.setattr(order, "whole_partition", lambda sample, ranks: pytest.fail("partitioned the whole sample"))
    sample = np.random.default_rng(4).normal(100, 20, 1024 * 768).astype(np.float32)
    np.testing.assert_array_equal(percentiles(sample, [2.0, 98.0, 25.0, 50.0, 75.0]), np.percentile(sample, [2.0, 98.0, 25.0, 50.0, 75.0]))


def test_float32_keys_sort_as_the_values_and_give_them_back():
    values = np.concatenate([np.random.default_rng(3).standard_cauchy(2000), [0.0, -0.0, np.inf, -np.inf, 1e-45, -1e-45,
                                                                              np.finfo(np.float32).max]]).astype(np.float32)
    keys = float32_keys(values)
    assert keys.dtype == np.uint32
    order = np.argsort(keys, kind="stable")
    assert np.all(np.diff(values[order]) >= 0)
    assert keys[values == 0.0].min() == keys[values == 0.0].max()  # 0.0 and -0.0: one value, one key
    back = float32_values(keys)
    np.testing.assert_array_equal(back.view(np.uint32), (values + np.float32(0.0)).view(np.uint32))
    assert float32_keys(np.array([1.0, np.nan], np.float32)) is None


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1)), max_size=60))
def test_sorted_pairs_are_lexsorts_order(pairs):
    high = np.array([h for h, _ in pairs], np.uint32)
    low = np.array([lo for _, lo in pairs], np.uint32)
    order_ = np.lexsort((low, high))
    got_high, got_low = order.sorted_pairs(high, low)
    np.testing.assert_array_equal(got_high, high[order_])
    np.testing.assert_array_equal(got_low, low[order_])
    wide_high, wide_low = order.sorted_pairs(high.astype(np.int64), low)  # labels come as signed integers
    np.testing.assert_array_equal(wide_high, high[order_])
    np.testing.assert_array_equal(wide_low, low[order_])
