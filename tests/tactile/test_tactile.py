"""Tactile furniture, measured from the output mesh (not from the layout code)."""

import numpy as np
import pytest
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from conftest import need

from tamp_os import make_lithograph
from tamp_os.tactile.braille import BrailleSpec, cell_dots, liblouis_available, to_braille
from tamp_os.cli.commands import main
from tamp_os.errors import ParameterError
from tamp_os.units import parse_length_m
from tamp_os.mesh.validate import check_solid

CAPTION = "FePt spheres imaged with a scanning electron microscope, 2024"


@pytest.fixture(scope="module", params=["adaptive", "grid"])
def litho(request):
    need(liblouis_available(), "liblouis (apt-get install liblouis-bin liblouis-data python3-louis)")
    y, x = np.mgrid[0:60, 0:80]
    image = 100 + 80 * np.sin(x / 7.0) * np.cos(y / 9.0)
    return make_lithograph(image, width_mm=80, resolution_px=80, pixel_size="1um", caption=CAPTION, frame_mm=2.0, mesher=request.param)


def raised_components(mesh, base):
    """Connected groups of faces above the plate top; each with its vertex indices and bbox."""
    faces = mesh.faces[(mesh.vertices[mesh.faces][:, :, 2] > base + 1e-3).any(axis=1)]
    n = len(mesh.vertices)
    a = np.concatenate([faces[:, 0], faces[:, 1], faces[:, 2]])
    b = np.concatenate([faces[:, 1], faces[:, 2], faces[:, 0]])
    graph = coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    used = np.unique(faces)
    groups = {}
    for v in used:
        groups.setdefault(label[v], []).append(v)
    out = []
    for members in groups.values():
        idx = np.array(members)
        p = mesh.vertices[idx]
        out.append({"idx": idx, "lo": p.min(axis=0), "hi": p.max(axis=0)})
    return out


def classify(litho):
    base = litho.params.base_mm
    comps = raised_components(litho.mesh, base)
    size = lambda c: c["hi"][:2] - c["lo"][:2]  # noqa: E731
    dots = [c for c in comps if np.all(size(c) < 2.0) and c["hi"][2] - base < 1.0]
    rest = [c for c in comps if not any(c is d for d in dots)]
    frame = max(rest, key=lambda c: np.prod(size(c)))
    bar = [c for c in rest if c is not frame and size(c)[0] > 8 * size(c)[1] / 5 and abs(size(c)[1] - 5.0) < 0.1]
    assert len(bar) == 1
    relief = [c for c in rest if c is not frame and c is not bar[0]]
    return base, dots, frame, bar[0], relief


def dot_measure(mesh, comp, base):
    p = mesh.vertices[comp["idx"]]
    ring = p[np.abs(p[:, 2] - base) < 1e-5]
    centre = ring[:, :2].mean(axis=0)
    diameter = 2 * np.linalg.norm(ring[:, :2] - centre, axis=1).max()
    return centre, diameter, p[:, 2].max() - base


def box_gap(lo1, hi1, lo2, hi2):
    dx = max(lo2[0] - hi1[0], lo1[0] - hi2[0], 0)
    dy = max(lo2[1] - hi1[1], lo1[1] - hi2[1], 0)
    return float(np.hypot(dx, dy))


def test_solid_is_closed_manifold(litho):
    check = check_solid(litho.mesh)
    assert check.ok, check.problems
    tm = trimesh.Trimesh(litho.mesh.vertices, litho.mesh.faces, process=False)
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0


def test_dots_count_size_and_spacing(litho):
    base, dots, *_ = classify(litho)
    spec = BrailleSpec()
    expected = sum(len(cell_dots(c)) for c in to_braille(CAPTION) + to_braille("20 µm"))
    assert len(dots) == expected
    measured = [dot_measure(litho.mesh, d, base) for d in dots]
    for _, diameter, height in measured:
        assert diameter == pytest.approx(spec.dot_diameter_mm, abs=0.05)
        assert height == pytest.approx(spec.dot_height_mm, abs=0.05)
    centres = np.array([c for c, _, _ in measured])
    # Caption dots (below the scale-bar row): rows 2.5 mm apart, lines 10 mm apart, columns on
    # a 6.0 mm cell lattice with the second column 2.5 mm right of the first.
    caption = centres[centres[:, 1] < centres[:, 1].max() - 8]
    ys = np.unique(np.round(caption[:, 1], 2))[::-1]
    steps = np.diff(ys) * -1
    assert all(min(abs(s - 2.5), abs(s - 5.0), abs(s - 7.5)) < 0.05 for s in steps if s < 8)
    assert any(abs(s - (10.0 - 5.0)) < 0.05 for s in steps)  # bottom row of one line to top of the next
    x0 = caption[:, 0].min()
    offsets = np.mod(caption[:, 0] - x0 + 0.1, 6.0) - 0.1
    assert np.all((np.abs(offsets) < 0.05) | (np.abs(offsets - 2.5) < 0.05))


