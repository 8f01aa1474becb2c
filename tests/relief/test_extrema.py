"""relief/extrema.py: h-maxima with one sort are scikit-image's h-maxima, pixel for pixel."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage import morphology

from tamp_os.relief import extrema
from tamp_os.relief.extrema import h_maxima

pytestmark = pytest.mark.timeout(120)


@settings(max_examples=150, deadline=None)
@given(rows=st.integers(1, 40), cols=st.integers(1, 40), levels=st.integers(1, 12), step=st.sampled_from([0.25, 0.1, 1e-3, 1.0]),
       h=st.sampled_from([0.1, 0.25, 0.3, 0.5, 1.0, 2.0, 1e-4]), seed=st.integers(0, 2**16),
       dtype=st.sampled_from([np.float32, np.float64]), smooth=st.booleans())
def test_h_maxima_are_scikit_images(rows, cols, levels, step, h, seed, dtype, smooth):
    # Plateaus and ties (few grey levels), or smooth hills; h below, at and above the steps.
    rng = np.random.default_rng(seed)
    picture = rng.integers(0, levels, (rows, cols)) * step
    if smooth:
        picture = picture + rng.random((rows, cols)) * step
    picture = picture.astype(dtype)
    got = h_maxima(picture, h)
    assert got.dtype == np.uint8
    np.testing.assert_array_equal(got, morphology.h_maxima(picture, h))


def test_a_picture_with_two_hills_keeps_only_the_one_standing_h_above_its_saddle():
    # Known answer: two peaks joined by a saddle; only the peak 1.0 above the saddle is an h-maximum at h = 0.5.
    picture = np.zeros((9, 19), np.float32)
    picture[4, 2:17] = 0.2  # the ridge joining them
    picture[4, 4], picture[4, 14] = 1.2, 0.5  # tall peak left, low peak right
    found = h_maxima(picture, 0.5)
    assert found[4, 4] == 1 and found.sum() == 1


def test_without_scikit_images_loop_it_is_scikit_images_h_maxima(monkeypatch):
    monkeypatch.setattr(extrema, "_reconstruction_loop", lambda: None)
    picture = np.random.default_rng(1).random((30, 40)).astype(np.float32)
    np.testing.assert_array_equal(h_maxima(picture, 0.3), morphology.h_maxima(picture, 0.3))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_negative_values_and_signed_zeros_are_ordered_as_numbers(dtype):
    # float32 is sorted by its bits: negative values (bits flipped) and -0.0 beside 0.0 must still
    # come in the order of their values.
    rng = np.random.default_rng(7)
    picture = (rng.integers(-6, 6, (40, 50)) * 0.25).astype(dtype)
    picture[rng.random(picture.shape) < 0.2] = -0.0
    for h in (0.2, 0.25, 0.6):
        np.testing.assert_array_equal(h_maxima(picture, h), morphology.h_maxima(picture, h))
