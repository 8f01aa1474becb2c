"""The relief joined to its furnished plate without a boolean (tactile/inlay.py) is the solid the
boolean gives: the same volume, bounds and surface heights (the furniture's and the relief's),
a closed surface oriented outwards, and nothing between the two solids."""

from __future__ import annotations

import manifold3d as m3
import numpy as np
import pytest
import trimesh
from conftest import examples
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from tamp_os.errors import ParameterError
from tamp_os.mesh.adaptive import adaptive_solid
from tamp_os.tactile.braille import BrailleSpec
from tamp_os.mesh.validate import check_as_written, merge_float32
from tamp_os.tactile.furniture import BAR_HEIGHT_MM, SEAM_MM, Furniture, add_furniture, build_parts, fuse_solid, plan_furniture, to_mesh
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


def _as_read_from_stl(mesh):
    """The mesh as an STL reader gets it: the file's bytes read back, corners merged by position."""
    import io

    from tamp_os.export.stl import write_stl
    from tamp_os.mesh.solid import Mesh

    fh = io.BytesIO()
    write_stl(mesh, fh, {})
    data = fh.getvalue()
    count = int(np.frombuffer(data[80:84], "<u4")[0])
    records = np.frombuffer(data[84:], np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attr", "<u2")]), count=count)
    corners = records["corners"].reshape(-1, 3).astype(np.float64)
    return Mesh(vertices=corners, faces=np.arange(len(corners)).reshape(-1, 3))


def _corners_inside_edges(mesh, z_mm: float) -> int:
    """How many vertices at height z_mm lie strictly inside an edge at that height (T-junctions,
    which a slicer sees as open edges), with vertices merged by position."""
    vertices, faces = merge_float32(mesh.vertices, mesh.faces)
    level = np.flatnonzero(vertices[:, 2] == np.float32(z_mm))
    edges = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1), axis=0)
    edges = edges[np.isin(edges[:, 0], level) & np.isin(edges[:, 1], level)]
    points, found = vertices[level, :2], 0
    for a, b in edges:
        along = vertices[b, :2] - vertices[a, :2]
        rel = points - vertices[a, :2]
        t = rel @ along / (along @ along)
        off = np.abs(rel[:, 0] * along[1] - rel[:, 1] * along[0]) / np.sqrt(along @ along)
        found += int(np.count_nonzero((t > 1e-9) & (t < 1 - 1e-9) & (off < 1e-6)))
    return found


@st.composite
def _plates(draw):
    """A small picture (random, all at the base, all at the top, a step) at a print size of
    10-300 mm, a base and relief height, and any furniture."""
    rows, cols = draw(st.integers(2, 12)), draw(st.integers(2, 12))
    width_mm = draw(st.floats(10, 300))
    depth_mm = draw(st.floats(10, 300))
    base_mm = draw(st.sampled_from([0.05, 0.6, 2.0, 8.0]))
    relief_mm = draw(st.sampled_from([0.0, 0.001, 0.5, 5.0]))
    shape = draw(st.sampled_from(["random", "low", "high", "step"]))
    picture = {
        "random": np.random.default_rng(draw(st.integers(0, 99))).random((rows, cols)),
        "low": np.zeros((rows, cols)),
        "high": np.ones((rows, cols)),
        "step": np.ones((rows, 1)) * (np.arange(cols) >= cols // 2),
    }[shape]
    furniture = Furniture(
        caption=draw(st.sampled_from([None, "a", "Cells"])),
        sample_m_per_print_mm=draw(st.sampled_from([None, 1e-6])),
        auto_scale_bar=True,
        frame_mm=draw(st.sampled_from([0.0, 2.0])),
        corner_cut=draw(st.booleans()),
        spec=BrailleSpec(),
    )
    return (base_mm + relief_mm * picture).astype(np.float32), width_mm, depth_mm, base_mm, furniture, draw(st.sampled_from([0.0, 0.06]))


@pytest.mark.timeout(300)
@settings(max_examples=examples(25), deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much, HealthCheck.function_scoped_fixture])
@given(plate=_plates())
def test_inlaid_plates_as_written_are_the_boolean_solid(monkeypatch, plate):
    """Any picture, size, base and furniture: the file as an STL reader sees it is closed,
    2-manifold and outward, without a T-junction on the pocket's rim, and holds the solid the
    boolean (the fallback) gives: the same volume and bounds."""
    import tamp_os.tactile.inlay as inlay

    heights, width_mm, depth_mm, base_mm, furniture, error_mm = plate
    relief = adaptive_solid(heights, width_mm, depth_mm, max_error_mm=error_mm)
    try:
        mesh, _ = add_furniture(relief, width_mm, depth_mm, base_mm=base_mm, furniture=furniture)
    except ParameterError:
        assume(False)  # a caption too long for a small print: refused with a message, as it should be
    with monkeypatch.context() as patch:
        patch.setattr(inlay, "inlaid", lambda *args, **kwargs: None)
        fused, _ = add_furniture(relief, width_mm, depth_mm, base_mm=base_mm, furniture=furniture)
    new, old = check_as_written(_as_read_from_stl(mesh)), check_as_written(_as_read_from_stl(fused))
    assert new.closed and new.manifold and new.outward and not new.problems, new.problems
    assert new.volume_mm3 == pytest.approx(old.volume_mm3, rel=1e-6, abs=1e-4)
    np.testing.assert_allclose(new.bounds_mm, old.bounds_mm, atol=1e-4)
    assert _corners_inside_edges(mesh, base_mm - min(SEAM_MM, base_mm / 10)) == 0


