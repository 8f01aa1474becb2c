"""The adaptive mesher: same solid guarantees as the grid, and a verified error bound."""

import manifold3d
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from tamp_os import make_lithograph
from tamp_os.mesh.adaptive import adaptive_solid, insert_point
from tamp_os.mesh.solid import grid_volume_mm3
from tamp_os.mesh.validate import check_solid
from conftest import examples


def surface_at_grid_nodes(mesh, rows, cols, width, depth):
    """Height of the mesh's top surface at every grid node, by barycentric interpolation."""
    sx, sy = width / (cols - 1), depth / (rows - 1)
    tri = mesh.vertices[mesh.faces]
    normal_z = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2]
    top = tri[(normal_z > 1e-12) & (tri[:, :, 2].min(axis=1) > 0)]
    z = np.full((rows, cols), np.nan)
    for t in top:
        c = t[:, 0] / sx
        r = (depth - t[:, 1]) / sy
        cc, rr = np.meshgrid(np.arange(int(np.floor(c.min())), int(np.ceil(c.max())) + 1),
                             np.arange(int(np.floor(r.min())), int(np.ceil(r.max())) + 1))
        px, py = cc * sx, depth - rr * sy
        (x0, y0, _), (x1, y1, _), (x2, y2, _) = t
        det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
        l0 = ((y1 - y2) * (px - x2) + (x2 - x1) * (py - y2)) / det
        l1 = ((y2 - y0) * (px - x2) + (x0 - x2) * (py - y2)) / det
        l2 = 1 - l0 - l1
        inside = (l0 >= -1e-9) & (l1 >= -1e-9) & (l2 >= -1e-9)
        z[rr[inside], cc[inside]] = (l0 * t[0, 2] + l1 * t[1, 2] + l2 * t[2, 2])[inside]
    return z


heightmaps = st.tuples(st.integers(2, 40), st.integers(2, 40)).flatmap(
    lambda shape: arrays(np.float64, shape, elements=st.floats(0.5, 6.0, allow_nan=False))
)


@settings(max_examples=examples(60), deadline=None)
@given(heightmaps, st.floats(5.0, 200.0), st.floats(5.0, 200.0), st.floats(0.01, 1.0))
def test_adaptive_solid_properties_and_error_bound(heights, width, depth, max_error):
    mesh = adaptive_solid(heights, width, depth, max_error_mm=max_error)
    check = check_solid(mesh)
    assert check.ok, check.problems
    lo, hi = mesh.bounds_mm
    np.testing.assert_array_equal(lo, [0, 0, 0])
    np.testing.assert_allclose(hi, [width, depth, heights.max()], rtol=0, atol=1e-9)
    m = manifold3d.Manifold(manifold3d.Mesh(vert_properties=mesh.vertices.astype(np.float32), tri_verts=mesh.faces.astype(np.uint32)))
    assert m.status() == manifold3d.Error.NoError
    rows, cols = heights.shape
    z = surface_at_grid_nodes(mesh, rows, cols, width, depth)
    assert not np.isnan(z).any()
    # pydelatin measures its error in float32; allow that rounding on top of the bound.
    assert np.abs(z - heights).max() <= max_error + 1e-5 * heights.max()


smooth_heightmaps = st.tuples(st.integers(8, 60), st.integers(8, 60), st.integers(0, 2**32 - 1), st.floats(1.0, 3.0))


@settings(max_examples=examples(40), deadline=None)
@given(smooth_heightmaps, st.floats(5.0, 200.0), st.floats(5.0, 200.0), st.floats(0.01, 0.3))
def test_adaptive_volume_within_error_times_area_on_blurred_reliefs(spec, width, depth, max_error):
    # Heightmaps as the pipeline makes them: blurred by at least one pixel (every preset does).
    # On raw pixel noise the bound cannot hold: pydelatin bounds the error at grid nodes only,
    # and a lone spike may become a wide tent between nodes.
    from scipy import ndimage

    rows, cols, seed, sigma = spec
    noise = np.random.default_rng(seed).random((rows, cols))
    heights = 1.0 + 3.0 * ndimage.gaussian_filter(noise, sigma, mode="nearest")
    mesh = adaptive_solid(heights, width, depth, max_error_mm=max_error)
    assert check_solid(mesh).ok
    grid_volume = grid_volume_mm3(heights, width, depth)
    assert abs(mesh.volume_mm3() - grid_volume) <= max_error * width * depth


