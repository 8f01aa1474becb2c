"""The numbers a 3-D model is priced by: the most triangles marching cubes can make of a grid
(`surface_triangles`), and the working grid's zoom (never far past the stack's own voxels)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from tamp_os.lithograph.volume import FINEST_PITCH_MM, MAX_GROWTH, refine_zoom
from tamp_os.lithograph.volume_price import price_model
from tamp_os.mesh.volume import isosurface, surface_triangles


def fields():
    rng = np.random.default_rng(7)
    yield "noise", rng.normal(size=(30, 40, 50)).astype(np.float32)
    yield "smoothed noise", ndimage.gaussian_filter(rng.normal(size=(40, 40, 40)).astype(np.float32), 0.5)
    yield "uniform", (rng.random((30, 30, 30)) - 0.5).astype(np.float32)
    yield "checker", ((np.indices((20, 20, 20)).sum(0) % 2) * 2 - 1).astype(np.float32) * 0.7
    yield "ball", (12 - np.sqrt(((np.indices((40, 40, 40)) - 19.7) ** 2).sum(0))).astype(np.float32) / 12
    yield "ball cut by the edge", (12 - np.sqrt(((np.indices((20, 40, 40)) - 19.7) ** 2).sum(0))).astype(np.float32) / 12


@pytest.mark.timeout(60)
@pytest.mark.parametrize("name,field", list(fields()), ids=[n for n, _ in fields()])
def test_the_triangle_bound_holds_and_is_tight_on_smooth_surfaces(name, field):
    made = isosurface(np.clip(field, -1, 1), (1.0, 1.0, 1.0)).n_triangles
    bound = surface_triangles(field > 0)
    assert bound >= made
    if name.startswith("ball"):
        assert bound <= made * 1.02  # about 2 a crossed cell, as marching cubes makes them
    else:
        assert bound <= made * 3


@pytest.mark.timeout(30)
def test_the_zoom_never_grows_a_stack_past_its_own_voxels_by_more_than_the_growth():
    # a coarse stack (a 2 × 2 × 2 stack at 100 mm: 50 mm voxels) grows twice each way, not to the print's pitch
    assert refine_zoom([50.0, 50.0, 50.0], (2, 2, 2), 8_000_000).tolist() == [2.0, 2.0, 2.0]
    # anisotropic voxels grow along their long axis first
    zoom = refine_zoom([6.6, 0.78, 0.78], (11, 128, 128), 8_000_000)
    assert zoom[0] == 8.0 and zoom[1] == zoom[2] == 1.0
    # a stack already at the print's pitch is not interpolated
    assert refine_zoom([FINEST_PITCH_MM] * 3, (100, 100, 100), 8_000_000).tolist() == [1.0, 1.0, 1.0]
    # within the voxel budget
    zoom = refine_zoom([1.0, 1.0, 1.0], (150, 150, 150), 8_000_000)
    assert np.prod(zoom) * 150 ** 3 <= 8_000_000
    for pitch, shape in (([3.0, 1.0, 0.5], (10, 30, 60)), ([0.9, 0.9, 0.9], (5, 500, 500)), ([40.0, 2.0, 2.0], (3, 50, 50))):
        assert np.prod(refine_zoom(pitch, shape, 8_000_000)) <= MAX_GROWTH


@pytest.mark.timeout(30)
def test_the_price_grows_with_the_surface_and_the_simplification():
    small, big = price_model(1_000_000, 100_000, 200_000), price_model(1_000_000, 3_000_000, 200_000)
    assert big.bytes > small.bytes and big.seconds > small.seconds
    assert "GB" in big.words() and "3.0 million triangles" in big.words()
