"""Every written mesh is a closed solid as slicers read it (vertices merged by position), the
product refuses to write one that is not, the automatic scale bar fits, and every plate carries
its cut corner (mesh/validate.py, with the furniture that every plate carries)."""

import logging

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import need, examples

from tamp_os import make_lithograph
from tamp_os.errors import ExportError, ParameterError
from tamp_os.export import check_export, save_mesh
from tamp_os.mesh.solid import Mesh, grid_solid
from tamp_os.mesh.validate import check_as_written, check_solid
from tamp_os.tactile.braille import liblouis_available
from tamp_os.tactile.furniture import BORDER_MM, CORNER_CUT_MM, Furniture, corner_legs_mm, plan_furniture
from tamp_os.tactile.scalebar import MIN_BAR_MM

CONFIGS = 300
CHUNKS = 6
CAPTIONS = ["FePt spheres", "Cells, 2024", "A", "SEM grains 5 um", "⠠⠋⠑⠀⠏⠞"]


def random_image(rng) -> np.ndarray:
    """A small picture of a random size and dtype: noise, waves, a flat field or a mask."""
    rows, cols = int(rng.integers(6, 48)), int(rng.integers(6, 48))
    y, x = np.mgrid[0:rows, 0:cols]
    kind = rng.choice(["noise", "waves", "flat", "steps"])
    img = {
        "noise": rng.random((rows, cols)),
        "waves": np.sin(x / rng.uniform(1, 6)) * np.cos(y / rng.uniform(1, 6)),
        "flat": np.full((rows, cols), rng.random()),
        "steps": (x > cols / 3).astype(float) + (y > rows / 2),
    }[kind]
    img = (img - img.min()) / (np.ptp(img) or 1.0)
    dtype = rng.choice(["uint8", "uint16", "float32", "float64", "bool"])
    scale = {"uint8": 255, "uint16": 65535, "float32": 1.0, "float64": 1.0, "bool": 1.0}[dtype]
    return (img > 0.5) if dtype == "bool" else (img * scale).astype(dtype)


def random_params(rng, image: np.ndarray, braille: bool) -> dict:
    width = float(rng.uniform(20, 300))
    p = dict(
        width_mm=width,
        mesher=str(rng.choice(["adaptive", "grid"])),
        base_mm=float(rng.choice([0.1, 0.5, 1.0, 1.5, rng.uniform(0.05, 5)])),
        relief_mm=float(rng.choice([0.2, 1.0, 3.0, rng.uniform(0.1, 8)])),
        resolution_px=int(rng.integers(6, 64)),
        quantize=bool(rng.random() < 0.2),
        invert=bool(rng.random() < 0.2),
        orientation_corner=str(rng.choice(["cut", "cut", "cut", "none"])),
    )
    if rng.random() < 0.5:
        captions = CAPTIONS if braille else CAPTIONS[-1:]
        p["caption"] = str(rng.choice(captions))
    if rng.random() < 0.3:
        p["frame_mm"] = float(rng.choice([1.0, 2.0, rng.uniform(0.3, 10)]))
    if braille and rng.random() < 0.6:
        pixel_um = float(10 ** rng.uniform(-4, 2))
        p["pixel_size"] = f"{pixel_um:.4g}um"
        if rng.random() < 0.3:  # a bar the user asks for, 8 mm to the picture's width
            length_mm = rng.uniform(MIN_BAR_MM + 0.5, min(40.0, width - 1))
            p["scale_bar"] = f"{float(f'{pixel_um:.4g}') * image.shape[1] / width * length_mm:.4g}um"
    return p


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize("chunk", range(CHUNKS))
def test_random_configurations_write_closed_solids_as_slicers_read_them(tmp_path, chunk):
    braille = liblouis_available()
    rng = np.random.default_rng(1000 + chunk)
    logging.disable(logging.WARNING)
    try:
        for i in range(CONFIGS // CHUNKS):
            image = random_image(rng)
            params = random_params(rng, image, braille)
            litho = make_lithograph(image, **params)
            path = litho.save(tmp_path / f"{i}.stl")[0]
            loaded = trimesh.load(path)  # default processing merges vertices by position
            loaded.merge_vertices()
            context = f"configuration {chunk}/{i}: {image.shape} {image.dtype} {params}"
            assert loaded.is_watertight, context
            assert loaded.is_winding_consistent, context
            assert loaded.volume > 0, context
            assert loaded.volume == pytest.approx(litho.mesh.volume_mm3(), rel=1e-4), context
    finally:
        logging.disable(logging.NOTSET)


def two_cubes_sharing_an_edge() -> Mesh:
    """Two closed cubes with their own vertices that touch along one edge: closed by index,
    pinched (an edge in four faces) once merged by position, as a slicer reads it."""
    cube = trimesh.creation.box(extents=(1, 1, 1))
    a = np.asarray(cube.vertices) + 0.5
    b = a + [1.0, 1.0, 0.0]
    faces = np.asarray(cube.faces)
    return Mesh(vertices=np.vstack([a, b]), faces=np.vstack([faces, faces + 8]).astype(np.int32))


@pytest.mark.timeout(30)
def test_validator_sees_a_pinch_that_index_checks_miss(tmp_path):
    mesh = two_cubes_sharing_an_edge()
    assert check_solid(mesh).ok  # by index it is closed
    check = check_as_written(mesh)
    assert not check.ok and any("more than one face" in p for p in check.problems)
    # trimesh agrees once it merges by position
    assert not trimesh.Trimesh(mesh.vertices, mesh.faces).is_watertight
    with pytest.raises(ExportError, match="not a closed solid"):
        save_mesh(mesh, tmp_path / "pinched.stl")
    assert list(tmp_path.iterdir()) == []  # nothing written, no temporary file left


def split_near_edge(mesh: Mesh, offset: float) -> Mesh:
    """Split the first face at a point `offset` (a fraction of the way) off its first edge: a sliver."""
    i, j, k = mesh.faces[0]
    v = mesh.vertices
    mid = (v[i] + v[j]) / 2
    new = len(v)
    faces = np.vstack([mesh.faces[1:], [[i, new, k], [new, j, k], [i, j, new]]]).astype(np.int32)
    return Mesh(vertices=np.vstack([v, mid + offset * (v[k] - mid)]), faces=faces)


@pytest.mark.timeout(30)
def test_validator_small_area_check():
    mesh = grid_solid(np.full((3, 3), 2.0), 10.0, 10.0)
    assert check_as_written(mesh).ok
    # A sliver whose corners stay distinct in float32: its edges pair up, only the area check sees it.
    sliver = split_near_edge(mesh, 1e-4)
    p = sliver.vertices.astype(np.float32).astype(np.float64)[sliver.faces[-1]]
    area = 0.5 * np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0]))
    loose = check_as_written(sliver, min_area_mm2=area / 2)
    strict = check_as_written(sliver, min_area_mm2=area * 2)
    assert loose.ok and strict.closed and strict.manifold
    assert strict.degenerate_faces == 1 and not strict.ok and "slivers" in " ".join(strict.problems)
    # A sliver that float32 flattens onto its edge: the default limit catches it.
    flat = check_as_written(split_near_edge(mesh, 1e-9))
    assert flat.degenerate_faces == 1 and not flat.ok
    assert check_solid(split_near_edge(mesh, 1e-4)).ok  # the index check's zero-area limit lets it through