def test_error_bound_on_a_real_micrograph_at_every_grid_node(fixture):
    # No cut corner and no scale bar: every top face belongs to the relief's grid.
    litho = make_lithograph(fixture("fept_spheres_sem.png"), resolution_px=160, max_error_mm=0.06, orientation_corner="none", scale_bar="off")
    rows, cols = litho.heightmap.shape
    z = surface_at_grid_nodes(litho.mesh, rows, cols, litho.layout.width_mm, litho.layout.depth_mm)
    assert np.abs(z - litho.heightmap).max() <= 0.06 + 1e-4
    grid = make_lithograph(fixture("fept_spheres_sem.png"), resolution_px=160, mesher="grid", orientation_corner="none", scale_bar="off")
    assert litho.mesh.n_triangles * 8 < grid.mesh.n_triangles
    # On a real (blurred) picture the volume is within e × area of the full grid's, and close.
    area = litho.layout.width_mm * litho.layout.depth_mm
    assert abs(litho.mesh.volume_mm3() - grid.mesh.volume_mm3()) <= 0.06 * area
    assert litho.mesh.volume_mm3() == pytest.approx(grid.mesh.volume_mm3(), rel=0.005)


def test_default_is_adaptive_with_half_a_layer_and_zero_means_the_grid(gradient_image):
    litho = make_lithograph(gradient_image, resolution_px=60)
    assert litho.report["mesher"] == "adaptive" and litho.report["max_error_mm"] == pytest.approx(0.06)
    exact = make_lithograph(gradient_image, resolution_px=60, max_error_mm=0)
    grid = make_lithograph(gradient_image, resolution_px=60, mesher="grid")
    np.testing.assert_array_equal(exact.mesh.faces, grid.mesh.faces)


def test_orientation_holds_for_adaptive_meshes(gradient_image):
    litho = make_lithograph(gradient_image, width_mm=64, resolution_px=64, blur_px=0, relief_style="reference")
    rows, cols = litho.heightmap.shape
    z = surface_at_grid_nodes(litho.mesh, rows, cols, litho.layout.width_mm, litho.layout.depth_mm)
    # The bright block at the image's top left is at row ~10, column ~12 of the grid.
    assert z[10, 12] == pytest.approx(4.0, abs=0.07)
    assert z[-5, 5] < 1.5


def test_insert_point_inside_on_edge_and_on_vertex():
    v = np.array([[0, 0, 1], [2, 0, 1], [2, 2, 1], [0, 2, 1]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    v2, f2 = insert_point(v, f, np.array([1.5, 0.5, 3.0]))
    assert len(f2) == 4 and len(v2) == 5
    v3, f3 = insert_point(v, f, np.array([1.0, 1.0, 3.0]))  # on the shared diagonal
    assert len(f3) == 4
    v4, f4 = insert_point(v, f, np.array([2.0, 2.0, 1.0]))
    assert len(f4) == 2 and len(v4) == 4
    for verts, faces in ((v2, f2), (v3, f3)):
        tri = verts[faces]
        u, w = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        area = u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]
        assert (area > 0).all() and area.sum() == pytest.approx(8.0)


def test_a_peak_the_first_pass_leaves_out_is_inserted_without_a_second_pass():
    """A ramp with a bump 0.01 mm high at its top: within 0.06 mm, so pydelatin's first pass leaves
    the highest point out; it is inserted, the error checked around it, and no second pass runs."""
    from tamp_os.mesh import adaptive

    rows, cols, width, depth = 40, 60, 30.0, 20.0
    heights = np.tile(np.linspace(1.0, 3.0, cols), (rows, 1))  # base + relief, above z = 0
    heights[20, 50] += 0.01
    passes = []
    original = adaptive._delatin_top

    def counted(*args):
        passes.append(args[-1])
        return original(*args)

    adaptive._delatin_top = counted
    try:
        mesh = adaptive_solid(heights, width, depth, max_error_mm=0.06)
    finally:
        adaptive._delatin_top = original
    assert passes == [0.06]  # one pass at the full bound
    assert mesh.vertices[:, 2].max() == heights.max()  # the print reaches exactly base + relief
    z = surface_at_grid_nodes(mesh, rows, cols, width, depth)
    assert np.abs(z - heights).max() <= 0.06 + 1e-6
    assert check_solid(mesh).ok


def test_the_check_around_an_inserted_peak_measures_the_grid_points_inside():
    from tamp_os.mesh.adaptive import error_at_grid_points

    heights = np.zeros((11, 11))
    heights[5, 5] = 1.0
    # one triangle over the whole left half at z = 0: the only point off it is outside; then a
    # triangle that covers (5, 5) at z = 0 misses it by 1 mm
    vertices = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 10.0, 0.0], [10.0, 10.0, 0.0], [10.0, 0.0, 0.0]])
    assert error_at_grid_points(vertices, np.array([[0, 1, 2]]), heights, width_mm=10.0, depth_mm=10.0) == 0.0
    assert error_at_grid_points(vertices, np.array([[0, 4, 3]]), heights, width_mm=10.0, depth_mm=10.0) == pytest.approx(1.0)


