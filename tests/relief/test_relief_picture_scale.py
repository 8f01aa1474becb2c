"""What is an object does not depend on the print's width (issue 26: picture_scale.py).

The FePt spheres and synthetic discs are prepared as the pipeline prepares them at Medium for
each width (the output grid follows the width, the blur stays 1.2 output pixels) and must give
the same members, and auto the same choice, at every width.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from tamp_os.relief.picture_scale import REFERENCE_WIDTH_MM, PictureScale
from tamp_os.relief.preprocess import prepare
from tamp_os.relief.styles import make_relief
from conftest import examples

BASE, RELIEF = 1.0, 3.0
WIDTHS_MM = (60, 80, 100, 120, 150)
# The four FePt spheres (as tests/test_relief_styles.py and benchmarks/content_truth.py): centre
# (x, y) and radius as fractions of the picture's width, measured by eye.
FEPT_SPHERES = [(0.20, 0.38, 0.187), (0.567, 0.24, 0.173), (0.46, 0.63, 0.171), (0.807, 0.56, 0.187)]


def at_width(path, width_mm):
    """The brightness picture the pipeline prepares for a print `width_mm` wide (Medium)."""
    from tamp_os.lithograph.pipeline import make_lithograph

    litho = make_lithograph(path, width_mm=width_mm, mesher="grid", scale_bar="off", channels="off", relief_style="reference")
    image01 = (litho.heightmap - litho.params.base_mm) / litho.params.relief_mm
    return image01.astype(np.float32), litho.layout.mm_per_px, litho.report.uniform


def disks(shape, spheres, share=1.0):
    """Bool masks of the spheres (a share of each radius) on a grid of `shape`."""
    rows, cols = shape
    yy, xx = np.mgrid[0:rows, 0:cols] / (cols - 1)
    return [(xx - x) ** 2 + (yy - y * (rows - 1) / (cols - 1)) ** 2 <= (share * r) ** 2 for x, y, r in spheres]


@pytest.mark.timeout(300)
def test_fept_spheres_are_the_same_four_members_at_every_width(fixture):
    """At 60-150 mm wide, auto chooses the same style, and each of the four spheres' inner half is
    one member of its own standing >= 1 mm over the ground (the picture away from all spheres)."""
    chosen = set()
    for width_mm in WIDTHS_MM:
        image, mm, uniform = at_width(fixture("fept_spheres_sem.png"), width_mm)
        made = make_relief(image, style="auto", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF, uniform=uniform)
        chosen.add(made.style)
        assert made.object_count == 4, (width_mm, made.object_count, made.reason)
        ground = ~np.any(disks(image.shape, FEPT_SPHERES, 1.2), axis=0)
        ground_mm = float(np.median(made.heights_mm[ground]))
        seen = set()
        for inner in disks(image.shape, FEPT_SPHERES, 0.5):
            labels = made.objects[inner]
            main = int(np.bincount(labels).argmax())
            assert main > 0 and (labels == main).mean() > 0.9 and main not in seen, width_mm
            seen.add(main)
            assert np.median(made.heights_mm[inner]) - ground_mm >= 1.0, width_mm
    assert chosen == {"content"}


def disc_picture(centres, radius, cols, rng):
    """A source picture 4:3 of bright discs (radius as a share of the width) on a dark, noisy ground,
    prepared as the pipeline does for an output grid `cols` wide (blur 1.2 output pixels)."""
    src_cols, src_rows = 800, 600
    yy, xx = np.mgrid[0:src_rows, 0:src_cols] / (src_cols - 1)
    picture = 0.2 + 0.02 * rng.standard_normal((src_rows, src_cols))
    for x, y in centres:
        picture[(xx - x) ** 2 + (yy - y) ** 2 <= radius**2] += 0.5
    rows = round((src_rows - 1) * (cols - 1) / (src_cols - 1)) + 1
    image = prepare(picture.astype(np.float32), None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
                    low_pct=2.0, high_pct=98.0, sigma_px=1.2, invert=False, flip_x=False).image
    return image


@st.composite
def disc_layouts(draw):
    """Discs 2-4 % of the width in radius (1.2-2.4 mm on a 60 mm print, 3-6 mm at 150 mm), apart by
    at least two radii, away from the border, enough of them to cover 3 % of the picture (with
    less, the pipeline's 98th-percentile stretch lands in the ground's noise and stretches it
    over the range)."""
    radius = draw(st.floats(0.02, 0.04))
    count = int(np.ceil(0.03 * 0.75 / (np.pi * radius**2)))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    centres = []
    for _ in range(400):
        x, y = rng.uniform(0.1, 0.9), rng.uniform(0.1, 0.65)
        if all(np.hypot(x - a, y - b) >= 4 * radius for a, b in centres):
            centres.append((x, y))
        if len(centres) == count:
            break
    assume(len(centres) == count)
    return centres, radius, seed


@pytest.mark.timeout(300)
@settings(max_examples=examples(6), deadline=None)
@given(disc_layouts())
def test_the_same_discs_are_found_at_every_width(layout):
    """N known discs printed 60, 100 and 150 mm wide: the content style finds N members at each
    width, one on every disc's centre, and every disc stands >= 1 mm over the ground."""
    centres, radius, seed = layout
    for width_mm in (60, 100, 150):
        cols = round(width_mm / (100 / 249)) + 1
        image = disc_picture(centres, radius, cols, np.random.default_rng(seed))
        mm = width_mm / (cols - 1)
        made = make_relief(image, style="content", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF)
        assert made.object_count == len(centres), (width_mm, made.object_count, made.reason)
        at = {int(made.objects[round(y * (cols - 1)), round(x * (cols - 1))]) for x, y in centres}
        assert 0 not in at and len(at) == len(centres), width_mm
        for x, y in centres:
            r, c = round(y * (cols - 1)), round(x * (cols - 1))
            assert made.heights_mm[r, c] - BASE >= 1.0, width_mm


def test_picture_grid_is_the_working_grid_at_the_reference_width():
    """At the reference width nothing is resampled; elsewhere the picture grid spans the same
    picture at the same pitch in reference mm, and labels come back to the working grid."""
    pitch = REFERENCE_WIDTH_MM / 249
    same = PictureScale.plan((188, 250), pitch)
    assert same.identity and same.blur_ratio == 1.0 and same.mm_per_reference_mm == pytest.approx(1.0)
    narrow = PictureScale.plan((113, 150), 60 / 149)
    assert (narrow.picture_shape[1] - 1) * narrow.picture_pitch_mm == pytest.approx(REFERENCE_WIDTH_MM)
    assert narrow.picture_pitch_mm == pytest.approx(60 / 149, rel=0.01)
    assert narrow.blur_ratio > 1.6 and narrow.blur_ratio == pytest.approx((narrow.picture_shape[1] - 1) / 149) and narrow.mm_per_reference_mm == pytest.approx(0.6)
    wide = PictureScale.plan((281, 375), 150 / 374)
    assert (wide.picture_shape[1] - 1) * wide.picture_pitch_mm == pytest.approx(REFERENCE_WIDTH_MM) and wide.blur_ratio == 1.0
    labels = np.zeros(wide.picture_shape, np.int32)
    labels[40:80, 40:80], labels[100:140, 150:200] = 3, 7
    back = wide.labels_to_work(labels)
    assert back.shape == (281, 375) and set(np.unique(back)) == {0, 1, 2}
    assert (back > 0).mean() == pytest.approx((labels > 0).mean(), rel=0.05)

