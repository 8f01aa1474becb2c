"""Tests an outside audit found missing (issue 25, point 6): cases that mutation testing showed
the suite could not tell apart in mesh/validate.py, tactile/braille.py, relief/legibility.py and
clean/scale.py."""

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


# --- mesh/validate.py -----------------------------------------------------------------------------

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


# --- tactile/braille.py ------------------------------------------------------------------------

def _dots_box(lines, spec, left, top):
    from tamp_os.tactile.braille import dot_centres

    centres = np.array(dot_centres(lines, spec, left, top))
    r = spec.dot_diameter_mm / 2
    return centres[:, 0].min() - r, centres[:, 1].min() - r, centres[:, 0].max() + r, centres[:, 1].max() + r


@settings(max_examples=examples(60), deadline=None)
@given(
    diameter=st.floats(1.2, 1.8), spacing=st.floats(2.2, 2.8), cell=st.floats(5.5, 7.6), line=st.floats(8.0, 15.0),
    cells=st.integers(1, 12), rows=st.integers(1, 4), eight_dot=st.booleans(),
    left=st.floats(-50, 50), top=st.floats(-50, 50),
)
def test_braille_block_size_is_the_bounding_box_of_full_cells(diameter, spacing, cell, line, cells, rows, eight_dot, left, top):
    from tamp_os.tactile.braille import BrailleSpec, block_size_mm

    spec = BrailleSpec(dot_diameter_mm=diameter, dot_spacing_mm=spacing, cell_spacing_mm=cell, line_spacing_mm=line)
    full = "⣿" if eight_dot else "⠿"
    lines = [full * cells] + [full * max(1, cells - i) for i in range(1, rows)]
    x0, y0, x1, y1 = _dots_box(lines, spec, left, top)
    width, height = block_size_mm(lines, spec)
    assert x0 == pytest.approx(left) and y1 == pytest.approx(top)
    assert width == pytest.approx(x1 - x0) and height == pytest.approx(y1 - y0)


def test_braille_block_of_sparse_cells_holds_every_dot():
    from tamp_os.tactile.braille import BrailleSpec, block_size_mm

    spec = BrailleSpec()
    lines = ["⠁⠂⠄", "⠈⠐", "⠠"]
    x0, y0, x1, y1 = _dots_box(lines, spec, 0.0, 0.0)
    width, height = block_size_mm(lines, spec)
    assert x0 >= -1e-9 and y1 <= 1e-9 and x1 <= width + 1e-9 and -y0 <= height + 1e-9
    assert block_size_mm([], spec) == (0.0, 0.0)


# --- relief/legibility.py ------------------------------------------------------------------------

def test_smallest_step_of_a_terrace_that_goes_up_and_down():
    from tamp_os.relief.legibility import assess

    # Bands 0, 1.5, 0.5, 2.0 mm: neighbours differ by 1.5, 1.0 and 1.5 mm. The smallest gap between
    # distinct levels (0 and 0.5) is 0.5 mm, but those two never touch: the step a finger meets is 1.0.
    band_px, pitch = 40, 0.25
    heights = np.repeat(np.array([0.0, 1.5, 0.5, 2.0]), band_px)[None, :].repeat(60, axis=0)
    result = assess(heights + 1.0, pitch, layer_mm=0.1)
    assert result.levels_used == 4
    assert result.smallest_step_mm == pytest.approx(1.0)
    descending = assess(heights[:, ::-1] + 1.0, pitch, layer_mm=0.1)
    assert descending.smallest_step_mm == pytest.approx(1.0)


def test_a_terrace_step_in_the_other_direction_counts_too():
    from tamp_os.relief.legibility import assess

    band_px, pitch = 40, 0.25
    heights = np.repeat(np.array([0.0, 1.5, 0.5, 2.0]), band_px)[:, None].repeat(60, axis=1)  # bands along rows
    result = assess(heights, pitch, layer_mm=0.1)
    assert result.levels_used == 4 and result.smallest_step_mm == pytest.approx(1.0)


# --- clean/scale.py: bad values in Hitachi and JEOL sidecars --------------------------------------