def decode_cells(centres, spec):
    """Unicode braille of one line of dots, from their centres."""
    x0, ytop = centres[:, 0].min(), centres[:, 1].max()
    cells = {}
    for x, y in centres:
        j = int(round((x - x0) / spec.cell_spacing_mm - 0.2))
        col = int(round((x - x0 - j * spec.cell_spacing_mm) / spec.dot_spacing_mm))
        row = int(round((ytop - y) / spec.dot_spacing_mm))
        dot = {(0, 0): 1, (0, 1): 2, (0, 2): 3, (1, 0): 4, (1, 1): 5, (1, 2): 6}[(col, row)]
        cells[j] = cells.get(j, 0) | (1 << (dot - 1))
    return "".join(chr(0x2800 + cells.get(j, 0)) for j in range(max(cells) + 1))


def test_scale_bar_length_matches_its_braille_value(litho):
    from tamp_os.tactile.braille import Liblouis

    base, dots, frame, bar, relief = classify(litho)
    bar_len = bar["hi"][0] - bar["lo"][0]
    label_dots = [d for d in dots if d["lo"][0] > bar["hi"][0] and d["lo"][1] > bar["lo"][1] - 1]
    label = [dot_measure(litho.mesh, d, base)[0] for d in label_dots]
    braille = decode_cells(np.array(label), BrailleSpec())
    louis = Liblouis.system().binding
    need(louis is not None, "the liblouis Python binding for back-translation")
    text = louis.backTranslateString(["en-ueb-g2.ctb"], braille, mode=louis.ucBrl)
    value_m = parse_length_m(text)
    sample_m_per_mm = 1e-6 * 80 / 80  # 1 µm pixels, 80 source pixels across 80 mm
    assert bar_len == pytest.approx(value_m / sample_m_per_mm, rel=0.01)
    assert 10 <= bar_len <= 40
    gap = min(d["lo"][0] for d in label_dots) - bar["hi"][0]
    assert 3.0 <= gap <= 6.0
    assert bar["hi"][2] - base == pytest.approx(1.0, abs=0.01)


def test_clearance_between_elements(litho):
    base, dots, frame, bar, relief = classify(litho)
    label = [d for d in dots if d["lo"][1] > bar["lo"][1] - 1]
    caption = [d for d in dots if d["lo"][1] <= bar["lo"][1] - 1]
    group = lambda cs: (np.min([c["lo"] for c in cs], axis=0), np.max([c["hi"] for c in cs], axis=0))  # noqa: E731
    groups = {"caption": group(caption), "label": group(label), "bar": (bar["lo"], bar["hi"]), "relief": group(relief)}
    for name, (lo, hi) in groups.items():
        for other, (lo2, hi2) in groups.items():
            if name < other:
                assert box_gap(lo, hi, lo2, hi2) >= 3.0, (name, other)
    # The frame is a ring: everything else lies outside it by 3 mm, or inside it by 3 mm.
    f_lo, f_hi = frame["lo"], frame["hi"]
    width = litho.params.frame_mm
    r_lo, r_hi = groups["relief"]
    assert r_lo[0] - (f_lo[0] + width) >= 3.0 - 1e-6 and (f_hi[1] - width) - r_hi[1] >= 3.0 - 1e-6
    for name in ("caption", "label", "bar"):
        assert f_lo[1] - groups[name][1][1] >= 3.0, name


def test_orientation_corner_is_cut(litho):
    w, d = litho.report["tactile"]["plate_mm"]
    v = litho.mesh.vertices
    assert np.all((w - v[:, 0]) + (d - v[:, 1]) >= 8.0 - 1e-6)
    on_cut = np.abs((w - v[:, 0]) + (d - v[:, 1]) - 8.0) < 1e-6
    assert on_cut.sum() >= 4
    assert not covers(litho.mesh, w - 1.0, d - 1.0) and covers(litho.mesh, 1.0, d - 1.0)