@pytest.mark.timeout(30)
def test_validator_sees_inward_winding_and_holes():
    mesh = grid_solid(np.full((4, 4), 1.0), 10.0, 10.0)
    inside_out = Mesh(vertices=mesh.vertices, faces=mesh.faces[:, ::-1].copy())
    check = check_as_written(inside_out)
    assert not check.outward and check.volume_mm3 < 0
    holed = Mesh(vertices=mesh.vertices, faces=mesh.faces[1:])
    assert not check_as_written(holed).closed


@pytest.mark.timeout(60)
def test_step_refusal_comes_before_any_file(tmp_path, monkeypatch):
    from tamp_os.export import step

    monkeypatch.setattr(step, "MAX_TRIANGLES", 10)
    litho = make_lithograph(np.eye(16), width_mm=30, resolution_px=16, mesher="grid")
    with pytest.raises(ExportError, match="STEP"):
        litho.save(tmp_path, formats=["stl", "step"])
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ExportError, match="STEP"):
        check_export(litho.mesh, [tmp_path / "x.stl", tmp_path / "x.step"])


# ---- the automatic scale bar fits, user bars are readable -------------------------------------


@pytest.mark.timeout(120)
@settings(max_examples=examples(150), deadline=None)
@given(
    width=st.floats(20.0, 300.0),
    depth=st.floats(5.0, 300.0),
    sample_m_per_mm=st.floats(1e-11, 1e-2),
    frame=st.sampled_from([0.0, 1.0, 3.5]),
)
def test_automatic_scale_bar_fits_every_width(width, depth, sample_m_per_mm, frame):
    need(liblouis_available(), "liblouis")
    furniture = Furniture(auto_scale_bar=True, sample_m_per_print_mm=sample_m_per_mm, frame_mm=frame, caption="x")
    placed = plan_furniture(width, depth, furniture).placed
    assert not placed.notes and placed.scale_bar_box is not None
    plate_w, plate_d = placed.plate_mm
    bx0, by0, bx1, by1 = placed.scale_bar_box
    lx0, ly0, lx1, ly1 = placed.scale_label_box
    assert MIN_BAR_MM - 1e-9 <= bx1 - bx0 <= 40.0 + 1e-9
    for x0, y0, x1, y1 in (placed.scale_bar_box, placed.scale_label_box, placed.caption_box):
        assert BORDER_MM - 1e-9 <= x0 and x1 <= plate_w - BORDER_MM + 1e-9 and 0 < y0 and y1 < placed.relief_origin_mm[1]
    assert lx0 - bx1 >= 3.0 or by0 - ly1 >= 3.0  # label beside or below the bar, apart from it
    # the bar stands for a round length, its value on the print
    from tamp_os.units import parse_length_m

    value_m = parse_length_m(placed.scale_label, "scale_bar")
    assert (bx1 - bx0) == pytest.approx(value_m / sample_m_per_mm, rel=1e-6)
    assert f"{value_m:.0e}"[0] in "125" and float(f"{value_m:.0e}") == pytest.approx(value_m, rel=1e-9)


