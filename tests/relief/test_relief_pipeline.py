"""The relief styles as the product uses them: through make_lithograph, the CLI, the description,
the recipe, the batch report, `check`, `presets` and the 2-D graphics."""

import json
import subprocess
from xml.etree import ElementTree

import numpy as np
import pytest
import trimesh
from PIL import Image

from conftest import need
from tamp_os import make_lithograph
from tamp_os.cli.commands import main
from tamp_os.params import RELIEF_STYLES
from tamp_os.relief.styles import STYLES

pytestmark = pytest.mark.timeout(180)


def asymmetric(rows=60, cols=80) -> np.ndarray:
    """Dark ground with a bright disc at the top left and a smaller one at the bottom right."""
    yy, xx = np.mgrid[0:rows, 0:cols]
    img = np.full((rows, cols), 40.0)
    img[(yy - 15) ** 2 + (xx - 18) ** 2 < 12 ** 2] = 220
    img[(yy - 45) ** 2 + (xx - 62) ** 2 < 6 ** 2] = 220
    return img.astype(np.uint8)


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_parameter_lists_the_styles_the_relief_makes():
    assert RELIEF_STYLES == STYLES


@pytest.mark.parametrize("style", ["structure", "levels", "objects", "auto"])
def test_every_style_keeps_orientation_and_the_requested_bounds(style):
    litho = make_lithograph(asymmetric(), relief_style=style, width_mm=80, base_mm=1.5, relief_mm=2.5, scale_bar="off")
    h = litho.heightmap
    rows, cols = h.shape
    # Row 0 is the top of the image: the big disc (top left) stands above the ground near it.
    disc = h[int(0.25 * rows), int(0.22 * cols)]
    ground = h[int(0.8 * rows), int(0.15 * cols)]
    assert disc > ground + 1.0, (style, disc, ground)
    # Every style spans exactly base .. base + relief, the bounds the user asked for.
    assert h.min() == pytest.approx(1.5, abs=1e-9) and h.max() == pytest.approx(4.0, abs=1e-9)
    # And the written mesh's top is that height, its far edge (large y) is the image's top row.
    top = litho.mesh.vertices[np.argmax(litho.mesh.vertices[:, 2])]
    assert top[2] == pytest.approx(4.0, abs=1e-6)


def test_invert_raises_the_dark_ground_in_every_style():
    for style in ("structure", "levels"):
        plain = make_lithograph(asymmetric(), relief_style=style, scale_bar="off").heightmap
        inverted = make_lithograph(asymmetric(), relief_style=style, invert=True, scale_bar="off").heightmap
        r, c = int(0.25 * plain.shape[0]), int(0.22 * plain.shape[1])
        assert plain[r, c] > inverted[r, c] + 1.0, style


def test_report_description_and_recipe_carry_the_style_and_the_touch_check(tmp_path):
    litho = make_lithograph(asymmetric(), relief_style="levels", level_count=3)
    assert litho.report.relief_style == "levels"
    leg = litho.report.legibility
    assert leg["verdicts"] and len(leg["levels_mm"]) == 3
    steps = np.diff(sorted(leg["levels_mm"]))
    assert (steps >= 0.5).all()
    paths = litho.save(tmp_path)
    text = (tmp_path / "array.description.txt").read_text(encoding="utf-8")
    assert "3 flat levels" in text and "What a finger will find" in text
    recipe = json.loads(paths[-1].read_text(encoding="utf-8"))
    assert recipe["relief"]["style"] == "levels" and recipe["relief"]["legibility"]["verdicts"] == leg["verdicts"]


def test_a_flat_plate_is_said_as_such(tmp_path, capsys):
    flat = make_lithograph(np.full((30, 40), 7, np.uint8))
    text = flat.metadata()["description"]
    assert "flat plate with no raised parts" in text and "are raised" not in text
    src = tmp_path / "in"
    src.mkdir()
    Image.fromarray(np.full((30, 40), 7, np.uint8)).save(src / "flat.png")
    Image.fromarray(asymmetric()).save(src / "shapes.png")
    code, out, _ = run(capsys, "convert", src / "flat.png", "-o", tmp_path / "one")
    assert code == 0 and "a flat plate" in out and "height levels" not in out
    code, _, _ = run(capsys, "batch", src, "-o", tmp_path / "out", "--workers", "1")
    rows = (tmp_path / "out" / "batch-report.json").read_text(encoding="utf-8")
    report = {r["input"].split("/")[-1]: r for r in json.loads(rows)}
    assert any("flat plate" in w for w in report["flat.png"]["warnings"])
    assert not any("flat plate" in w for w in report["shapes.png"]["warnings"])
    assert report["shapes.png"]["touch"]


def test_check_measures_an_image_and_a_mesh(tmp_path, capsys):
    Image.fromarray(asymmetric()).save(tmp_path / "shapes.png")
    assert main(["convert", str(tmp_path / "shapes.png"), "-o", str(tmp_path), "--relief-style", "levels"]) == 0
    capsys.readouterr()
    code, out, _ = run(capsys, "check", tmp_path / "shapes.png", tmp_path / "shapes.stl", "--relief-style", "levels")
    assert code == 0
    image_part, mesh_part = out.split("shapes.stl (mesh")
    assert "relief style levels" in image_part and "height levels" in image_part.lower()
    assert "levels" in mesh_part.lower() or "level" in mesh_part.lower()
    code, _, err = run(capsys, "check", tmp_path / "nothing.stl")
    assert code == 1 and err.startswith("error:") and "Traceback" not in err


