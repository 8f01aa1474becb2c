"""Wall thickness of a solid, measured along the inward normal: Embree's batched rays and
manifold3d's exact ray cast agree, and a box of known walls measures them."""

import numpy as np
import pytest

from conftest import need_module

from tamp_os.mesh import budget as mb


@pytest.mark.timeout(120)
def test_a_hollow_box_measures_its_walls_the_same_by_either_ray_cast():
    need_module("embreex")
    import manifold3d as m3

    outer = m3.Manifold.cube((20.0, 20.0, 20.0), center=True)
    inner = m3.Manifold.cube((16.0, 16.0, 17.0), center=True).translate((0.0, 0.0, 2.0))  # 2 mm walls, a 3.5 mm floor, open top
    solid = outer - inner
    model = mb.from_manifold(solid)
    points, normals = mb.sample_surface(model, 2000, seed=1)
    by_embree = mb.wall_thickness(solid, points, normals, reach_mm=50.0)
    by_manifold = mb._wall_by_manifold(solid, points - normals * mb.RAY_START_MM, normals, 50.0)
    assert np.abs(by_embree - by_manifold).max() < 1e-6
    # Points on the outer side faces, away from the edges, have a 2 mm wall behind them.
    side = (np.abs(np.abs(points[:, 0]) - 10.0) < 1e-6) & (np.abs(points[:, 1]) < 7.0) & (np.abs(points[:, 2]) < 5.0)
    assert side.sum() > 50
    assert np.allclose(by_embree[side], 2.0, atol=1e-6)
    floor = (np.abs(points[:, 2] + 10.0) < 1e-6) & (np.abs(points[:, 0]) < 7.0) & (np.abs(points[:, 1]) < 7.0)
    assert floor.sum() > 20 and np.allclose(by_embree[floor], 3.5, atol=1e-6)