@pytest.mark.timeout(60)
def test_narrow_prints_with_a_known_scale_get_a_bar_not_an_error():
    need(liblouis_available(), "liblouis")
    for width in (20.0, 25.0, 32.0, 39.0):
        litho = make_lithograph(np.random.default_rng(0).random((30, 30)), width_mm=width, pixel_size="2.614um", resolution_px=30)
        tactile = litho.report["tactile"]
        assert tactile["scale_bar_box_mm"] is not None, width
        x0, _, x1, _ = tactile["scale_bar_box_mm"]
        assert x1 - x0 >= MIN_BAR_MM
        assert tactile["scale_label_box_mm"][2] <= tactile["plate_mm"][0] - BORDER_MM + 1e-9


@pytest.mark.timeout(60)
def test_a_plate_without_room_leaves_the_bar_out_with_a_note():
    need(liblouis_available(), "liblouis")
    litho = make_lithograph(np.random.default_rng(0).random((20, 20)), width_mm=6, pixel_size="1um", resolution_px=20)
    assert litho.report["tactile"]["scale_bar_box_mm"] is None
    assert any("scale_bar" in w and "left out" in w for w in litho.report["warnings"])


@pytest.mark.timeout(60)
def test_a_chosen_bar_too_short_to_feel_is_refused():
    # 5 µm on a 100 mm print of 1024 pixels of 2.6 µm is about 0.19 mm (issue 16 point 5)
    with pytest.raises(ParameterError, match="scale_bar") as info:
        make_lithograph(np.random.default_rng(0).random((48, 64)), width_mm=100, pixel_size="42um", scale_bar="5um", resolution_px=32)
    assert "8 mm" in str(info.value) and "5 µm" in str(info.value)


# ---- orientation: the cut corner on every plate -----------------------------------------------


def corner_is_cut(mesh: Mesh, plate_w: float, plate_d: float, legs: float) -> bool:
    """Measured on the mesh: nothing beyond the 45° line at the top right, and faces on it."""
    v = mesh.vertices
    beyond = (plate_w - v[:, 0]) + (plate_d - v[:, 1])
    return bool((beyond >= legs - 1e-4).all() and (np.abs(beyond - legs) < 1e-4).sum() >= 4)


@pytest.mark.timeout(120)
@pytest.mark.parametrize(
    "extra",
    [{}, {"mesher": "grid"}, {"frame_mm": 2.0}, {"caption": "⠠⠋⠑"}, {"pixel_size": "1um"}, {"width_mm": 5.0}, {"base_mm": 0.1}],
)
def test_every_plate_has_its_cut_corner(extra):
    if "pixel_size" in extra:
        need(liblouis_available(), "liblouis")
    params = dict(dict(width_mm=40.0, resolution_px=24), **extra)
    litho = make_lithograph(np.random.default_rng(1).random((18, 24)), **params)
    plate_w, plate_d = litho.report["tactile"]["plate_mm"]
    lo, hi = litho.mesh.bounds_mm
    assert hi[0] == pytest.approx(plate_w, abs=1e-4) and hi[1] == pytest.approx(plate_d, abs=1e-4)
    legs = corner_legs_mm(plate_w, plate_d)
    assert legs == pytest.approx(min(CORNER_CUT_MM, 0.4 * min(plate_w, plate_d)))
    assert corner_is_cut(litho.mesh, plate_w, plate_d, legs)
    assert check_as_written(litho.mesh).ok
    none = make_lithograph(np.random.default_rng(1).random((18, 24)), orientation_corner="none", **params)
    w, d = none.mesh.bounds_mm[1][:2]
    assert ((w - none.mesh.vertices[:, 0]) + (d - none.mesh.vertices[:, 1]) < 1e-6).any()  # the corner is there


@pytest.mark.timeout(60)
def test_description_says_the_corner_only_when_cut(tmp_path):
    cut = make_lithograph(np.eye(20), width_mm=30)
    plain = make_lithograph(np.eye(20), width_mm=30, orientation_corner="none")
    assert "top right corner of the plate is cut off" in cut.metadata()["description"]
    assert "cut off" not in plain.metadata()["description"]

