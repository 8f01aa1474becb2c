"""Issue 53, class 1: which side is specimen when the detector is not in the metadata. A backscatter
SEM of blood cells on a filter (mid-grey discs of one flat grey, dark gaps, a thin brighter fibrin
mesh) makes the most common brightness the cells' own: taken as the ground, the dark gaps became
3 mm shards and the cells holes. What the picture says decides: detector words in its data band
("BSD Full … 10 kV": bright is matter), and where nothing says, the side whose pieces are compact
and convex is raised, not the concave shards between them. Exact truth: the discs as drawn."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from conftest import need
from synthetic_content import bse_blood_cells, dark_line_network, packed_cells, with_data_band
from tamp_os.clean import ocr
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.relief.content import content_polarity, side_shapes

RAISED_MM = 0.5
FLAT_CELLS = dict(grey=(0.41, 0.41), dimple=0.0, rim=0.0, strand=0.7, overlap=0.72)  # flat enough to look like an empty ground


def _on_grid(labels: np.ndarray, shape) -> np.ndarray:
    rows = np.linspace(0, labels.shape[0] - 1, shape[0]).round().astype(int)
    cols = np.linspace(0, labels.shape[1] - 1, shape[1]).round().astype(int)
    return labels[rows][:, cols]


def _discs_over_gaps(litho, members: np.ndarray) -> tuple[float, float]:
    """(the discs' median height over the gaps' median, the share of discs whose median stands
    RAISED_MM over it), gaps taken a grid point in from the discs' drawn edges."""
    h = litho.heightmap
    discs = _on_grid(members, h.shape)
    gaps = ndimage.binary_erosion(discs == 0, iterations=1)
    base = float(np.median(h[gaps]))
    tops = np.array([np.median(h[discs == k]) for k in range(1, int(discs.max()) + 1) if (discs == k).sum() >= 10])
    return float(np.median(h[discs > 0])) - base, float(np.mean(tops - base >= RAISED_MM))


@pytest.mark.timeout(180)
def test_backscatter_cells_without_any_detector_words_are_raised_over_their_gaps():
    t = bse_blood_cells()
    litho = make_lithograph(t.image, width_mm=100, scale_bar="off")
    over, felt = _discs_over_gaps(litho, t.members)
    reason = litho.report.relief_reason
    assert over >= RAISED_MM and felt >= 0.9, (over, felt, reason)
    assert "compact and convex" in reason and "bright parts are raised" in reason, reason


@pytest.mark.timeout(180)
def test_backscatter_cells_with_bsd_in_their_data_band_are_raised_over_their_gaps():
    need(ocr.backend() is not None, "OCR (tesserocr with the eng model, or the tesseract command)")
    t = bse_blood_cells()
    litho = make_lithograph(with_data_band(t.image, "BSD Full  10 kV  x2000  WD 8 mm"), width_mm=100, scale_bar="off")
    assert litho.report.crop.bottom_rows >= 40
    assert litho.report.instrument["signal"] == "BSE", litho.report.instrument
    over, felt = _discs_over_gaps(litho, t.members)
    reason = litho.report.relief_reason
    assert over >= RAISED_MM and felt >= 0.9, (over, felt, reason)
    assert "BSE signal" in reason, reason


@pytest.mark.timeout(180)
def test_flat_cells_that_look_like_an_empty_bright_ground_are_turned_over_by_their_shape():
    """Cells of one flat grey covering most of the field: more than half the picture lies within
    0.06 of its most common brightness, which alone reads as an empty bright ground (glass) and
    raises the dark gaps. The gaps are concave shards between compact discs: the discs are raised."""
    t = bse_blood_cells(**FLAT_CELLS)
    litho = make_lithograph(t.image, width_mm=100, scale_bar="off")
    from tamp_os.relief.preprocess import prepare

    rows, cols = litho.heightmap.shape
    work = prepare(t.image, None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch", low_pct=2,
                   high_pct=98, sigma_px=1.2, invert=False, flip_x=False).image
    by_brightness = content_polarity(work, litho.layout.mm_per_px)
    assert by_brightness.empty and not by_brightness.bright, by_brightness  # the trap the shapes get out of
    over, felt = _discs_over_gaps(litho, t.members)
    assert over >= RAISED_MM and felt >= 0.9, (over, felt, litho.report.relief_reason)


@pytest.mark.parametrize("maker, bright", [
    (lambda: bse_blood_cells().image, True),  # compact discs, concave gaps
    (lambda: bse_blood_cells(radius=(35, 45), seed=4).image, True),
    (lambda: packed_cells().image, True),
    (lambda: 1.0 - packed_cells(overlap=1.0, tries=600, fibres=0).image, False),  # dark cells on bright glass
    (lambda: dark_line_network().image, None),  # thin dark lines: no side of areas to compare
    (lambda: np.random.default_rng(0).random((300, 400)).astype(np.float32), None),  # noise has no members
])
def test_the_side_of_compact_pieces_is_found_on_the_fine_grid(maker, bright):
    picture = maker()
    width_mm = 100.0
    pitch_mm = width_mm / (picture.shape[1] - 1)
    if pitch_mm > 0.2:  # as the pipeline measures it: about 0.2 mm per point
        picture = ndimage.zoom(picture, pitch_mm / 0.2, order=1)
        pitch_mm = width_mm / (picture.shape[1] - 1)
    shapes = side_shapes(picture, pitch_mm)
    assert shapes.members_bright is bright, shapes


def test_a_bright_field_signal_raises_the_dark_side():
    """TEM bright field: matter is dark whatever the ground's brightness says (here mid-grey)."""
    yy, xx = np.mgrid[0:200, 0:260].astype(np.float32)
    picture = np.full((200, 260), 0.55, np.float32)
    for cy, cx in ((50, 60), (120, 150), (60, 200), (150, 60)):
        picture[(yy - cy) ** 2 + (xx - cx) ** 2 < 15**2] = 0.1
    assert not content_polarity(picture, 0.4, signal="BF").bright
    assert content_polarity(picture, 0.4, signal="BSE").bright