def test_check_reads_the_heights_of_a_mesh_back():
    from tamp_os.lithograph.check import heights_from_mesh

    litho = make_lithograph(asymmetric(), relief_style="levels", orientation_corner="none", scale_bar="off", width_mm=80)
    z = heights_from_mesh(litho.mesh.vertices, litho.mesh.faces, pitch_mm=0.5)
    # The disc at the top left of the image is high at the far left of the grid.
    assert z[int(0.25 * z.shape[0]), int(0.22 * z.shape[1])] == pytest.approx(litho.heightmap.max(), abs=0.2)
    assert np.median(z) == pytest.approx(np.median(litho.heightmap), abs=0.3)


def test_presets_never_suggest_high_for_noise(tmp_path, capsys):
    noise = (np.random.default_rng(3).random((68, 68)) * 255).astype(np.uint8)
    Image.fromarray(noise).save(tmp_path / "noise.png")
    code, out, _ = run(capsys, "presets", tmp_path / "noise.png")
    assert code == 0
    line = [x for x in out.splitlines() if x.startswith("suggested for")][0]
    assert "High" not in line and "mm" in line


def test_bad_style_parameters_are_one_clear_error(capsys, tmp_path):
    Image.fromarray(asymmetric()).save(tmp_path / "s.png")
    for option, value, needle in (("--relief-style", "swirl", "--relief-style"), ("--level-count", "7", "--level-count"),
                                  ("--detail-mm", "0.1", "--detail-mm")):
        code, _, err = run(capsys, "convert", tmp_path / "s.png", "-o", tmp_path / "o", option, value)
        assert code in (1, 2) and needle in err and err.count("error:") == 1, (option, err)
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_pdf_and_svg_graphics_at_true_size(tmp_path, capsys):
    need(subprocess.run(["which", "pdfinfo"], capture_output=True).returncode == 0, "pdfinfo (poppler-utils)")
    Image.fromarray(asymmetric()).save(tmp_path / "s.png")
    code, out, err = run(capsys, "convert", tmp_path / "s.png", "-o", tmp_path, "--formats", "stl,pdf,svg",
                         "--relief-style", "levels", "--width-mm", "80", "--pixel-size", "1um")
    assert code == 0, err
    stl = trimesh.load(tmp_path / "s.stl")
    w, d = stl.bounds[1][:2] - stl.bounds[0][:2]
    info = subprocess.run(["pdfinfo", str(tmp_path / "s.pdf")], capture_output=True, text=True).stdout
    size = [line for line in info.splitlines() if line.startswith("Page size")][0].split()
    assert float(size[2]) / 72 * 25.4 == pytest.approx(w, abs=0.5) and float(size[4]) / 72 * 25.4 == pytest.approx(d, abs=0.5)
    root = ElementTree.parse(tmp_path / "s.svg").getroot()
    assert root.get("width").endswith("mm") and float(root.get("width")[:-2]) == pytest.approx(w, abs=0.5)
    assert float(root.get("height")[:-2]) == pytest.approx(d, abs=0.5)
    # A page too small for the graphic is refused before any file of the run is written.
    code, _, err = run(capsys, "convert", tmp_path / "s.png", "-o", tmp_path / "big", "--formats", "stl,pdf",
                       "--width-mm", "400", "--page-size", "a4")
    assert code == 1 and "--page-size" in err
    assert not (tmp_path / "big").exists() or not list((tmp_path / "big").glob("*.stl"))


def _on_grid(a: np.ndarray, shape) -> np.ndarray:
    from scipy import ndimage

    zoom = (shape[0] / a.shape[0], shape[1] / a.shape[1])
    return ndimage.zoom(a, zoom, order=0, grid_mode=True, mode="grid-constant")[: shape[0], : shape[1]]


@pytest.mark.parametrize("width_mm", [60, 100, 150])
def test_sparse_strokes_are_raised_as_lines_at_every_width(width_mm):
    """A line drawing whose ink covers 1 % of the paper (under the stretch's 2nd percentile),
    through make_lithograph with its defaults: the strokes stand at least 0.5 mm over what they
    enclose (benchmarks/content_metrics.py), whatever the print width (before, the paper's
    stretched noise was raised and the strokes lay 1-2 mm below it)."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from content_metrics import lines_over_enclosed
    from synthetic_content import sparse_strokes

    truth = sparse_strokes(ink_pct=1.0)
    litho = make_lithograph(truth.image, width_mm=width_mm, scale_bar="off")
    h, mm = litho.heightmap, litho.layout.mm_per_px
    lines = _on_grid(truth.lines.astype(np.uint8), h.shape) > 0
    assert lines_over_enclosed(h, lines, mm) >= 0.5, litho.report.relief_reason


@pytest.mark.parametrize("width_mm", [60, 100, 150])
def test_every_bead_of_a_sparse_field_is_felt_at_every_width(width_mm):
    """Three beads covering 0.3 % of a dark field, through make_lithograph with its defaults:
    every one stands 0.5 mm over a 1.5 mm ring around it, and nothing else is raised."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from content_metrics import members_felt, spurious
    from synthetic_content import sparse_beads

    truth = sparse_beads(count=3, cover_pct=0.3)
    litho = make_lithograph(truth.image, width_mm=width_mm, scale_bar="off")
    h, mm = litho.heightmap, litho.layout.mm_per_px
    members = _on_grid(truth.members, h.shape)
    assert members_felt(h, members, mm) == 1.0, litho.report.relief_reason
    assert spurious(h, members > 0, mm, litho.params.base_mm) == 0