def covers(mesh, x, y) -> bool:
    """Whether any face, seen from above, covers the point (x, y)."""
    t = mesh.vertices[mesh.faces][:, :, :2]
    p = np.array([x, y])

    def cross(a, b, c):
        return (b[:, 0] - a[:, 0]) * (c[1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[0] - a[:, 0])

    s = np.stack([cross(t[:, 0], t[:, 1], p), cross(t[:, 1], t[:, 2], p), cross(t[:, 2], t[:, 0], p)], axis=1)
    return bool(((s >= 0).all(axis=1) | (s <= 0).all(axis=1)).any())


def test_description_says_where_everything_is(litho, tmp_path):
    litho.save(tmp_path, formats=["3mf"])
    text = (tmp_path / f"{litho.name}.description.txt").read_text(encoding="utf-8")
    # what is raised: a content print of members says domes by the same lift, a brightness print the bright parts
    raised = "dome by the same lift" if litho.report.content_kind == "members" else "bright parts"
    for needle in ("top right corner", "scale bar", "20 µm", "braille caption", CAPTION, raised, "1 mm on the print = 1 µm"):
        assert needle in text, needle


def test_translation_matches_liblouis():
    need(liblouis_available(), "liblouis")
    from tamp_os.tactile import braille

    cases = {"5 µm": "⠼⠑⠀⠨⠍⠍", "FePt": "⠠⠋⠑⠠⠏⠞", "SEM 2024": "⠠⠠⠎⠑⠍⠀⠼⠃⠚⠃⠙"}
    for text, cells in cases.items():
        assert braille.to_braille(text, "en-ueb-g1.ctb").replace("\u2800", " ") == cells.replace("\u2800", " ")
    # The command-line fallback gives the same cells as the Python binding.
    command_only = braille.Liblouis(binding=None, command=braille.Liblouis.system().command)
    need(command_only.available, "the lou_translate command")
    fallback = {t: braille.to_braille(t, translator=command_only) for t in ("5 µm", "FePt Spheres, SEM", "Grade two contracts words")}
    assert fallback == {t: braille.to_braille(t) for t in fallback}


def test_unicode_braille_is_used_as_is_and_bad_sizes_are_refused():
    assert to_braille("⠠⠋⠑ ⠏⠞") == "⠠⠋⠑⠀⠏⠞"
    with pytest.raises(ParameterError, match="dot_height_mm"):
        make_lithograph(np.eye(20), caption="x", dot_height_mm=2.0)
    with pytest.raises(ParameterError, match="dot_diameter_mm"):
        BrailleSpec(dot_diameter_mm=2.0, dot_spacing_mm=2.2)


def test_scale_bar_needs_a_scale(capsys, tmp_path):
    with pytest.raises(ParameterError, match="pixel_size"):
        make_lithograph(np.eye(20), scale_bar="5um")
    # The command line says it in its own words.
    assert main(["convert", str(_png(tmp_path)), "-o", str(tmp_path), "--scale-bar", "5um"]) == 1
    assert "--pixel-size" in capsys.readouterr().err
    assert make_lithograph(np.eye(20), orientation_corner="none").report["tactile"] is None  # nothing asked, nothing added
    plain = make_lithograph(np.eye(20)).report["tactile"]  # the cut corner only (on every plate by default)
    assert plain["orientation"] and plain["scale_bar_box_mm"] is None and not plain["caption_braille"] and plain["braille_dots"] == 0


def test_braille_test_plate_command(tmp_path, capsys):
    need(liblouis_available(), "liblouis")
    assert main(["braille-test-plate", "-o", str(tmp_path), "--heights", "0.6,0.8", "--diameters", "1.5"]) == 0
    mesh = trimesh.load(tmp_path / "braille-test-plate.stl")
    assert mesh.is_watertight and mesh.volume > 0
    out = capsys.readouterr().out
    assert "2 rows" in out and "row 2: dots 0.8 mm high" in out
    heights = sorted({round(z, 2) for z in mesh.vertices[:, 2]})
    assert 1.5 + 0.6 in heights and 1.5 + 0.8 in heights


def _png(tmp_path):
    from PIL import Image

    path = tmp_path / "eye.png"
    Image.fromarray((np.eye(20) * 255).astype(np.uint8)).save(path)
    return path
