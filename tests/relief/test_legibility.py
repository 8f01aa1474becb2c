"""Legibility report and the preset suggestion by touch, on reliefs whose answers are known."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from synthetic import tem_texture
from tamp_os.relief.legibility import assess
from tamp_os.relief.touch import suggest_by_touch
from conftest import examples

MM = 0.4  # grid pitch in mm


@pytest.mark.timeout(30)
def test_flat_plate_is_said_as_such():
    report = assess(np.full((60, 80), 1.0), MM)
    assert report.fine_share == 0.0 and report.levels_used == 1
    assert report.verdicts == ("This print is a flat plate: there is nothing raised to feel.",)


@pytest.mark.timeout(30)
def test_fine_share_tells_noise_from_shape():
    rng = np.random.default_rng(0)
    noise = 1.0 + 3.0 * rng.random((100, 120))
    ramp = np.tile(np.linspace(1.0, 4.0, 120), (100, 1))
    assert assess(noise, MM).fine_share > 0.8
    assert assess(ramp, MM).fine_share < 0.01
    assert any("structure" in v for v in assess(noise, MM).verdicts)


@pytest.mark.timeout(60)
@settings(max_examples=examples(15), deadline=None)
@given(step=st.sampled_from([0.24, 0.48, 0.6, 1.2]), count=st.integers(2, 4))
def test_levels_and_smallest_step_of_a_terrace(step, count):
    cols = np.repeat(np.arange(count), 30)
    heights = 1.0 + step * np.tile(cols, (40, 1)).astype(float)
    report = assess(heights, MM, layer_mm=0.12)
    assert report.levels_used == count
    assert report.smallest_step_mm == pytest.approx(step)
    says_too_small = any("under the 0.5 mm" in v for v in report.verdicts)
    assert says_too_small == (step < 0.5)


@pytest.mark.timeout(30)
def test_narrow_features_are_found_and_wide_ones_are_not():
    pitch = 0.1
    heights = np.ones((200, 200))
    heights[:, 50:53] += 1.0  # a ridge 0.3 mm wide: under two 0.4 mm nozzle widths
    heights[:, 120:170] += 1.0  # a plateau 5 mm wide
    report = assess(heights, pitch, nozzle_mm=0.4)
    ridge_mm2 = 0.3 * 200 * pitch
    assert ridge_mm2 * 0.8 <= report.narrow_area_mm2 <= ridge_mm2 * 2.0


@pytest.mark.timeout(30)
@given(angle=st.floats(5, 60))
@settings(max_examples=examples(10), deadline=None)
def test_steepest_slope_of_a_ramp(angle):
    x = np.arange(100) * MM
    heights = np.tile(1.0 + np.tan(np.radians(angle)) * x, (50, 1))
    assert assess(heights, MM).steepest_slope_deg == pytest.approx(angle, abs=0.5)


@pytest.mark.timeout(30)
def test_object_lift_above_the_ground_around_it():
    yy, xx = np.mgrid[0:120, 0:160]
    disk_a = (yy - 40) ** 2 + (xx - 40) ** 2 < 15**2
    disk_b = (yy - 80) ** 2 + (xx - 110) ** 2 < 15**2
    heights = np.full((120, 160), 1.0) + 0.5 * (xx > 80)  # the right half of the ground is higher
    heights[disk_a] += 2.0
    heights[disk_b] += 0.4
    report = assess(heights, MM, objects=disk_a | disk_b)
    assert report.object_count == 2
    assert report.lowest_lift_mm == pytest.approx(0.4)
    assert any("relief_style objects" in v for v in report.verdicts) == (report.object_lift_mm < 1.0)


@pytest.mark.timeout(60)
@settings(max_examples=examples(6), deadline=None)
@given(seed=st.integers(0, 1000), size=st.sampled_from([68, 128]))
def test_noise_never_gets_high(seed, size):
    noisy = np.random.default_rng(seed).normal(0.5, 0.2, (size, size)).astype(np.float32)
    suggestion = suggest_by_touch(noisy, None, width_mm=100, nozzle_mm=0.4)
    assert suggestion.preset == "low" and "mm" in suggestion.reason


@pytest.mark.timeout(60)
def test_noisy_texture_gets_low_and_clean_edges_do_not():
    assert suggest_by_touch(tem_texture().image, None, width_mm=100, nozzle_mm=0.4).preset == "low"
    text = np.zeros((200, 400), np.float32)
    text[:, ::8] = 1.0  # thin clean lines 1 px wide every 8 px: 2 mm apart at 100 mm
    text[:, 1::8] = 1.0
    s = suggest_by_touch(text, None, width_mm=100, nozzle_mm=0.4)
    assert s.preset in ("medium", "high") and s.noise_ratio < 0.35


@pytest.mark.timeout(30)
def test_uniform_picture_gets_low():
    s = suggest_by_touch(np.full((50, 50), 513, np.uint16), None, width_mm=100, nozzle_mm=0.4)
    assert s.preset == "low" and "uniform" in s.reason


def test_relief_span_is_the_former_two_percentiles_difference():
    rng = np.random.default_rng(5)
    for _ in range(20):
        rows, cols = rng.integers(8, 60, 2)
        h = 1.0 + rng.gamma(rng.uniform(0.2, 3.0), 1.0, (rows, cols)) * rng.uniform(0.1, 5.0)
        got = assess(h, 0.4).relief_span_mm
        assert got == float(np.percentile(h, 99) - np.percentile(h, 1))