def _insert_point_by_rows(vertices, faces, point):
    """insert_point as first written (the barycentric weights from vertices[faces]'s rows): the
    reference its faster form must match exactly."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    p = point[:2]

    def cross(u, v, w):
        return (v[..., 0] - u[..., 0]) * (w[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (w[..., 0] - u[..., 0])

    area = cross(a, b, c)
    weights = [cross(p, b, c) / area, cross(a, p, c) / area, cross(a, b, p) / area]
    hits = np.flatnonzero((weights[0] >= -1e-9) & (weights[1] >= -1e-9) & (weights[2] >= -1e-9))
    if len(hits) == 0:
        return vertices, faces
    bary = np.stack([w[hits] for w in weights], axis=1)
    if (np.abs(bary - 1) <= 1e-9).any():
        return vertices, faces
    new, keep, added = len(vertices), np.ones(len(faces), bool), []
    for f, weight in zip(hits, bary):
        i, j, k = faces[f]
        zero = np.flatnonzero(np.abs(weight) <= 1e-9)
        keep[f] = False
        if len(zero) == 0:
            added += [(i, j, new), (j, k, new), (k, i, new)]
        else:
            order = [faces[f][(zero[0] + m) % 3] for m in range(3)]
            added += [(order[0], order[1], new), (order[0], new, order[2])]
    return np.vstack([vertices, point]), np.vstack([faces[keep], np.array(added, dtype=faces.dtype)])


@pytest.mark.timeout(120)
@settings(max_examples=examples(100), deadline=None)
@given(seed=st.integers(0, 2**16), where=st.sampled_from(["random", "vertex", "edge", "outside"]))
def test_insert_point_is_the_row_by_row_computation(seed, where):
    """On a real adaptive top and any point (inside, on a vertex, on an edge, off the surface):
    the same vertices and faces, bit for bit, as the weights computed from vertices[faces]."""
    from tamp_os.mesh.adaptive import adaptive_top

    rng = np.random.default_rng(seed)
    heights = rng.random((24, 31)).astype(np.float32)
    vertices, faces = adaptive_top(heights, 30.0, 23.0, max_error_mm=0.2)
    if where == "vertex":
        point = vertices[rng.integers(len(vertices))] + [0.0, 0.0, 1.0]
    elif where == "edge":
        f = faces[rng.integers(len(faces))]
        point = (vertices[f[0]] + vertices[f[1]]) / 2
    elif where == "outside":
        point = np.array([31.0, 5.0, 1.0])
    else:
        point = np.array([rng.uniform(0, 30), rng.uniform(0, 23), 1.5])
    got, expected = insert_point(vertices, faces, point), _insert_point_by_rows(vertices, faces, point)
    assert got[0].tobytes() == expected[0].tobytes() and got[1].tobytes() == expected[1].tobytes()
    assert got[1].dtype == expected[1].dtype
