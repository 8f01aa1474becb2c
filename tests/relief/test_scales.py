"""relief/scales.py: the wide Gaussian by FFT gives ndimage's edge-extended Gaussian to float32 rounding."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from tamp_os.relief.scales import wide_gaussian

pytestmark = pytest.mark.timeout(120)


@settings(max_examples=40, deadline=None)
@given(rows=st.integers(1, 90), cols=st.integers(1, 90), sigma_px=st.floats(0.5, 40.0), seed=st.integers(0, 2**16),
       as_float64=st.booleans())
def test_the_wide_gaussian_is_ndimages_nearest_mode_gaussian(rows, cols, sigma_px, seed, as_float64):
    # Any shape, also smaller than the kernel (the edge pixels then extend past the far side too).
    picture = np.random.default_rng(seed).random((rows, cols))
    picture = picture if as_float64 else picture.astype(np.float32)
    expected = ndimage.gaussian_filter(picture.astype(np.float32), sigma_px, mode="nearest")
    got = wide_gaussian(picture, sigma_px)
    assert got.shape == picture.shape and got.dtype == np.float32
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6)


def test_the_wide_gaussian_keeps_a_step_and_its_side():
    # An asymmetric picture: a step at column 30 of 100. Far from the step each side keeps its level,
    # and at the step the blur is half-way (the kernel is symmetric), on the right side of the picture.
    picture = np.zeros((40, 100), np.float32)
    picture[:, 30:] = 1.0
    blurred = wide_gaussian(picture, 5.0)
    assert blurred[:, :5].max() < 1e-6 and blurred[:, 60:].min() > 1 - 1e-6
    assert abs(float(blurred[20, 29:31].mean()) - 0.5) < 1e-6
    assert np.all(np.diff(blurred[20]) >= -1e-6)  # rising across the step (to FFT rounding)
