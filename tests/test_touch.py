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


def test_a_large_picture_is_measured_on_a_centre_crop_and_a_flat_one_is_no_noise():
    rng = np.random.default_rng(2)
    big = np.zeros((3000, 3000))
    big[1244:1756, 1244:1756] = rng.normal(0.5, 0.1, (512, 512))  # noise only in the centre crop
    assert noise_share(big, (0.2, 0.8)) > MOSTLY_NOISE
    assert noise_share(np.full((50, 60), 0.3), (0.3, 0.3)) == 0.0
    assert noise_share(np.full((50, 60), 0.3), (0.0, 1.0)) == 0.0
