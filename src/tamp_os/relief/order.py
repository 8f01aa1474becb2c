"""Percentiles of a large sample, the same numbers as NumPy's, found without partitioning it all.

`np.percentile` partitions the whole sample around every rank it needs: 7.5 ms for the five
percentiles the stretch takes of a 1024 x 768 picture. The ranks' values lie in narrow brackets
that a sorted subsample predicts; counting the pixels below a bracket and partitioning only the
few inside it gives the same order statistics (checked: when a bracket misses its rank, the whole
sample is partitioned as before), and NumPy's own interpolation between them gives the same bits.
"""

from __future__ import annotations

import numpy as np

# Below this many values, np.percentile's one partition is as cheap as the brackets.
MIN_BRACKETED = 1 << 16
SUBSAMPLE = 1 << 16  # values in the sorted subsample that predicts each rank's bracket
# A bracket reaches this many deviations of a subsample rank (at most half its square root) each side.
BRACKET_DEVIATIONS = 4.0


def percentiles(sample: np.ndarray, pcts) -> np.ndarray:
    """`np.percentile(sample, pcts)` (method "linear", float64) of a 1-D float sample without NaN."""
    n = sample.size
    if n < MIN_BRACKETED:
        return np.percentile(sample, pcts)
    # NumPy's virtual indexes and neighbours (numpy/lib/_function_base_impl.py, method "linear").
    virtual = (n - 1) * np.true_divide(np.asarray(pcts, dtype=np.float64), 100)
    previous = np.floor(virtual)
    following = previous + 1
    top = virtual >= n - 1
    previous[top] = following[top] = n - 1
    bottom = virtual < 0
    previous[bottom] = following[bottom] = 0
    gamma = virtual - previous
    ranks = np.unique(np.concatenate([previous, following]).astype(np.intp))
    values = dict(zip(ranks.tolist(), order_statistics(sample, ranks)))
    a = np.array([values[k] for k in previous.astype(np.intp).tolist()], dtype=sample.dtype)
    b = np.array([values[k] for k in following.astype(np.intp).tolist()], dtype=sample.dtype)
    # NumPy's _lerp: the difference in the sample's type, the interpolation in float64, from the
    # nearer end (b - diff * (1 - gamma) from gamma 0.5 on).
    diff = b - a
    return np.where(gamma >= 0.5, b - diff * (1 - gamma), a + diff * gamma)


def order_statistics(sample: np.ndarray, ranks: np.ndarray) -> list:
    """The k-th smallest value of `sample` for each k in `ranks` (0-based, sorted, unique).
    Neighbouring ranks (a percentile's two neighbours) share one bracket."""
    n = sample.size
    step = max(1, n // SUBSAMPLE)
    sub = np.sort(sample[::step])
    margin = int(BRACKET_DEVIATIONS * 0.5 * np.sqrt(sub.size)) + 2
    groups = np.split(ranks, np.flatnonzero(np.diff(ranks) > 1) + 1)
    out = []
    for group in groups:
        first, last = int(group[0]), int(group[-1])
        low = sub[max(0, first * sub.size // n - margin)]
        high = sub[min(sub.size - 1, last * sub.size // n + margin)]
        within = sample >= low
        below = n - int(np.count_nonzero(within))
        within &= sample <= high
        count = int(np.count_nonzero(within))
        if not (below <= first and last < below + count):
            return whole_partition(sample, ranks)
        if low == high:  # a plateau of one value holds the ranks (a saturated area): nothing to sort
            out += [sample.dtype.type(low)] * len(group)
            continue
        out += np.partition(sample[within], group - below)[group - below].tolist()
    return out


def whole_partition(sample: np.ndarray, ranks: np.ndarray) -> list:
    """The plain way, for a bracket that missed its rank (a sample whose strided subsample is
    unlike the whole)."""
    return np.partition(sample, ranks)[ranks].tolist()


def float32_keys(values: np.ndarray) -> np.ndarray | None:
    """uint32 keys that sort as the float32 `values` do (equal values, 0.0 and -0.0 too, get equal
    keys), or None if a value is NaN (unordered). Packed above an index or a label into 64-bit
    keys, one np.sort (SIMD) replaces an argsort, several times slower."""
    if np.isnan(values).any():
        return None
    bits = (values.astype(np.float32, copy=False) + np.float32(0.0)).view(np.uint32)  # + 0: -0.0 is 0.0
    # Negative floats: all bits flipped (a larger magnitude is a smaller number); others: the sign bit set.
    return np.where(bits >= SIGN_BIT, ~bits, bits | np.uint32(SIGN_BIT))


def sorted_pairs(high: np.ndarray, low: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (high, low) pairs of integers in 0 .. 2**32 - 1 (any integer dtype: high is widened
    once, into the key) sorted by high, then low, as two uint32 arrays: one sort of 64-bit keys
    (high above low; NumPy's SIMD sort, several times faster than an argsort or a lexsort of the two)."""
    key = high.astype(np.uint64)
    key <<= np.uint64(32)
    key |= low
    key.sort()
    halves = key.view(np.uint32)  # each key's two halves, in the machine's byte order
    return (halves[1::2], halves[::2]) if np.little_endian else (halves[::2], halves[1::2])


def float32_values(keys: np.ndarray) -> np.ndarray:
    """The float32 values of float32_keys (uint32)."""
    keys = keys.astype(np.uint32, copy=False)
    return np.where(keys >= SIGN_BIT, keys ^ np.uint32(SIGN_BIT), ~keys).view(np.float32)


SIGN_BIT = 1 << 31
