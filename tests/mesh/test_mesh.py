"""Property tests of the solid: closed, 2-manifold, outward, exact volume and bounds,
checked by our validator and by two independent libraries (trimesh, manifold3d)."""

import manifold3d
import numpy as np
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tamp_os.mesh.solid import boundary_edges, grid_solid, grid_top, grid_volume_mm3
from tamp_os.mesh.validate import check_solid
from conftest import examples

heightmaps = st.tuples(st.integers(2, 24), st.integers(2, 24)).flatmap(
    lambda shape: arrays(np.float64, shape, elements=st.floats(0.2, 10.0, allow_nan=False))
)
sizes = st.floats(1.0, 300.0)


def independent_checks(mesh):
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert tm.is_watertight
    assert tm.is_winding_consistent
    assert tm.volume > 0
    m = manifold3d.Manifold(manifold3d.Mesh(vert_properties=mesh.vertices.astype(np.float32), tri_verts=mesh.faces.astype(np.uint32)))
    assert m.status() == manifold3d.Error.NoError
    return tm, m


@settings(max_examples=examples(60), deadline=None)
@given(heightmaps, sizes, sizes)
def test_grid_solid_is_closed_manifold_outward_with_exact_volume_and_bounds(heights, width, depth):
    mesh = grid_solid(heights, width, depth)
    check = check_solid(mesh)
    assert check.ok, check.problems
    expected = grid_volume_mm3(heights, width, depth)
    assert abs(check.volume_mm3 - expected) <= 1e-6 * expected
    lo, hi = mesh.bounds_mm
    np.testing.assert_array_equal(lo, [0.0, 0.0, 0.0])
    np.testing.assert_allclose(hi, [width, depth, heights.max()], rtol=0, atol=1e-12)
    tm, m = independent_checks(mesh)
    assert abs(tm.volume - expected) <= 1e-6 * expected
    assert abs(m.volume() - expected) <= 1e-4 * expected  # manifold3d works in float32


def test_flat_plate_volume_is_box():
    mesh = grid_solid(np.full((5, 7), 2.0), 30.0, 20.0)
    assert abs(mesh.volume_mm3() - 30 * 20 * 2) < 1e-9


def test_bottom_is_a_fan_not_a_grid():
    rows, cols = 40, 50
    mesh = grid_solid(np.ones((rows, cols)), 10, 8)
    perimeter_edges = 2 * ((rows - 1) + (cols - 1))
    bottom = mesh.faces[mesh.vertices[mesh.faces].max(axis=1)[:, 2] == 0]
    assert len(bottom) == perimeter_edges
    assert len(mesh.vertices) == rows * cols + perimeter_edges + 1


@settings(max_examples=examples(40), deadline=None)
@given(st.integers(2, 40), st.integers(2, 40), st.integers(0, 10_000), st.sampled_from([0.01, 0.06, 0.3]))
def test_the_adaptive_outline_is_the_edges_used_once_in_the_same_order(rows, cols, seed, error_mm):
    """The adaptive top's outline, found from the rectangle's sides, is boundary_edges' own."""
    from tamp_os.mesh.adaptive import adaptive_top
    from tamp_os.mesh.solid import rectangle_boundary_edges

    heights = np.random.default_rng(seed).random((rows, cols)) * 3
    verts, faces = adaptive_top(heights, 7.0 * cols, 5.0 * rows, max_error_mm=error_mm)
    assert np.array_equal(rectangle_boundary_edges(verts, faces, 7.0 * cols, depth_mm=5.0 * rows), boundary_edges(faces))


def test_grid_outline_matches_the_edges_used_once():
    verts, faces, boundary = grid_top(np.zeros((4, 6)), 5, 3)
    found = boundary_edges(faces)
    assert sorted(map(tuple, found)) == sorted(map(tuple, boundary))


def test_validator_catches_a_flipped_face_and_a_hole():
    mesh = grid_solid(np.ones((4, 4)), 10, 10)
    flipped = mesh.faces.copy()
    flipped[0] = flipped[0, ::-1]
    mesh.faces = flipped
    assert not check_solid(mesh).ok
    mesh.faces = flipped[1:]
    check = check_solid(mesh)
    assert not check.closed