def _scale_with_sidecar(tmp_path, text):
    from tamp_os.clean.scale import read_pixel_size

    image = tmp_path / "sem.tif"
    image.write_bytes(b"")
    (tmp_path / "sem.txt").write_text(text)
    return read_pixel_size({}, {}, str(image), 100)


@pytest.mark.parametrize("value, warning", [
    ("abc", "present but not a number"), ("", "present but not a number"), ("nan", "present but not a number"),
    ("inf", "present but not a number"), ("0", "zero, negative or implausible"), ("-2.5", "zero, negative or implausible"),
    ("1e30", "zero, negative or implausible"),
])
def test_bad_hitachi_pixel_sizes_are_skipped_with_a_warning(tmp_path, value, warning):
    found = _scale_with_sidecar(tmp_path, f"[SemImageFile]\nPixelSize={value}\n")
    assert found.metres is None and found.provenance == "none"
    assert any("Hitachi sidecar sem.txt PixelSize (nm)" in w and warning in w for w in found.warnings), found.warnings


def test_good_hitachi_and_jeol_sidecars_read_exactly(tmp_path):
    found = _scale_with_sidecar(tmp_path, "[SemImageFile]\nDataSize=1280x960\n  PixelSize = 3.90625 \n")
    assert found.metres == pytest.approx(3.90625e-9) and found.warnings == ()
    found = _scale_with_sidecar(tmp_path, "$CM_FORMAT JEOL/SEM\n$$SM_MICRON_BAR 120\n$$SM_MICRON_MARKER 10 um\n")
    assert found.metres == pytest.approx(10e-6 / 120) and "JEOL" in found.provenance
    found = _scale_with_sidecar(tmp_path, "$$SM_MICRON_MARKER 500nm\n$$SM_MICRON_BAR 250\n")
    assert found.metres == pytest.approx(2e-9)


@pytest.mark.parametrize("bar, marker", [
    ("0", "10um"), ("-5", "10um"), ("abc", "10um"), ("120", "10furlong"), ("120", "um"), ("120", "0um"), ("120", ""),
])
def test_bad_jeol_values_give_no_scale(tmp_path, bar, marker):
    found = _scale_with_sidecar(tmp_path, f"$CM_FORMAT JEOL/SEM\n$$SM_MICRON_BAR {bar}\n$$SM_MICRON_MARKER {marker}\n")
    assert found.metres is None
    if marker and bar not in ("abc",):
        assert found.warnings and all("JEOL sidecar" in w for w in found.warnings), found.warnings


def test_a_jeol_sidecar_missing_one_key_is_not_a_source(tmp_path):
    for text in ("$$SM_MICRON_BAR 120\n", "$$SM_MICRON_MARKER 10um\n", "$CM_FORMAT JEOL/SEM\n"):
        found = _scale_with_sidecar(tmp_path, text)
        assert found.metres is None and found.warnings == ()


def test_a_bad_sidecar_falls_through_to_the_next_source(tmp_path):
    from tamp_os.clean.scale import read_pixel_size

    image = tmp_path / "sem.tif"
    image.write_bytes(b"")
    (tmp_path / "sem.txt").write_text("PixelSize=0\n")
    found = read_pixel_size({"imagej_metadata": {"unit": "micron"}}, {282: (4, 1)}, str(image), 100)
    assert found.metres == pytest.approx(0.25e-6) and "ImageJ" in found.provenance
    assert any("Hitachi" in w for w in found.warnings)


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


# --- tactile/braille.py: wrapping and the translators --------------------------------------------

words_of_cells = st.lists(st.text(alphabet="⠁⠃⠉⠙⠑⠋", min_size=1, max_size=14), min_size=1, max_size=12)


