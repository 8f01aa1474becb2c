"""The relief joined to its furnished plate without a boolean (tactile/inlay.py) is the solid the
boolean gives: the same volume, bounds and surface heights (the furniture's and the relief's),
a closed surface oriented outwards, and nothing between the two solids."""

from __future__ import annotations

import manifold3d as m3
import numpy as np
import pytest
import trimesh

from tamp_os.mesh.adaptive import adaptive_solid
from tamp_os.tactile.braille import BrailleSpec
from tamp_os.tactile.furniture import BAR_HEIGHT_MM, Furniture, add_furniture, build_parts, fuse_solid, plan_furniture, to_mesh
from tamp_os.tactile.inlay import closed_and_oriented

BASE_MM = 2.0


def _relief():
    """A relief of 60 × 40 mm with domes and a ridge, meshed adaptively as the pipeline does."""
    y, x = np.mgrid[0:81, 0:121] / 2.0
    heights = BASE_MM + 1.5 * np.exp(-((x - 20) ** 2 + (y - 20) ** 2) / 40) + 0.8 * (np.abs(x - 40) < 2) * (y > 5)
    return adaptive_solid(heights.astype(np.float32), 60.0, 40.0, max_error_mm=0.06)


def _solid(mesh):
    return m3.Manifold(m3.Mesh(vert_properties=mesh.vertices.astype(np.float32), tri_verts=mesh.faces.astype(np.uint32)))


def _top_z(mesh, xy: np.ndarray) -> np.ndarray:
    """The highest surface point straight above each (x, y)."""
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    origins = np.column_stack([xy, np.full(len(xy), 50.0)])
    locations, rays, _ = tm.ray.intersects_location(origins, np.tile([0.0, 0.0, -1.0], (len(xy), 1)))
    top = np.full(len(xy), -np.inf)
    np.maximum.at(top, rays, locations[:, 2])
    return top


@pytest.mark.timeout(60)
@pytest.mark.parametrize("frame_mm", [0.0, 2.0], ids=["bar-and-caption", "with-frame"])
def test_inlaid_relief_is_the_boolean_solid(frame_mm):
    relief = _relief()
    furniture = Furniture(caption="Test", sample_m_per_print_mm=1e-6, auto_scale_bar=True, frame_mm=frame_mm, spec=BrailleSpec())
    mesh, placed = add_furniture(relief, 60.0, 40.0, base_mm=BASE_MM, furniture=furniture)
    plan = plan_furniture(60.0, 40.0, furniture)
    top = float(relief.vertices[:, 2].max()) + 1.0
    fused = to_mesh(fuse_solid(build_parts(relief, plan, BASE_MM, spec=furniture.spec), plan.placed, top))
    assert len(mesh.faces) != len(fused.faces) or not np.array_equal(mesh.faces, fused.faces)  # it is the other construction
    assert closed_and_oriented(np.asarray(mesh.faces))
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0  # outward
    new, old = _solid(mesh), _solid(fused)
    assert new.status() == m3.Error.NoError
    assert new.volume() == pytest.approx(old.volume(), rel=1e-9)
    assert (new - old).volume() < 1e-6 and (old - new).volume() < 1e-6
    np.testing.assert_allclose(new.bounding_box(), old.bounding_box(), atol=1e-5)
    # heights where the furniture and the relief stand: dots, the bar, the relief's dome and ridge
    ox, oy = placed.relief_origin_mm
    x0, y0, x1, y1 = placed.scale_bar_box
    points = np.array(plan.dot_centres + [((x0 + x1) / 2, (y0 + y1) / 2), (ox + 10, oy + 10), (ox + 20.1, oy + 15), (ox + 55, oy + 35)])
    heights, expected = _top_z(mesh, points), _top_z(fused, points)
    np.testing.assert_allclose(heights, expected, atol=1e-5)
    assert heights[len(plan.dot_centres)] == pytest.approx(BASE_MM + BAR_HEIGHT_MM, abs=1e-5)
    assert np.all(heights[: len(plan.dot_centres)] == pytest.approx(BASE_MM + furniture.spec.dot_height_mm, abs=1e-3))


@pytest.mark.timeout(60)
def test_a_relief_down_at_the_plate_top_takes_the_boolean():
    """A relief whose top comes down to the plate's top (base 0) cannot stand on the pocket's rim:
    the boolean makes it, and the result is still one closed solid."""
    relief = adaptive_solid(np.zeros((41, 61), np.float32) + 0.001, 60.0, 40.0, max_error_mm=0.06)
    furniture = Furniture(caption="Test", spec=BrailleSpec())
    mesh, _ = add_furniture(relief, 60.0, 40.0, base_mm=BASE_MM, furniture=furniture)
    plan = plan_furniture(60.0, 40.0, furniture)
    fused = to_mesh(fuse_solid(build_parts(relief, plan, BASE_MM, spec=furniture.spec), plan.placed, BASE_MM + 2.0))
    assert np.array_equal(mesh.faces, fused.faces) and np.array_equal(mesh.vertices, fused.vertices)
    assert closed_and_oriented(np.asarray(mesh.faces))
