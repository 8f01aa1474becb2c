"""The finer picture the content style looks for thin lines on (preprocess.Prepared.finer)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tamp_os.relief.preprocess import prepare


def _prepared(values, cols=50, invert=False, flip_x=False, alpha=None):
    rows = round((values.shape[0] - 1) * (cols - 1) / (values.shape[1] - 1)) + 1
    return prepare(values, alpha, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
                   low_pct=2.0, high_pct=98.0, sigma_px=1.2, invert=invert, flip_x=flip_x)


@pytest.mark.timeout(60)
def test_the_finer_picture_keeps_a_one_pixel_line_the_print_grid_blurs_away():
    values = np.full((200, 400), 0.5, np.float32)
    values[:, 201] = 0.0  # one source pixel wide
    values[:40, :40], values[-40:, -40:] = 0.0, 1.0  # black and white blocks span the range
    prepared = _prepared(values)
    fine = prepared.finer(400)
    assert fine.shape == values.shape  # no wider than asked: the source's own pixels
    ground = float(np.median(fine[60:140, 150:190]))
    assert ground - fine[60:140, 201].mean() > 0.45  # the line is as deep as drawn
    image = prepared.image
    column = round(201 * (image.shape[1] - 1) / 399)
    print_ground = float(np.median(image[10:15, column - 8 : column - 3]))
    assert print_ground - image[10:15, column - 1 : column + 2].min() < 0.25  # on the print grid, resampled and blurred, it is faint


@pytest.mark.timeout(60)
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), invert=st.booleans(), flip_x=st.booleans(), want=st.integers(60, 500))
def test_the_finer_picture_follows_the_prints_orientation_and_never_exceeds_the_source(seed, invert, flip_x, want):
    rng = np.random.default_rng(seed)
    values = rng.random((90, 160)).astype(np.float32)
    values[:, :40] = 0.0  # a dark left quarter: where it lands tells the mirroring and inversion
    prepared = _prepared(values, invert=invert, flip_x=flip_x)
    fine = prepared.finer(want)
    if want >= 160:
        assert fine.shape == values.shape  # never finer than the source
    else:
        assert fine.shape[1] == want
        aspect = (prepared.image.shape[0] - 1) / (prepared.image.shape[1] - 1)
        assert abs((fine.shape[0] - 1) - aspect * (fine.shape[1] - 1)) <= 1.5
    assert 0.0 <= fine.min() and fine.max() <= 1.0
    quarter = max(1, fine.shape[1] // 5)
    left, right = fine[:, :quarter].mean(), fine[:, -quarter:].mean()
    dark_side_is_left = not flip_x
    expected_low = (left if dark_side_is_left else right)
    other = (right if dark_side_is_left else left)
    assert (expected_low > other) if invert else (expected_low < other)
    # The print grid's own picture comes the same way round.
    p_left, p_right = prepared.image[:, :5].mean(), prepared.image[:, -5:].mean()
    assert (p_left < p_right) == (left < right)


@pytest.mark.timeout(60)
def test_a_uniform_picture_has_no_finer_picture():
    assert _prepared(np.full((40, 60), 3.0, np.float32)).finer(200) is None
