"""mesh/validate.py on small hand-made solids: outward, pinched, open, slivers as written, merge by position."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tamp_os.mesh.solid import Mesh
from tamp_os.mesh.validate import check_as_written, check_solid, merge_float32
from conftest import examples


CUBE_VERTICES = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)


CUBE_FACES = np.array([
    [0, 2, 1], [0, 3, 2],  # bottom, seen from below
    [4, 5, 6], [4, 6, 7],  # top
    [0, 1, 5], [0, 5, 4],  # front (y = 0)
    [1, 2, 6], [1, 6, 5],  # right (x = 1)
    [2, 3, 7], [2, 7, 6],  # back (y = 1)
    [3, 0, 4], [3, 4, 7],  # left (x = 0)
])


def cube(offset=(0.0, 0.0, 0.0), size=1.0) -> Mesh:
    return Mesh(CUBE_VERTICES * size + np.asarray(offset, float), CUBE_FACES.copy())


def test_a_unit_cube_is_a_good_solid_with_exact_volume_and_bounds():
    for check in (check_solid(cube((2, 3, 4), 2.0)), check_as_written(cube((2, 3, 4), 2.0))):
        assert check.ok and check.closed and check.manifold and check.outward and check.degenerate_faces == 0
        assert check.volume_mm3 == pytest.approx(8.0, abs=1e-9)
        assert check.bounds_mm == [[2, 3, 4], [4, 5, 6]]
        assert check.problems == []


def test_an_inside_out_closed_mesh_is_reported_as_not_outward():
    mesh = cube()
    mesh.faces = mesh.faces[:, ::-1].copy()  # every face wound inward: still closed and manifold
    for check in (check_solid(mesh), check_as_written(mesh)):
        assert check.closed and check.manifold
        assert not check.outward and not check.ok
        assert check.volume_mm3 == pytest.approx(-1.0)
        assert any("wind inward" in p for p in check.problems), check.problems


def test_a_closed_mesh_of_zero_volume_is_reported_as_not_outward():
    # Two triangles back to back: every edge used twice, once each way, but nothing is enclosed.
    mesh = Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 1]]))
    for check in (check_solid(mesh), check_as_written(mesh)):
        assert check.closed and check.manifold and check.degenerate_faces == 0
        assert check.volume_mm3 == 0.0
        assert not check.outward and not check.ok


def test_an_open_and_a_pinched_mesh_are_told_apart():
    open_mesh = Mesh(CUBE_VERTICES.copy(), CUBE_FACES[1:].copy())
    check = check_solid(open_mesh)
    assert not check.closed and not check.manifold and any("only one face" in p for p in check.problems)
    doubled = Mesh(CUBE_VERTICES.copy(), np.vstack([CUBE_FACES, CUBE_FACES[:2]]))
    check = check_solid(doubled)
    assert check.closed and not check.manifold and any("more than one face" in p for p in check.problems)


def test_a_seam_of_plus_and_minus_zero_is_one_position_as_written():
    # The left face's vertices are duplicated with x = -0.0: open by index, closed once written.
    vertices = np.vstack([CUBE_VERTICES, CUBE_VERTICES[[0, 3, 4, 7]] * np.array([-1.0, 1, 1])])
    assert np.signbit(vertices[8:, 0]).all()
    faces = CUBE_FACES.copy()
    remap = {0: 8, 3: 9, 4: 10, 7: 11}
    faces[10:] = np.vectorize(remap.get)(faces[10:])
    mesh = Mesh(vertices, faces)
    assert not check_solid(mesh).closed
    merged, merged_faces = merge_float32(vertices, faces)
    assert len(merged) == 8 and not np.signbit(merged).any()
    check = check_as_written(mesh)
    assert check.ok and check.volume_mm3 == pytest.approx(1.0)


def test_faces_that_collapse_after_float32_rounding_are_slivers_as_written():
    # A vertex 1e-6 mm from a corner at 100 mm (float32 spacing there: 7.6e-6) on the cube's edge 0-1:
    # distinct in float64 (the mesh is closed and every face has area), one position in float32.
    mesh = cube((100.0, 100.0, 100.0))
    near = mesh.vertices[0] + [1e-6, 0, 0]
    vertices = np.vstack([mesh.vertices, near])
    faces = [f for f in mesh.faces.tolist() if not ({0, 1} <= set(f))]
    # The two faces on edge 0-1 ([0, 2, 1] bottom, [0, 1, 5] front), each split at the new vertex 8.
    faces += [[0, 2, 8], [8, 2, 1], [0, 8, 5], [8, 1, 5]]
    mesh = Mesh(vertices, np.array(faces))
    by_index = check_solid(mesh)
    assert by_index.ok, by_index.problems
    as_written = check_as_written(mesh)
    assert as_written.degenerate_faces == 2 and not as_written.ok
    assert as_written.closed  # the collapsed faces are left out of the edge count, the rest still closes


def test_edge_problems_are_counted_exactly():
    from tamp_os.mesh.validate import _edge_problems

    faces = CUBE_FACES.copy()
    assert _edge_problems(faces, 8) == (0, 0)
    assert _edge_problems(faces[1:], 8) == (0, 3)  # one face gone: its three edges have one face each
    assert _edge_problems(faces[2:], 8) == (0, 4)  # the bottom gone: its four outer edges are open
    assert _edge_problems(np.vstack([faces, faces[:2]]), 8) == (6, 0)  # two faces twice: six directed edges reused
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert _edge_problems(flipped, 8) == (3, 0)  # one face flipped: its edges run the same way as the neighbours'
    check = check_solid(Mesh(CUBE_VERTICES.copy(), faces[1:]))
    assert "3 edges have only one face (the surface is open)" in check.problems
    check = check_solid(Mesh(CUBE_VERTICES.copy(), np.vstack([faces, faces[:2]])))
    assert "6 directed edges are used by more than one face (pinched or inconsistently wound)" in check.problems


def test_a_needle_face_far_from_the_origin_is_a_sliver_as_written():
    # Three distinct points, collinear once rounded to float32 (y = 10 + 1e-8 becomes 10): the
    # face keeps three positions but has no area. The first corner is far from the origin.
    vertices = np.array([[10.0, 10.0, 10.0], [11.0, 10.0, 10.0], [10.5, 10.0 + 1e-8, 10.0]])
    mesh = Mesh(vertices, np.array([[0, 1, 2], [0, 2, 1]]))
    assert check_solid(mesh).degenerate_faces == 0
    check = check_as_written(mesh)
    assert check.degenerate_faces == 2 and not check.ok
    assert "2 faces have an area of at most 1e-08 mm² (slivers)" in check.problems


def test_slivers_and_volume_add_up_across_chunks():
    from tamp_os.mesh.validate import _small_faces_and_volume

    mesh = cube((3.0, 4.0, 5.0))
    needle = np.array([[20.0, 0, 0], [21.0, 0, 0], [20.5, 0, 0]])
    vertices = np.vstack([mesh.vertices, needle])
    faces = np.vstack([[8, 9, 10], mesh.faces, [8, 10, 9]])
    whole = _small_faces_and_volume(vertices, faces, 1e-8)
    for chunk in (1, 2, 5, 13):
        assert _small_faces_and_volume(vertices, faces, 1e-8, chunk=chunk) == pytest.approx(whole)
    assert whole[0] == 2 and whole[1] == pytest.approx(1.0)


def _colliding_positions():
    """Two float32 positions whose 64-bit grouping keys in merge_float32 collide."""
    rng = np.random.default_rng(11)
    mult = np.uint64(0x9E3779B97F4A7C15)
    with np.errstate(over="ignore"):
        while True:
            p = rng.random(3).astype(np.float32) * 10
            z_q = np.float32(rng.random() * 10)
            bp = p.view(np.uint32).astype(np.uint64)
            key_p = ((bp[0] << np.uint64(32)) | bp[1]) ^ (bp[2] * mult)
            hi_q = key_p ^ (np.array([z_q], np.float32).view(np.uint32).astype(np.uint64)[0] * mult)
            q = np.array([hi_q >> np.uint64(32), hi_q & np.uint64(0xFFFFFFFF)], np.uint64).astype(np.uint32).view(np.float32)
            if np.isfinite(q).all() and (np.abs(q) < 1e6).all() and (np.abs(q) > 1e-6).all():
                return p, np.array([q[0], q[1], z_q], np.float32)


def test_merge_by_position_is_exact_even_when_grouping_keys_collide():
    p, q = _colliding_positions()
    vertices = np.array([p, q, p, q, p], np.float64)
    faces = np.array([[0, 1, 2], [3, 4, 1]])
    merged, merged_faces = merge_float32(vertices, faces)
    assert len(merged) == 2
    assert np.array_equal(merged[merged_faces[0]], vertices[[0, 1, 2]].astype(np.float32).astype(np.float64))
    assert np.array_equal(merged[merged_faces[1]], vertices[[3, 4, 1]].astype(np.float32).astype(np.float64))
    assert merged_faces[0, 0] == merged_faces[0, 2] == merged_faces[1, 1] != merged_faces[0, 1]


def test_merge_of_distinct_positions_keeps_every_vertex_and_face():
    vertices = CUBE_VERTICES + 0.25
    merged, merged_faces = merge_float32(vertices, CUBE_FACES)
    assert np.array_equal(merged, vertices) and np.array_equal(merged_faces, CUBE_FACES)
    twice = np.vstack([vertices, vertices])
    merged, merged_faces = merge_float32(twice, CUBE_FACES + 8)
    assert len(merged) == 8
    assert np.array_equal(merged[merged_faces], vertices[CUBE_FACES])
