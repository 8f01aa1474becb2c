"""Issue 32, "know when the print is wrong": the print compared with the picture it came from.

Synthetic pictures with known truth: a field of shaded bright particles (the specimen) on a smooth
dark ground. A print that raises the particles agrees; one that raises the ground (an inverted
print) is caught, by the modality when the file says SE/BSE and by where the structure lies when
nothing says; structure the picture shows and the print leaves flat is caught too.
"""

from __future__ import annotations

import numpy as np
import pytest

from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.relief.agreement import INVERTED_WORDS, agreement

PITCH_MM = 0.25  # 400 px across = a 100 mm print
BASE_MM = 1.0


def particle_field(rows=300, cols=400, seed=1):
    """Bright domes (radius 14-22 px = 3.5-5.5 mm on the print) with a speckled, shaded top on a
    smooth dark ground; returns (picture 0..1, particle mask)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    img = np.full((rows, cols), 0.15, np.float32)
    mask = np.zeros((rows, cols), bool)
    for cy in range(40, rows - 30, 70):
        for cx in range(40, cols - 30, 70):
            r = rng.uniform(14, 22)
            d2 = ((yy - cy) ** 2 + (xx - cx) ** 2) / r**2
            inside = d2 <= 1
            # shading across the dome (lit from the left) and a coarse surface grain a finger can follow
            grain = 0.18 * np.sin(xx / 2.5 + rng.uniform(0, 6)) * np.sin(yy / 2.5)
            img[inside] = (0.55 + 0.3 * np.sqrt(1 - d2[inside]) - 0.15 * (xx[inside] - cx) / r + grain[inside])
            mask |= inside
    img += rng.normal(0, 0.005, img.shape).astype(np.float32)
    return np.clip(img, 0, 1), mask


def heights_raising(mask):
    return np.where(mask, BASE_MM + 3.0, BASE_MM).astype(np.float32)


@pytest.mark.timeout(60)
def test_a_print_that_raises_the_particles_agrees_with_the_picture():
    picture, mask = particle_field()
    found = agreement(picture, heights_raising(mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal="SE")
    assert found.sentences == ()
    assert found.raised_brightness > found.ground_brightness + 0.3


@pytest.mark.timeout(60)
def test_raising_the_dark_gaps_of_a_backscatter_image_is_called_an_inversion():
    picture, mask = particle_field()
    found = agreement(picture, heights_raising(~mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal="BSE",
                      style="structure")
    assert len(found.sentences) == 1 and found.possibly_inverted
    said = found.sentences[0]
    assert said.startswith(f"Raised parts darker than their ground ({INVERTED_WORDS})"), said
    assert "backscattered-electron" in said and "bright side" in said, said
    # the option named is the one that flips it, in each front end's words
    assert "`invert`" in said.template
    # the content style reads its polarity from the picture, so `invert` would not turn it: the style that follows brightness is named
    by_content = agreement(picture, heights_raising(~mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal="BSE")
    assert "`relief_style` structure" in by_content.sentences[0].template


@pytest.mark.timeout(60)
def test_without_a_modality_raised_dark_parts_are_doubted_and_the_structure_agrees():
    picture, mask = particle_field()
    found = agreement(picture, heights_raising(~mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=None)
    assert len(found.sentences) == 1 and INVERTED_WORDS in found.sentences[0], found
    assert found.ground_structure > 2 * found.raised_structure  # the specimen's shading stays at the base
    # printed the right way round, nothing is said
    right = agreement(picture, heights_raising(mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=None)
    assert right.sentences == () and not right.possibly_inverted


@pytest.mark.timeout(60)
def test_dark_matter_raised_on_an_empty_bright_ground_agrees():
    """Bright field: dark particles on smooth bright glass, raised, are what the picture shows as
    matter (with no modality, by the empty ground; with a BF signal, by the modality); the glass
    raised instead is doubted."""
    picture, mask = particle_field()
    dark = np.where(mask, 1.0 - picture, 0.85).astype(np.float32)
    for signal in (None, "BF"):
        right = agreement(dark, heights_raising(mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=signal)
        assert not right.possibly_inverted and right.sentences == (), (signal, right)
    wrong = agreement(dark, heights_raising(~mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal="BF")
    assert wrong.possibly_inverted and wrong.sentences[0].startswith("Raised parts brighter than their ground"), wrong


@pytest.mark.timeout(60)
def test_flat_bright_members_printed_inverted_are_no_empty_ground():
    """Members of one flat bright grey (SE particles, backscatter cells) left at the base look like an
    empty bright ground by their grey alone; they are many pieces, not one field around the raised
    parts, so raising the dark ground between them is doubted."""
    picture, mask = particle_field()
    flat = np.where(mask, 0.8, 0.15).astype(np.float32)
    found = agreement(flat, heights_raising(~mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=None)
    assert found.possibly_inverted and INVERTED_WORDS in found.sentences[0], found


@pytest.mark.timeout(60)
def test_an_inverted_landscape_whose_lowest_points_are_a_few_particles_is_doubted():
    """A brightness-following style printed inverted, its heights a steep function of darkness: the
    dark ground is raised and only the particles' brightest points come near the base (0.1 % of the
    plate in the lowest 15 % of the relief). The highest and lowest tenth of the points are compared."""
    from scipy import ndimage

    picture, mask = particle_field()
    shown = ndimage.gaussian_filter(picture, 2.0)
    landscape = (BASE_MM + 3.0 * np.sqrt((shown.max() - shown) / np.ptp(shown))).astype(np.float32)
    assert float(np.mean(landscape - BASE_MM <= 0.15 * 3.0)) < 0.02  # under MIN_PHASE_AREA: the fixed bands cannot compare
    found = agreement(1.0 - picture, landscape, mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=True, signal=None, style="structure")
    assert found.possibly_inverted and "`invert` off" in found.sentences[0].template, found


@pytest.mark.timeout(60)
def test_an_inverted_picture_is_judged_as_displayed():
    """The relief sees 1 - picture when it inverts; the check undoes that before it compares, so
    the advice is to turn invert off."""
    picture, mask = particle_field()
    found = agreement(1 - picture, heights_raising(~mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=True, signal="SE")
    assert len(found.sentences) == 1 and "`invert` off" in found.sentences[0].template


@pytest.mark.timeout(60)
def test_structure_left_flat_on_the_plate_is_said_with_where_it_lies():
    picture, mask = particle_field()
    heights = heights_raising(mask)
    heights[:, : heights.shape[1] // 2] = BASE_MM  # the left half's particles never printed
    found = agreement(picture, heights, mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=None, polarity=False)
    assert 0.15 <= found.flat_structure_share <= 0.5, found
    assert len(found.sentences) == 1 and "left side" in found.sentences[0] and "relief_style" in found.sentences[0].template
    # the structure style is advised a finer detail instead of itself
    by_structure = agreement(picture, heights, mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=None,
                             polarity=False, style="structure")
    assert "`detail_mm`" in by_structure.sentences[0].template and "relief_style" not in by_structure.sentences[0].template
    # the whole field printed: nothing flat
    whole = agreement(picture, heights_raising(mask), mm_per_px=PITCH_MM, base_mm=BASE_MM, inverted=False, signal=None, polarity=False)
    assert whole.flat_structure_share < 0.05 and whole.sentences == ()


@pytest.mark.timeout(120)
def test_the_report_warns_when_a_user_inverts_a_particle_field():
    """End to end: the default print of the field raises the particles and says nothing; the
    structure style (which follows brightness, unlike the content style, which finds the particles
    either way) with `invert` raises the ground, and the report's verdicts say so."""
    picture, mask = particle_field()
    right = make_lithograph(picture, width_mm=100, scale_bar="off")
    wrong = make_lithograph(picture, width_mm=100, scale_bar="off", invert=True, relief_style="structure")
    rows, cols = right.heightmap.shape
    on_grid = mask[np.linspace(0, mask.shape[0] - 1, rows).round().astype(int)][:, np.linspace(0, mask.shape[1] - 1, cols).round().astype(int)]
    assert np.median(right.heightmap[on_grid]) > np.median(right.heightmap[~on_grid]) + 1.0
    assert np.median(wrong.heightmap[on_grid]) < np.median(wrong.heightmap[~on_grid])
    said_right = " ".join(right.report.legibility.verdicts)
    said_wrong = " ".join(wrong.report.legibility.verdicts)
    assert INVERTED_WORDS not in said_right, said_right
    assert INVERTED_WORDS in said_wrong and "invert off" in said_wrong, said_wrong
    assert any(INVERTED_WORDS in f for f in wrong.report.check_flags) and not right.report.check_flags