@pytest.mark.timeout(60)
def test_furnished_plate_made_once_per_shape_and_the_same_solid(monkeypatch):
    """The furnished plate is kept for the next print of the same shape: a second print is the
    same solid as the first (and as one made after forgetting the plate), the kept plate cannot
    be changed by a caller, and another caption gets a plate of its own."""
    from tamp_os.tactile import furniture as module
    from tamp_os.tactile import inlay

    plates = []
    join = inlay.inlaid
    monkeypatch.setattr(inlay, "inlaid", lambda relief, plate, *args, **kwargs: plates.append(plate) or join(relief, plate, *args, **kwargs))
    relief = _relief()

    def furnished(caption):
        furniture = Furniture(caption=caption, sample_m_per_print_mm=1e-6, auto_scale_bar=True, spec=BrailleSpec())
        return add_furniture(relief, 60.0, 40.0, base_mm=BASE_MM, furniture=furniture)[0]

    module.clear_plate_cache()
    first, again = furnished("Test"), furnished("Test")
    module.clear_plate_cache()
    fresh = furnished("Test")
    assert plates[1] is plates[0] and plates[2] is not plates[0]
    for mesh in (again, fresh):
        np.testing.assert_array_equal(mesh.vertices, first.vertices)
        np.testing.assert_array_equal(mesh.faces, first.faces)
    with pytest.raises(ValueError):
        plates[0].vertices[0, 0] = -1.0
    other = furnished("Other words")
    assert plates[3] is not plates[2] and len(other.vertices) != len(first.vertices)


def _closed_and_oriented_by_two_sorts(faces: np.ndarray) -> bool:
    """The plain statement: no repeated corner; the directed edges, sorted, are distinct and are
    their own reverses sorted."""
    if (faces[:, 0] == faces[:, 1]).any() or (faces[:, 1] == faces[:, 2]).any() or (faces[:, 0] == faces[:, 2]).any():
        return False
    a, b, c = (faces[:, k].astype(np.int64) for k in range(3))
    n = int(faces.max()) + 1
    forward = np.sort(np.concatenate([a * n + b, b * n + c, c * n + a]))
    backward = np.sort(np.concatenate([b * n + a, c * n + b, a * n + c]))
    return bool(np.array_equal(forward, backward)) and bool((np.diff(forward) > 0).all())


@pytest.mark.timeout(120)
@settings(max_examples=examples(300), deadline=None)
@given(seed=st.integers(0, 2**16), spoil=st.sampled_from(["none", "flip", "drop", "duplicate", "renumber", "random", "odd"]))
def test_closed_and_oriented_answers_as_the_plain_statement(seed, spoil):
    """Closed meshes (a box, a sphere, the relief) whole and spoiled in every way that matters:
    the one-sort test says what sorting the edges and their reverses says."""
    rng = np.random.default_rng(seed)
    mesh = [trimesh.creation.box(), trimesh.creation.icosphere(subdivisions=1 + seed % 2), _relief()][seed % 3]
    faces = np.asarray(mesh.faces, dtype=np.int64).copy()
    k = int(rng.integers(len(faces)))
    if spoil == "flip":
        faces[k] = faces[k][::-1]
    elif spoil == "drop":
        faces = np.delete(faces, k, axis=0)
    elif spoil == "duplicate":
        faces = np.vstack([faces, faces[k : k + 2]])
    elif spoil == "renumber":
        faces[k, 0] = faces[k, 1]
    elif spoil == "random":
        faces = rng.integers(0, 6, (int(rng.integers(1, 24)), 3))  # odd counts too
    elif spoil == "odd":  # a closed surface has an even number of faces; one more than that
        faces = np.vstack([faces, faces[k][::-1]])
    expected = _closed_and_oriented_by_two_sorts(faces)
    assert closed_and_oriented(faces) == expected
    assert expected == (spoil == "none") or spoil in ("random", "renumber")