@settings(max_examples=examples(120), deadline=None)
@given(words=words_of_cells, max_cells=st.integers(1, 10))
def test_wrapped_braille_lines_are_greedy_and_lose_nothing(words, max_cells):
    from tamp_os.tactile.braille import BLANK, wrap_cells

    lines = wrap_cells(BLANK.join(words), max_cells)
    assert all(1 <= len(line) <= max_cells for line in lines)
    assert "".join("".join(line.split(BLANK)) for line in lines) == "".join(words)  # every cell, in order
    for word in words:
        if len(word) <= max_cells:  # a word that fits a line is never split
            assert any(word in line.split(BLANK) for line in lines), (word, lines)
    for line, following in zip(lines, lines[1:]):
        first = following.split(BLANK)[0]
        if BLANK not in line and len(line) == max_cells:
            continue  # a piece of a long word
        assert len(line) + 1 + len(first) > max_cells  # greedy: the next word did not fit


def test_wrapping_examples_and_a_plate_too_narrow():
    from tamp_os.errors import ParameterError
    from tamp_os.tactile.braille import BLANK, wrap_cells

    b = BLANK
    assert wrap_cells(f"⠁⠁{b}⠃⠃{b}⠉⠉", 5) == [f"⠁⠁{b}⠃⠃", "⠉⠉"]
    assert wrap_cells(f"⠁⠁{b}⠃⠃{b}⠉⠉", 8) == [f"⠁⠁{b}⠃⠃{b}⠉⠉"]
    assert wrap_cells("⠁⠃⠉⠙⠑⠋⠛", 3) == ["⠁⠃⠉", "⠙⠑⠋", "⠛"]
    assert wrap_cells(f"⠁{b}⠃⠉⠙⠑⠋⠛{b}⠓", 3) == ["⠁", "⠃⠉⠙", "⠑⠋⠛", "⠓"]
    assert wrap_cells("", 4) == []
    with pytest.raises(ParameterError, match="too narrow"):
        wrap_cells("⠁", 0)


def test_braille_ascii_folds_lower_case_onto_the_same_cells():
    from tamp_os.tactile.braille import _fold

    assert [_fold(c) for c in "az`{|}~"] == list("AZ@[\\]^")
    assert [_fold(c) for c in "AZ@_ 09"] == list("AZ@_ 09")


def test_the_lou_translate_command_and_its_failures(tmp_path):
    from conftest import need

    from tamp_os.errors import MissingDependencyError, ParameterError
    from tamp_os.tactile.braille import Liblouis

    command = Liblouis.system().command
    need(command is not None, "liblouis' lou_translate (apt-get install liblouis-bin)")
    by_command = Liblouis(binding=None, command=command)
    assert by_command.translate("abc", "en-ueb-g1.ctb") == "⠁⠃⠉"
    assert by_command.translate("ABC", "en-ueb-g1.ctb").endswith("⠁⠃⠉")
    assert by_command.translate("中", "en-ueb-g1.ctb") == "\u2873"  # a character the table lacks: marked for refusal
    if Liblouis.system().binding is not None:
        assert Liblouis.system().translate("5 µm", "en-ueb-g1.ctb") == by_command.translate("5 µm", "en-ueb-g1.ctb")
    failing = tmp_path / "lou_translate"
    failing.write_text("#!/bin/sh\necho 'bad table' >&2\nexit 3\n")
    failing.chmod(0o755)
    with pytest.raises(ParameterError, match="lou_translate failed \\(bad table\\)"):
        Liblouis(binding=None, command=str(failing)).translate("abc", "x.ctb")
    with pytest.raises(MissingDependencyError):
        Liblouis(binding=None, command=None).translate("abc", "x.ctb")
    assert not Liblouis(binding=None, command=None).available and by_command.available


def test_a_binding_that_refuses_a_table_is_a_parameter_error():
    from tamp_os.errors import ParameterError
    from tamp_os.tactile.braille import Liblouis

    class Binding:
        dotsIO, ucBrl = 1, 2

        @staticmethod
        def translateString(tables, text, mode=0):
            assert mode == 3 and tables == ["t.ctb"]
            if text == "bad":
                raise RuntimeError("cannot compile table")
            return "⠁"

    louis = Liblouis(binding=Binding, command=None)
    assert louis.translate("a", "t.ctb") == "⠁"
    with pytest.raises(ParameterError, match="braille table 't.ctb': liblouis cannot use it \\(cannot compile table\\)"):
        louis.translate("bad", "t.ctb")
