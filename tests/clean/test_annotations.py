"""The inpainting of removed annotations (clean/annotations.inpaint): the harmonic fill."""

from __future__ import annotations

import numpy as np
import pytest

from tamp_os.clean.annotations import inpaint


def _harmonic(shape) -> np.ndarray:
    """x² − y² + 3xy + 2x − y: its five-point Laplacian is exactly zero, so it is its own fill."""
    y, x = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64) / 10
    return x * x - y * y + 3 * x * y + 2 * x - y


@pytest.mark.timeout(30)
@pytest.mark.parametrize("where", ["box", "blob", "edge"])
def test_inpaint_restores_a_harmonic_surface(where):
    truth = _harmonic((120, 200))
    mask = np.zeros(truth.shape, bool)
    if where == "box":
        mask[80:110, 20:180] = True  # a databar-like strip
    elif where == "blob":
        y, x = np.ogrid[0:120, 0:200]
        mask[((y - 60) / 25) ** 2 + ((x - 90) / 50) ** 2 < 1] = True
    else:
        mask[100:, 150:] = True  # in a corner: the picture's edge is no boundary value (zero flux)
    values = np.where(mask, 0.0, truth).astype(np.float32)
    filled = inpaint(values, mask)
    assert filled.dtype == np.float32 and np.array_equal(filled[~mask], values[~mask])
    if where == "edge":
        # no Dirichlet values on two sides: bounded by its surroundings (maximum principle), not the truth
        ring = values[95:, 145:][~mask[95:, 145:]]
        assert ring.min() - 1e-3 <= filled[mask].min() and filled[mask].max() <= ring.max() + 1e-3
        return
    scale = np.abs(truth).max()
    assert np.abs(filled[mask] - truth[mask]).max() <= 1e-5 * scale


@pytest.mark.timeout(30)
def test_box_fill_agrees_with_the_direct_solve_on_a_rough_picture():
    """A databar-like box with its corners rounded (holes of known pixels inside its bounding box)
    takes the fast path; the same box beside a far-away masked pixel (a bounding box mostly
    unmasked) takes the sparse direct solve. The fill of the box is the same problem in both:
    it agrees to 1e-6 of the picture's range (a float32 step is 6e-8)."""
    rng = np.random.default_rng(7)
    values = rng.random((150, 300)).astype(np.float32)
    box = np.zeros(values.shape, bool)
    box[100:140, 20:280] = True
    for r, c in ((100, 20), (100, 279), (139, 20), (139, 279), (100, 21), (139, 278)):
        box[r, c] = False
    alone = box.copy()
    alone[5, 5] = True  # its own component: it changes nothing in the box's solution
    fast, direct = inpaint(values, box), inpaint(values, alone)
    assert np.abs(fast[box] - direct[box]).max() <= 1e-6
    assert np.array_equal(fast[~box], values[~box])
    # harmonic: every filled pixel is the mean of its four neighbours
    inner = box[1:-1, 1:-1]
    f = fast.astype(np.float64)
    mean = (f[:-2, 1:-1] + f[2:, 1:-1] + f[1:-1, :-2] + f[1:-1, 2:]) / 4
    assert np.abs(mean[inner] - f[1:-1, 1:-1][inner]).max() <= 1e-5


@pytest.mark.timeout(60)
def test_filled_holes_is_scipys_fill_of_holes():
    """filled_holes (one labelling of the background) fills exactly what binary_fill_holes fills:
    4-connected holes only, nothing that reaches an edge, on random masks of every density and
    on masks of one row or column."""
    from scipy import ndimage

    from tamp_os.clean.annotations import filled_holes

    rng = np.random.default_rng(4)
    shapes = [(1, 9), (9, 1), (2, 2), (7, 11), (30, 40)]
    for shape in shapes:
        for density in (0.0, 0.2, 0.45, 0.6, 0.8, 1.0):
            for _ in range(5):
                solid = rng.random(shape) < density
                np.testing.assert_array_equal(filled_holes(solid), ndimage.binary_fill_holes(solid), err_msg=f"{shape} {density}")
    ring = np.ones((5, 5), bool)
    ring[2, 2] = False  # a hole
    ring[1, 1] = False  # joined to the hole only by a corner: a hole of its own, not the outside
    np.testing.assert_array_equal(filled_holes(ring), np.ones((5, 5), bool))


@pytest.mark.timeout(60)
def test_saturated_parts_are_the_whole_pictures_labels():
    """saturated_parts labels only the box around the True pixels: each part has the number,
    the extent and the pixels the whole picture's labelling gives it (sparse and dense masks,
    masks in a corner, a single pixel, none)."""
    from scipy import ndimage

    from tamp_os.clean.annotations import saturated_parts

    rng = np.random.default_rng(7)
    masks = []
    for shape in [(1, 9), (9, 1), (7, 11), (40, 60)]:
        for density in (0.0, 0.02, 0.3, 0.7, 1.0):
            masks.append(rng.random(shape) < density)
            corner = np.zeros(shape, bool)
            corner[shape[0] // 2 :, shape[1] // 2 :] = rng.random((shape[0] - shape[0] // 2, shape[1] - shape[1] // 2)) < density
            masks.append(corner)
    one = np.zeros((6, 8), bool)
    one[3, 5] = True
    masks.append(one)
    for saturated in masks:
        whole, n = ndimage.label(saturated)
        labels, parts = saturated_parts(saturated)
        assert len(parts) == n
        for i, ((sl, own), expected) in enumerate(zip(parts, ndimage.find_objects(whole)), start=1):
            assert sl == expected
            np.testing.assert_array_equal(labels[own] == i, whole[sl] == i)


def _label_box(values, top, left, *, rows=24, cols=70, text_value=0.0):
    """A white label box with dark glyph strokes inside and two letters beside it, in place."""
    values[top : top + rows, left : left + cols] = 1.0
    for k in range(4):
        values[top + 6 : top + rows - 6, left + 8 + 15 * k : left + 12 + 15 * k] = text_value
    for k in range(2):  # letters of the box's colour just right of it
        c = left + cols + 4 + 8 * k
        values[top + 8 : top + 15, c : c + 4] = 1.0


@pytest.mark.timeout(60)
@pytest.mark.parametrize("where", ["top-left", "bottom-right", "middle", "two"])
def test_annotation_mask_grown_within_its_box_is_the_whole_pictures_growth(monkeypatch, where):
    """The mask's 2-pixel halo is grown within the box of what was found: the same mask as
    growing it over the whole picture, for boxes and letters at the picture's edges and corners."""
    from scipy import ndimage

    from tamp_os.clean import annotations

    values = np.full((160, 220), 0.5)
    values += np.random.default_rng(2).normal(0, 0.05, values.shape)
    values[0, 0], values[-1, -1] = 0.0, 1.0
    corners = {"top-left": [(0, 0)], "bottom-right": [(136, 130)], "middle": [(70, 60)], "two": [(0, 120), (130, 0)]}
    for top, left in corners[where]:
        _label_box(values, top, left, cols=70 if left + 86 <= 220 else 60)
    mask, found = annotations.detect_annotations(values)
    assert {a.kind for a in found} == {"box", "text"} and mask.any()  # boxes and the letters beside them
    monkeypatch.setattr(annotations, "_grown", lambda m, box, iterations: ndimage.binary_dilation(m, iterations=iterations))
    whole, found_whole = annotations.detect_annotations(values)
    np.testing.assert_array_equal(mask, whole)
    assert found == found_whole
