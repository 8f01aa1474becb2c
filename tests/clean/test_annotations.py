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
