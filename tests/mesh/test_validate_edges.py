"""mesh/validate.py: the smallest sliver, an empty mesh, and faces that collapse once written."""

import math
import numpy as np
import pytest
from conftest import need


def test_a_face_of_exactly_the_smallest_area_is_a_sliver_and_a_larger_one_is_not():
    from tamp_os.mesh.validate import _small_faces_and_volume

    right = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 2.0, 0]])  # area exactly 1 mm²
    faces = np.array([[0, 1, 2]])
    assert _small_faces_and_volume(right, faces, 1.0)[0] == 1  # "at most" the smallest area
    assert _small_faces_and_volume(right, faces, 0.999)[0] == 0
    assert _small_faces_and_volume(right, faces, 0.7)[0] == 0  # 1.43 times the limit is a real face


def test_an_empty_mesh_has_no_bounds_and_no_volume():
    from tamp_os.mesh.solid import Mesh
    from tamp_os.mesh.validate import check_solid

    check = check_solid(Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64)))
    assert check.bounds_mm == [[], []] and check.volume_mm3 == 0.0 and not check.outward and not check.ok


def test_faces_that_collapse_once_written_are_left_out_of_the_edge_count():
    from tamp_os.mesh.solid import Mesh
    from tamp_os.mesh.validate import check_as_written

    # A unit cube at 100 mm whose bottom half [0, 2, 1] comes with two more faces through a point
    # 1e-6 mm from corner 0: one position in float32, so [0, 2, 8] and [0, 8, 1] collapse and
    # [8, 2, 1] closes the bottom; the collapsed faces' self-edges must not count as pinches.
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float) + 100.0
    v = np.vstack([v, v[0] + [1e-6, 1e-6, 0]])
    faces = np.array([[0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6],
                      [3, 0, 4], [3, 4, 7], [0, 2, 8], [8, 2, 1], [0, 8, 1]])
    check = check_as_written(Mesh(v, faces))
    assert check.closed and check.manifold and check.degenerate_faces == 2
    assert check.problems == ["2 faces have an area of at most 1e-08 mm² (slivers)"]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("offset", [(10, 10, 0), (10, 10, 10)], ids=["edge", "point"])
def test_a_pinch_is_parted_so_a_reader_merging_by_position_sees_a_closed_solid(offset):
    """Two cubes touching along an edge (or at a corner): manifold3d keeps the touching vertices
    apart by index, a slicer merging positions sees edges of four faces. Parted by a micrometre,
    the solid is closed and outward as written, each copy moved within its own cube's surface."""
    import manifold3d as m3
    import trimesh

    from tamp_os.mesh.budget import from_manifold
    from tamp_os.mesh.repair import PINCH_NUDGE_MM, part_pinches
    from tamp_os.mesh.validate import check_as_written

    touching = m3.Manifold.cube([10, 10, 10]) + m3.Manifold.cube([10, 10, 10]).translate(list(offset))
    mesh = from_manifold(touching)
    assert not check_as_written(mesh).ok or offset == (10, 10, 10)
    parted = part_pinches(mesh)
    assert check_as_written(parted).ok, check_as_written(parted).problems
    moved = np.linalg.norm(parted.vertices - mesh.vertices, axis=1)
    assert moved.max() == pytest.approx(PINCH_NUDGE_MM) and np.count_nonzero(moved) == (4 if offset[2] == 0 else 2)
    read = trimesh.Trimesh(parted.vertices.astype(np.float32), parted.faces)  # merged by position, as an STL is read
    assert read.is_watertight and read.is_winding_consistent and read.volume > 0
    assert read.volume == pytest.approx(2000.0, rel=1e-3)
    assert part_pinches(parted) is parted  # nothing left to part
