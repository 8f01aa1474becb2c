"""The finer picture the content style looks for thin lines on (preprocess.Prepared.finer)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from scipy import ndimage
from synthetic_content import sparse_beads, sparse_strokes

from tamp_os.relief.preprocess import prepare, stretch
from conftest import examples


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
@settings(max_examples=examples(25), deadline=None)
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


def _plain_stretch(values, low_pct=2.0, high_pct=98.0):
    """The stretch between the picture's own percentiles, computed here independently."""
    low, high = np.percentile(values[np.isfinite(values)], [low_pct, high_pct])
    return np.clip((values - low) / (high - low), 0, 1), (float(low), float(high))


def _assert_plain_stretch(values):
    """`stretch` gives exactly the plain 2-98 % stretch of `values` (range and image)."""
    image, (low, high), _ = stretch(values, None, 2.0, high_pct=98.0)
    expected, expected_range = _plain_stretch(values)
    assert (low, high) == pytest.approx(expected_range)
    np.testing.assert_allclose(image, expected, atol=1e-5)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("ink_pct", [0.5, 1.0, 1.5])
@pytest.mark.parametrize("with_unknown", [False, True])
def test_sparse_strokes_keep_their_contrast_and_the_papers_noise_stays_light(ink_pct, with_unknown):
    """Ink under 2 % of a drawing: the 2nd percentile lies in the paper's noise. The strokes must
    stay the darkest thing and the paper, noise and all, must stay near white (before, the
    noise was spread over 0..1 and its darkest pixels were as black as the ink)."""
    truth = sparse_strokes(ink_pct=ink_pct)
    values = truth.image.copy()
    if with_unknown:  # unknown pixels take the masked path of the stretch
        values[:20, :30] = np.nan
    assert np.percentile(truth.image, 2) > 0.8  # the case is the one described: the percentile is paper
    image, (low, high), uniform = stretch(values, None, 2.0, high_pct=98.0)
    paper = ~ndimage.binary_dilation(truth.lines, iterations=2) & np.isfinite(values)
    assert not uniform
    assert np.median(image[truth.lines]) <= 0.05
    assert np.percentile(image[paper], 0.1) >= 0.8  # the paper's darkest noise is far above the ink
    assert low <= np.median(truth.image[truth.lines]) + 0.02 and high == pytest.approx(np.percentile(truth.image, 98))


@pytest.mark.timeout(60)
@pytest.mark.parametrize(("count", "cover_pct"), [(3, 0.3), (5, 0.6), (6, 1.0)])
def test_sparse_beads_keep_their_contrast_and_the_ground_stays_dark(count, cover_pct):
    truth = sparse_beads(count=count, cover_pct=cover_pct)
    image, _, _ = stretch(truth.image, None, 2.0, high_pct=98.0)
    ground = ndimage.distance_transform_edt(truth.members == 0) > 3
    assert np.percentile(image[ground], 99.9) <= 0.2
    peaks = ndimage.maximum(image, truth.members, np.arange(1, count + 1))
    assert np.min(peaks) >= 0.5  # every bead, the dimmest too, well above the ground


@pytest.mark.timeout(60)
def test_a_few_specks_or_scattered_hot_pixels_do_not_set_the_stretch():
    """Too few far pixels (dust), or far pixels that touch none of their own kind (hot pixels,
    salt noise), are no content: the stretch stays between the percentiles and clips them."""
    rng = np.random.default_rng(1)
    ground = (0.5 + 0.01 * rng.standard_normal((300, 400))).astype(np.float32)
    specks = ground.copy()
    specks[100:104, 200:205] = 0.0  # 20 px: under 0.02 % of the picture
    salt = ground.copy()
    salt[::10, ::10] = 1.0  # 1 % of the pixels, none touching another
    for values in (specks, salt):
        _assert_plain_stretch(values)


@pytest.mark.timeout(60)
def test_a_long_tail_of_an_ordinary_picture_and_dense_content_keep_the_percentile_stretch():
    """The moon's tails run on from its ground (no distinct population), and strokes over
    2 % of a drawing already hold the percentile: both keep the plain 2-98 % stretch."""
    import skimage.data

    moon = skimage.data.moon().astype(np.float32)
    dense = sparse_strokes(ink_pct=4.0).image
    for values in (moon, dense):
        _assert_plain_stretch(values)


@pytest.mark.timeout(120)
@settings(max_examples=examples(30), deadline=None)
@given(seed=st.integers(0, 2**31 - 1), sigma=st.floats(0.0, 6.0), offset=st.floats(-100, 100), scale=st.floats(0.01, 1000))
def test_pictures_without_a_distinct_tail_keep_the_percentile_stretch(seed, sigma, offset, scale):
    """Noise, smooth or not, at any level and scale: no tail is a population apart from the rest."""
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.standard_normal((120, 160)), sigma) if sigma > 0 else rng.standard_normal((120, 160))
    values = (offset + scale * field).astype(np.float32)
    _, (low, high), _ = stretch(values, None, 2.0, high_pct=98.0)
    assert (low, high) == pytest.approx(_plain_stretch(values)[1])


@pytest.mark.timeout(60)
def test_one_pixel_strokes_in_a_large_picture_are_found_though_the_noise_is_measured_on_a_subsample():
    """Over a million pixels the ground is measured on evenly spaced pixels; strokes one pixel
    wide on odd columns of an even-width picture (a step of 2 from the first pixel would miss
    every one) still keep their contrast."""
    rng = np.random.default_rng(2)
    values = (0.9 + 0.008 * rng.standard_normal((1024, 2048))).astype(np.float32)
    columns = np.arange(101, 2000, 200)  # ten strokes, all on odd columns: 0.4 % of the picture
    values[100:-100, columns] = 0.1
    image, (low, _), _ = stretch(values, None, 2.0, high_pct=98.0)
    assert low < 0.2
    assert image[100:-100, columns].max() <= 0.05
    assert np.percentile(np.delete(image, columns, axis=1), 0.1) >= 0.8


def test_stretch_of_unknown_or_infinite_pixels_matches_the_masked_way():
    # The quick all-finite check must send every picture holding a NaN or an infinity down the
    # masked way: the same picture with an all-opaque alpha always takes it.
    rng = np.random.default_rng(11)
    for bad in (np.nan, np.inf, -np.inf, None):
        for dtype in (np.float32, np.float64):
            values = rng.gamma(2.0, 20.0, (60, 80)).astype(dtype)
            if bad is not None:
                values[rng.random(values.shape) < 0.02] = bad
            quick = stretch(values, None, 1.0, high_pct=99.0)
            masked = stretch(values, np.ones(values.shape, np.float32), 1.0, high_pct=99.0)
            assert quick[1:] == masked[1:]
            assert np.array_equal(quick[0], masked[0])
