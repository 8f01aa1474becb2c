"""relief/legibility.py: the smallest step of a terrace, both ways."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tamp_os.mesh.solid import Mesh
from tamp_os.mesh.validate import check_as_written, check_solid, merge_float32
from conftest import examples


def test_smallest_step_of_a_terrace_that_goes_up_and_down():
    from tamp_os.relief.legibility import assess

    # Bands 0, 1.5, 0.5, 2.0 mm: neighbours differ by 1.5, 1.0 and 1.5 mm. The smallest gap between
    # distinct levels (0 and 0.5) is 0.5 mm, but those two never touch: the step a finger meets is 1.0.
    band_px, pitch = 40, 0.25
    heights = np.repeat(np.array([0.0, 1.5, 0.5, 2.0]), band_px)[None, :].repeat(60, axis=0)
    result = assess(heights + 1.0, pitch, layer_mm=0.1)
    assert result.levels_used == 4
    assert result.smallest_step_mm == pytest.approx(1.0)
    descending = assess(heights[:, ::-1] + 1.0, pitch, layer_mm=0.1)
    assert descending.smallest_step_mm == pytest.approx(1.0)


def test_a_terrace_step_in_the_other_direction_counts_too():
    from tamp_os.relief.legibility import assess

    band_px, pitch = 40, 0.25
    heights = np.repeat(np.array([0.0, 1.5, 0.5, 2.0]), band_px)[:, None].repeat(60, axis=1)  # bands along rows
    result = assess(heights, pitch, layer_mm=0.1)
    assert result.levels_used == 4 and result.smallest_step_mm == pytest.approx(1.0)
