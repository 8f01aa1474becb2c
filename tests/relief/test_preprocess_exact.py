"""relief/preprocess.py and heightmap.py: the stretch maps the source's percentiles, quantize rounds to the nearest layer, resampling is antialiased, a uniform image stays flat when inverted."""

import json
import os
import subprocess
import sys
import numpy as np
import pytest
from PIL import Image
from conftest import FIXTURES, ROOT, run_cli as run
from tamp_os import make_lithograph
from tamp_os.errors import ParameterError
from tamp_os.relief.heightmap import heights_mm
from tamp_os.relief.preprocess import prepare, resample, stretch


pytestmark = pytest.mark.timeout(240)


def test_the_stretch_maps_the_chosen_percentiles_of_the_source():
    values = np.arange(1000, dtype=np.float64).reshape(20, 50)
    image, (low, high), uniform = stretch(values, None, 2.0, high_pct=98.0)
    assert not uniform
    assert low == pytest.approx(np.percentile(values, 2)) and high == pytest.approx(np.percentile(values, 98))
    assert image.min() == 0 and image.max() == 1
    # A pixel half-way between the percentiles maps to 0.5.
    mid = np.argmin(np.abs(values - (low + high) / 2))
    assert image.ravel()[mid] == pytest.approx(0.5, abs=1e-3)


def test_quantize_rounds_to_the_nearest_layer_not_down():
    image = np.array([[0.0, 0.1, 0.149, 0.151, 1.0]])
    h = heights_mm(image, base_mm=1.0, relief_mm=1.0, layer_mm=0.1)
    np.testing.assert_allclose((h - 1.0)[0], [0.0, 0.1, 0.1, 0.2, 1.0], atol=1e-12)


def test_resampling_is_antialiased():
    stripes = np.tile(np.array([0.0, 1.0], np.float32), (64, 32))  # 1-pixel stripes
    small = resample(stripes, 16, 16)
    # Point sampling would give all 0 or all 1; an antialiased filter averages to the mean.
    assert np.allclose(small, 0.5, atol=0.1)


def test_invert_of_a_uniform_image_is_still_a_flat_plate_at_base():
    prepared = prepare(np.full((10, 12), 7.0), None, rows=10, cols=12, target_aspect=10 / 12, fit="pad",
                       low_pct=2, high_pct=98, sigma_px=1.0, invert=True, flip_x=False)
    assert prepared.uniform and np.all(prepared.image == 0)
    litho = make_lithograph(np.full((10, 12), 7.0), invert=True, orientation_corner="none")
    assert np.all(litho.heightmap == litho.params.base_mm)
