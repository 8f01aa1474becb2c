"""relief/touch.py: how much of a picture is noise."""

import numpy as np

from tamp_os.relief.touch import MOSTLY_NOISE, noise_share


def test_white_noise_is_mostly_noise_and_a_picture_with_noise_is_not():
    rng = np.random.default_rng(1)
    noise = rng.normal(0.5, 0.1, (300, 400))
    assert noise_share(noise, (0.2, 0.8)) > MOSTLY_NOISE
    yy, xx = np.mgrid[0:300, 0:400]
    discs = ((np.hypot((xx % 80) - 40, (yy % 80) - 40) < 25) * 0.6).astype(np.float64)
    assert noise_share(discs + rng.normal(0, 0.05, discs.shape), (0.0, 0.6)) < 0.3


def test_a_large_picture_with_an_empty_centre_is_not_noise_and_a_flat_one_is_no_noise():
    rng = np.random.default_rng(2)
    noisy = rng.normal(0.5, 0.1, (1500, 1500))
    assert noise_share(noisy, (0.2, 0.8)) > MOSTLY_NOISE
    # structure away from the centre (discs along the edges), a faintly noisy empty ground in the centre
    picture = rng.normal(0.1, 0.01, (1500, 1500))
    yy, xx = np.mgrid[0:1500, 0:1500]
    for cy, cx in [(150, 150), (150, 1350), (1350, 150), (1350, 1350), (150, 750), (1350, 750)]:
        picture[np.hypot(yy - cy, xx - cx) < 120] = 0.9
    assert noise_share(picture, (0.1, 0.9)) < 0.3
    assert noise_share(np.full((50, 60), 0.3), (0.3, 0.3)) == 0.0
    assert noise_share(np.full((50, 60), 0.3), (0.0, 1.0)) == 0.0


def test_unknown_pixels_count_as_the_low_end_and_the_range_clips():
    # Noise with a NaN block and infinite pixels, against the definition: the picture mapped to
    # 0..1 by the stretch's range (NaN as the low end, infinities clipped), the spread of that,
    # and the noise of the same mapping on the centre crop.
    from tamp_os.relief.touch import NOISE_SAMPLE_PX, noise_sigma

    rng = np.random.default_rng(5)
    values = rng.normal(100, 10, (300, 400)).astype(np.float32)
    values[:40, :40] = np.nan
    values[200, 100], values[250, 300] = np.inf, -np.inf
    lo, hi = 80.0, 120.0
    mapped = np.clip((np.where(np.isnan(values), lo, np.clip(values.astype(np.float64), -1e300, 1e300)) - lo) / (hi - lo), 0, 1)
    top, left = max(0, (300 - NOISE_SAMPLE_PX) // 2), max(0, (400 - NOISE_SAMPLE_PX) // 2)
    expected = noise_sigma(mapped[top : top + NOISE_SAMPLE_PX, left : left + NOISE_SAMPLE_PX]) / mapped.std()
    assert abs(noise_share(values, (lo, hi)) - expected) <= 1e-9 * expected


def _former_noise_share(values, source_range):
    """noise_share as it was before its spread was taken in place: numpy's own std and a copy."""
    from scipy import ndimage

    lo, hi = source_range
    if not hi > lo:
        return 0.0

    def unit(a):
        return np.clip((np.nan_to_num(a.astype(np.float64), nan=lo) - lo) / (hi - lo), 0.0, 1.0)

    rows, cols = values.shape[:2]
    step = max(1, int(np.ceil(np.sqrt(rows * cols / 1e6))))
    spread = float(unit(values[::step, ::step]).std())
    if spread <= 1e-6:
        return 0.0
    top, left = max(0, (rows - 512) // 2), max(0, (cols - 512) // 2)
    crop = unit(values[top : top + 512, left : left + 512])
    kernel = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    response = ndimage.convolve(crop.astype(np.float64), kernel)[1:-1, 1:-1]
    return float(np.sqrt(np.pi / 2) * np.abs(response).mean() / 6) / spread


def test_noise_share_gives_the_same_number_as_the_former_way():
    rng = np.random.default_rng(7)
    for shape, dtype in [((37, 53), np.float32), ((300, 411), np.float64), ((768, 1024), np.float32),
                         ((1100, 1300), np.float32), ((9, 700), np.uint16)]:
        for _ in range(3):
            values = (rng.gamma(2.0, 30.0, shape) + rng.normal(0, 5, shape)).astype(dtype)
            if values.dtype.kind == "f" and rng.random() < 0.5:
                values[rng.random(shape) < 0.01] = np.nan
            source = (float(np.nanpercentile(values, 2)), float(np.nanpercentile(values, 98)))
            assert noise_share(values, source) == _former_noise_share(values, source)