@pytest.mark.timeout(300)
def test_real_widefield_membranes_print_as_raised_outlines(fixture):
    """nikon_widefield_zstack_11z.nd2 (README: "membrane-labelled cells: a polygonal outline
    network"): the print of its projection raises the bright outlines at least 0.5 mm over the cells
    they enclose, and does not raise a cell's speckled interior as the tallest plateau."""
    from scipy import ndimage
    from skimage import filters
    from skimage.transform import resize

    litho = make_lithograph(fixture("real/nikon_widefield_zstack_11z.nd2"), width_mm=100)
    assert litho.report.content_kind == "lines", litho.report.relief_style
    from tamp_os.read.image import read_image

    values = np.asarray(read_image(fixture("real/nikon_widefield_zstack_11z.nd2")).values, np.float32)
    smooth = filters.gaussian(values, 1.0, preserve_range=True)
    outline = smooth > filters.threshold_otsu(smooth)  # the bright membranes (about a quarter of the picture)
    h = litho.heightmap
    on_grid = resize(outline.astype(float), h.shape, order=0) > 0.5
    assert 0.1 < outline.mean() < 0.45
    from skimage.morphology import skeletonize

    middle = ndimage.binary_dilation(skeletonize(on_grid))  # the outlines' middles, where a raised line runs
    assert np.median(h[middle]) - np.median(h[~on_grid]) >= 0.5, (np.median(h[middle]), np.median(h[~on_grid]))
    # every cell interior (the regions the outlines enclose) stays low: none stands as a plateau
    # (cells: enclosed regions over 2 % of the picture; a sliver between two close lines is filled on purpose)
    cells, n = ndimage.label(ndimage.binary_erosion(~on_grid, iterations=3))
    sizes = np.bincount(cells.ravel())[1:]
    big = np.flatnonzero(sizes > 0.02 * h.size) + 1
    interiors = ndimage.median(h, cells, index=big)
    assert len(big) >= 5 and max(interiors) < np.median(h[middle]) - 0.5, interiors
