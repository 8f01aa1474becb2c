"""relief/objects.py's label helpers: the lookup-table renumbering and ranks are scikit-image's and NumPy's."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage import segmentation

from tamp_os.relief.objects import dense_ranks, sequential_labels

pytestmark = pytest.mark.timeout(120)


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 40), cols=st.integers(1, 40), top=st.integers(0, 5000), seed=st.integers(0, 2**16),
       dtype=st.sampled_from([np.int32, np.int64, np.uint16]))
def test_sequential_labels_are_relabel_sequentials(rows, cols, top, seed, dtype):
    rng = np.random.default_rng(seed)
    labels = np.where(rng.random((rows, cols)) < 0.4, 0, rng.integers(0, top + 1, (rows, cols))).astype(dtype)
    got = sequential_labels(labels)
    assert got.dtype == labels.dtype
    np.testing.assert_array_equal(got, segmentation.relabel_sequential(labels)[0])
    assert set(np.unique(got)) - {0} == set(range(1, len(set(np.unique(labels)) - {0}) + 1))


@settings(max_examples=60, deadline=None)
@given(size=st.integers(1, 3000), top=st.one_of(st.integers(0, 100), st.integers(10**6, 10**12)), seed=st.integers(0, 2**16))
def test_dense_ranks_are_uniques_inverse(size, top, seed):
    # Small keys take the lookup table, keys far larger than their count take np.unique.
    keys = np.random.default_rng(seed).integers(0, top + 1, (size // 30 + 1, 30)).astype(np.int64)
    expected = np.unique(keys, return_inverse=True)[1].reshape(keys.shape)
    np.testing.assert_array_equal(dense_ranks(keys), expected)
