"""Multi-panel figures (issue 23): panels found in figures composed from real micrographs and
synthetic pictures, single micrographs never split, each panel printed on its own with its
letter in braille, the overview, the controls and bad input."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import FIXTURES, need, run_cli, examples
from figures import (box_error, dark_fluorescence, fluorescence_composite, grid_colour, grid_white_boxes, micrograph, row_on_black,
                     save, stained_section, synthetic_texture, unequal, with_title)
from synthetic import sem_spheres
from synthetic_content import dark_line_network, dim_and_bright_beads, faint_grains

from tamp_os.clean.panels import detect_panels, parse_letter, reading_order
from tamp_os.errors import ParameterError
from tamp_os.params import LithoParams

REAL = ["fept_spheres_sem.png", "real/sem_fei_sio2_particles_35kx.tif", "real/confocal_membranes_cells3d.tif", "real/tvips_bin4.tif"]


def _need_fixtures(*names):
    for name in names:
        need((FIXTURES / name).is_file(), f"fixture {name}")


def _need_ocr():
    need(shutil.which("tesseract") is not None, "the tesseract command (tesseract-ocr)")


def _check(figure, layout, letters=True):
    assert layout.split, layout.reason
    assert len(layout.panels) == len(figure.boxes), (layout.boxes(), figure.boxes)
    for panel, truth in zip(layout.panels, figure.boxes):
        assert box_error(panel.box_px, truth) <= 0.02, (panel.box_px, truth)
    if letters:
        assert layout.labels() == figure.letters
        assert all(p.letter_read for p in layout.panels), layout.notes


# --- layouts --------------------------------------------------------------------------------


@pytest.mark.timeout(120)
def test_grid_of_real_micrographs_on_white_with_letters_in_boxes():
    _need_fixtures(*REAL)
    _need_ocr()
    figure = grid_white_boxes([micrograph(name, 300, 400) for name in REAL], cols=2)
    _check(figure, detect_panels(figure.image.astype(np.float32)))


@pytest.mark.timeout(120)
def test_row_on_black_with_upper_case_letters_and_a_dark_fluorescence_panel():
    """The dark panel's edges are as black as the gutter: it is found from its neighbours."""
    _need_fixtures(*REAL[:2])
    _need_ocr()
    panels = [micrograph(REAL[0], 300, 300), dark_fluorescence(300, 300, 7), micrograph(REAL[1], 300, 300)]
    figure = row_on_black(panels)
    layout = detect_panels(figure.image.astype(np.float32))
    _check(figure, layout)
    assert [p.found_by for p in layout.panels] == ["gutters", "regular grid", "gutters"]
    assert layout.gutter == "black"


@pytest.mark.timeout(120)
def test_unequal_panel_sizes():
    _need_fixtures("real/sem_fei_sio2_particles_10kx.tif")
    _need_ocr()
    figure = unequal(micrograph("real/sem_fei_sio2_particles_10kx.tif", 630, 420), [synthetic_texture(300, 400, 9), synthetic_texture(300, 400, 10)])
    _check(figure, detect_panels(figure.image.astype(np.float32)))


@pytest.mark.timeout(120)
def test_title_strip_is_not_a_panel_and_parenthesised_letters_read():
    _need_ocr()
    figure = with_title([synthetic_texture(300, 400, 11), synthetic_texture(300, 400, 12), synthetic_texture(300, 400, 13)])
    layout = detect_panels(figure.image.astype(np.float32))
    _check(figure, layout)
    assert any("text" in n for n in layout.notes)


@pytest.mark.timeout(120)
def test_panel_with_its_own_sem_data_band_keeps_it():
    """The Zeiss image with its white data zone (text, bar, logo) is one panel, band included."""
    _need_fixtures("test_tiff_Zeiss_SEM_1k.tif")
    zeiss = micrograph("test_tiff_Zeiss_SEM_1k.tif", 384, 512)
    figure = grid_white_boxes([zeiss, synthetic_texture(384, 512, 3)], cols=2, letters="")
    layout = detect_panels(figure.image.astype(np.float32), read_letters=False)
    _check(figure, layout, letters=False)


# --- single micrographs are never split --------------------------------------------------------

SINGLES = ["fept_spheres_sem.png", "test_tiff_Zeiss_SEM_1k.tif", "FEI-Helios-Ebeam-8bits.tif", "JEOL-SightX-TEM-mag-dummy.tif",
           "real/sem_fei_sio2_particles_35kx.tif", "real/sem_fei_sio2_particles_10kx.tif", "real/confocal_membranes_cells3d.tif",
           "real/aperio_cmu1_he_skin.svs", "real/tvips_bin4.tif", "real/confocal_beads_zstack_41z.tif"]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", SINGLES)
def test_single_micrographs_are_never_split(name):
    from tamp_os.read.image import read_image

    _need_fixtures(name)
    layout = detect_panels(read_image(FIXTURES / name).values)
    assert not layout.split and not layout.panels
    assert layout.reason  # says why it is whole


ALL_FIXTURES = sorted(p.relative_to(FIXTURES).as_posix() for p in [*FIXTURES.glob("*.*"), *FIXTURES.glob("real/*")]
                      if p.is_file() and p.suffix not in (".md", ".ser"))


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ALL_FIXTURES or ["fept_spheres_sem.png"])
def test_no_fixture_is_a_figure_or_an_ambiguous_one(name):
    """Every fixture is a single picture, read as convert reads it: not split, and nothing in it
    suggests a figure (so no figure talk is worth a warning)."""
    from tamp_os.lithograph.pipeline import read_source

    _need_fixtures(name)
    layout = detect_panels(read_source(FIXTURES / name, LithoParams()).values, read_letters=False)
    assert not layout.split and not layout.ambiguous, layout.reason
    assert layout.reason


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ["real/velox_talos_haadf_particles.emd", "test_tiff_Zeiss_SEM_1k.tif", "real/confocal_beads_zstack_41z.tif"])
def test_a_single_micrograph_through_convert_says_nothing_about_figures(name, tmp_path, capsys, caplog):
    """These three have straight bands of one colour (a dark support between particles, a data
    zone, beads on black), which once made convert warn that 'the figure is printed whole'."""
    from tamp_os.lithograph.figure import make_figure

    _need_fixtures(name)
    code, out, err = run_cli(capsys, "convert", FIXTURES / name, "-o", tmp_path, "--formats", "stl")
    assert code == 0, err
    said = (out + err + caplog.text).lower()
    assert "figure" not in said and "panel" not in said and "single picture" not in said, said
    made = make_figure(FIXTURES / name, width_mm=60)
    report = made.prints[0][1].report
    assert not made.split and report.panels.reason  # the reason stays in the report
    assert not any("figure" in w or "single picture" in w for w in report.warnings)


@pytest.mark.timeout(300)
def test_an_ambiguous_layout_is_still_warned_about(caplog):
    """A picture and a dark fluorescence panel on black: the dark one is cut into its spots and only
    one rectangular picture is left, so the layout cannot be split; that is worth saying."""
    from tamp_os.lithograph.figure import make_figure

    figure = row_on_black([synthetic_texture(300, 300, 3), dark_fluorescence(300, 300, 7)], letters="AB")
    layout = detect_panels(figure.image.astype(np.float32), read_letters=False)
    assert not layout.split and layout.ambiguous and "ambiguous" in layout.reason
    made = make_figure(figure.image, width_mm=60)
    assert any("printed whole" in w and "ambiguous" in w for w in made.prints[0][1].report.warnings)
    assert "ambiguous" in caplog.text


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", ["cell", "immunohistochemistry", "retina", "moon", "coins", "hubble_deep_field", "brick", "checkerboard", "binary_blobs"])
def test_bundled_sample_images_are_not_split(name):
    import skimage.data

    image = np.asarray(getattr(skimage.data, name)(), dtype=np.float32)
    rgb = image if image.ndim == 3 else None
    gray = image[..., :3] @ np.array([0.299, 0.587, 0.114], np.float32) if image.ndim == 3 else image
    assert not detect_panels(gray, rgb, read_letters=False).split


@pytest.mark.timeout(300)
@settings(max_examples=examples(25), deadline=None)
def _regular_grid(rows, cols, gutter, ph, pw, black, seed):
    """An equal grid of textured panels on a white or black gutter, and the true boxes (x, y, w, h)."""
    H, W = rows * ph + (rows + 1) * gutter, cols * pw + (cols + 1) * gutter
    image = np.full((H, W), 0 if black else 255, np.uint8)
    truth = []
    for i in range(rows * cols):
        r, c = divmod(i, cols)
        x, y = gutter + c * (pw + gutter), gutter + r * (ph + gutter)
        image[y:y + ph, x:x + pw] = synthetic_texture(ph, pw, seed + i)
        truth.append((x, y, pw, ph))
    return image, truth


@given(rows=st.integers(1, 3), cols=st.integers(1, 3), gutter=st.integers(3, 30), ph=st.integers(60, 160), pw=st.integers(60, 160),
       black=st.booleans(), seed=st.integers(0, 1000))
def test_any_regular_grid_is_found_exactly(rows, cols, gutter, ph, pw, black, seed):
    n = rows * cols
    image, truth = _regular_grid(rows, cols, gutter, ph, pw, black, seed)
    layout = detect_panels(image.astype(np.float32), read_letters=False)
    if n == 1:
        assert not layout.split
    else:
        assert layout.boxes() == truth
        assert layout.labels() == [str(i + 1) for i in range(n)]


def test_reading_order_rows_then_columns():
    boxes = [(500, 10, 100, 100), (10, 300, 100, 100), (10, 10, 100, 100), (500, 300, 100, 100)]
    order, rows = reading_order(boxes)
    assert order == [2, 0, 1, 3] and rows == ((0, 1), (2, 3))


def test_letters_parsed_as_ocr_gives_them():
    assert [parse_letter(t) for t in ("a", "(b)", "C.", "Cc", "oO", "ab", "1", "")] == ["a", "b", "C", "?c", "?o", None, None, None]


@pytest.mark.slow
@pytest.mark.timeout(60)
def test_detection_geometry_on_a_4000_by_3000_figure():
    """The geometry (gutters, cut, classification) of a large figure exact; its speed is measured,
    with letters, in benchmarks/bench_panels.py."""
    figure = grid_white_boxes([synthetic_texture(1460, 1960, s) for s in range(4)], cols=2, gutter=26, letters="")
    values = figure.image.astype(np.float32)
    layout = detect_panels(values, read_letters=False)
    assert layout.boxes() == figure.boxes


# --- printing ------------------------------------------------------------------------------------


def _closed(path):
    import trimesh

    mesh = trimesh.load(path, force="mesh")
    return mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, mesh


@pytest.fixture(scope="module")
def printed(tmp_path_factory):
    """A 2×2 figure with letters, converted by the command line at 60 mm, STL and SVG."""
    need(shutil.which("tesseract") is not None, "the tesseract command (tesseract-ocr)")
    folder = tmp_path_factory.mktemp("figure")
    figure = grid_white_boxes([synthetic_texture(150, 200, s) for s in range(4)], cols=2, gutter=14, size=22)
    path = save(figure, folder)
    from tamp_os.cli.commands import main

    assert main(["convert", str(path), "-o", str(folder / "out"), "--width-mm", "60", "--formats", "stl,svg"]) == 0
    return folder, path, figure


@pytest.mark.timeout(300)
def test_each_panel_printed_closed_sized_and_lettered_in_braille(printed):
    from tamp_os.tactile.braille import to_braille
    import json

    folder, path, figure = printed
    out = folder / "out"
    for letter in "abcd":
        ok, mesh = _closed(out / f"grid_white.panel-{letter}.stl")
        assert ok
        recipe = json.loads((out / f"grid_white.panel-{letter}.tamp.json").read_text())
        assert recipe["params"]["panel"] == letter and recipe["params"]["panel_boxes"].startswith("a=")
        description = (out / f"grid_white.panel-{letter}.description.txt").read_text()
        assert description.startswith(f"Panel {letter} of four")
        assert f"braille caption reads: {letter}." in description
        assert (out / f"grid_white.panel-{letter}.svg").is_file()
    # Sized as asked: the relief (the picture) is 60 mm wide; the plate adds its borders and caption.
    from tamp_os.lithograph.figure import make_figure

    made = make_figure(path, width_mm=60, formats=("stl",))
    for suffix, litho in made.prints[:-1]:
        assert litho.layout.width_mm == pytest.approx(60.0)
        assert litho.report.tactile["caption_braille"][0].startswith(to_braille(suffix[-1]))
        bounds = litho.mesh.bounds_mm
        assert bounds[1][0] - bounds[0][0] >= 60.0
        assert litho.report.relief_mm[1] == pytest.approx(60 * 150 / 200, rel=0.02)


@pytest.mark.timeout(300)
def test_overview_frames_letters_and_words(printed):
    folder, path, figure = printed
    out = folder / "out"
    ok, mesh = _closed(out / "grid_white.overview.stl")
    assert ok
    text = (out / "grid_white.overview.description.txt").read_text()
    from tamp_os.lithograph.figure import make_figure

    over = make_figure(path, width_mm=60).prints[-1][1]
    words = {k: w.words for k, w in over.report.panels.contents.items()}
    assert (f"Four panels in two rows: a, top left, {words['a']}; b, top right, {words['b']}; c, bottom left, {words['c']}; "
            f"d, bottom right, {words['d']}.") in text
    heights = over.heightmap
    base = over.params.base_mm
    # Each panel is a raised frame 1 mm high: the frame's rows stand at base + 1 mm along the panel's top edge.
    cols, rows = heights.shape[1] - 1, heights.shape[0] - 1
    W, H = figure.image.shape[1], figure.image.shape[0]
    for x, y, w, h in figure.boxes:
        r = int(round(y * rows / H))
        c0, c1 = int(round(x * cols / W)), int(round((x + w) * cols / W))
        assert np.allclose(heights[r, c0:c1], base + 1.0)
        inside = heights[int(round((y + h / 2) * rows / H)), c0 + 4:c1 - 4]
        assert inside.max() <= base + 0.5 + 1e-9  # the content hint stays lower than the frame
    # The four letters in braille inside the frames, besides the caption's dots: a = 1 dot, b/c/d = 2 cells.
    letters = over.report.panels["letters_braille"]
    assert letters == {"a": "⠁", "b": "⠰⠃", "c": "⠰⠉", "d": "⠰⠙"}
    caption_dots = sum(bin(ord(ch) - 0x2800).count("1") for line in over.report.tactile["caption_braille"] for ch in line)
    letter_dots = sum(bin(ord(ch) - 0x2800).count("1") for b in letters.values() for ch in b)
    assert over.report.tactile["braille_dots"] == caption_dots + letter_dots


@pytest.mark.timeout(300)
def test_recipe_rebuild_is_byte_identical(printed, capsys):
    folder, path, figure = printed
    out, again = folder / "out", folder / "again"
    code, _, err = run_cli(capsys, "convert", "--recipe", out / "grid_white.panel-c.tamp.json", "-o", again)
    assert code == 0, err
    # (SVG is left out: cairo numbers its surfaces per process, "surface11" vs "surface26", in every SVG it writes.)
    for name in ("grid_white.panel-c.stl", "grid_white.overview.stl", "grid_white.panel-c.description.txt", "grid_white.overview.description.txt"):
        assert (again / name).read_bytes() == (out / name).read_bytes(), name
    assert not (again / "grid_white.panel-a.stl").exists()  # only the panel of that recipe, and the overview


@pytest.mark.timeout(600)
def test_overview_words_agree_with_each_panels_print_and_not_with_the_choice():
    """Each panel's word in the overview names what that panel's own print raised (its content
    kind; members counted within a tenth), and the overview is the same whichever panels a run
    prints (its words come from the pixels and the parameters, never from the prints made)."""
    from content_support import agrees as _agrees

    from tamp_os.lithograph.figure import make_figure

    names = ["fept_spheres_sem.png", "real/sem_fei_sio2_particles_35kx.tif", "real/zeiss_sem_al2o3_grains.czi", "real/confocal_membranes_cells3d.tif"]
    _need_fixtures(*names)
    figure = grid_white_boxes([micrograph(name, 360, 480) for name in names], cols=2, letters="")
    made = make_figure(figure.image, width_mm=80)
    assert [s for s, _ in made.prints] == [".panel-1", ".panel-2", ".panel-3", ".panel-4", ".overview"]
    over = made.prints[-1][1]
    contents = over.report.panels.contents
    for suffix, litho in made.prints[:-1]:
        label = suffix[len(".panel-"):]
        assert _agrees(contents[label], litho.report), (label, contents[label], litho.report.content_kind, litho.report.legibility)
    assert over.description.count("particles") >= 1 and "network of lines" in over.description
    alone = make_figure(figure.image, width_mm=80, panel="3").prints[-1][1]
    assert alone.description == over.description
    assert np.array_equal(alone.heightmap, over.heightmap)


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_panel_choice_off_and_forced_grid(printed):
    from tamp_os.lithograph.figure import make_figure

    folder, path, figure = printed
    made = make_figure(path, panel="b,c")
    assert [s for s, _ in made.prints] == [".panel-b", ".panel-c", ".overview"]
    whole = make_figure(path, panels="off")
    assert [s for s, _ in whole.prints] == [""]
    forced = make_figure(path, panels="1x2", panel="1")
    assert forced.layout.reason.startswith("cut into the 1×2 grid")
    assert len(forced.layout.panels) == 2
    with pytest.raises(ParameterError, match="there is no panel e"):
        make_figure(path, panel="e")


def test_panels_parameter_is_checked():
    with pytest.raises(ParameterError, match="panels must be auto, off or a grid"):
        LithoParams(panels="three")
    with pytest.raises(ParameterError, match="panel_boxes"):
        LithoParams(panel_boxes="a=1,2,3")
    assert LithoParams(panels="2x3").panels == "2x3"


# --- bad input ------------------------------------------------------------------------------------


@pytest.mark.timeout(300)
def test_dozens_of_tiny_panels_are_refused_each_with_a_note(tmp_path):
    from tamp_os.lithograph.figure import make_figure

    figure = grid_white_boxes([synthetic_texture(36, 40, s) for s in range(48)], cols=8, gutter=6, letters="")
    made = make_figure(figure.image, width_mm=50)
    assert len(made.layout.panels) == 48
    refused = [n for n in made.notes if "is not printed on its own" in n]
    assert len(refused) == 48 and refused[0].startswith("panel 1 (40×36 pixels)") and "panels off" in refused[0]
    assert [s for s, _ in made.prints] == [""]  # printed whole instead
    assert any("printed whole" in w for w in made.prints[0][1].report.warnings)


@pytest.mark.timeout(300)
def test_unread_letters_fall_back_to_numbers_and_say_so():
    from tamp_os.lithograph.figure import make_figure

    figure = grid_white_boxes([synthetic_texture(150, 200, s) for s in range(2)], cols=2, gutter=14, letters="")
    made = make_figure(figure.image, width_mm=50)
    assert [s for s, _ in made.prints] == [".panel-1", ".panel-2", ".overview"]
    if shutil.which("tesseract"):
        assert any("no panel letters could be read" in n for n in made.notes)
    assert "no letter was read" in made.prints[0][1].description


@pytest.mark.timeout(300)
def test_panel_with_data_band_is_cleaned_and_scaled_on_its_own():
    """Printed, the Zeiss panel's data zone is cropped by its own pipeline and its own "200 µm"
    bar gives its scale (the fixture's pixel is 2.614 µm); the other panel reads its own bar."""
    from tamp_os.lithograph.figure import make_figure

    _need_fixtures("test_tiff_Zeiss_SEM_1k.tif", "fept_spheres_sem.png")
    _need_ocr()
    zeiss = micrograph("test_tiff_Zeiss_SEM_1k.tif", 768, 1024)
    figure = grid_white_boxes([zeiss, micrograph("fept_spheres_sem.png", 768, 1024)], cols=2, letters="ab", size=40)
    made = make_figure(figure.image, width_mm=80)
    _check(figure, made.layout)
    (_, a), (_, b) = made.prints[0], made.prints[1]
    assert a.report.crop["bottom_rows"] >= 60 and a.report.crop["source"] == "detected data band"
    assert a.report.pixel_size_source == "scale bar label"
    assert a.report.pixel_size_m == pytest.approx(2.614e-6, rel=0.05)
    assert b.report.pixel_size_m and abs(b.report.pixel_size_m / a.report.pixel_size_m - 1) > 0.5  # its own scale


# --- colour panels and what each panel shows ------------------------------------------------------


def _encodings(litho):
    return [(e.encoding, e.label) for e in litho.report.key]


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_colour_panels_take_the_channel_path_as_on_their_own(tmp_path):
    """A fluorescence composite, a grey SEM panel and an H&E section in one figure: each colour
    panel takes the channel or stain path with the key it gets printed alone, the grey panel does
    not, and every panel's heights are those of the panel cut out of the figure, saved as a PNG
    and printed as its own picture at the same width. Tolerance 1e-6 mm: the pixels are the same
    and the pipeline is deterministic, so only float rounding of the brightness (computed over
    arrays of another width) could differ, a millionth of a millimetre against a 0.12 mm layer."""
    from PIL import Image

    from tamp_os.lithograph.figure import make_figure
    from tamp_os.lithograph.pipeline import make_lithograph

    _need_fixtures("real/aperio_cmu1_he_skin.svs")
    _need_ocr()
    composite, stained = fluorescence_composite(300, 400), stained_section(300, 400)
    sem = (sem_spheres(300, 400).image * 255).astype(np.uint8)
    figure = grid_colour([composite, sem, stained], cols=3, letters="abc")
    path = tmp_path / "colour.png"
    Image.fromarray(figure.image).save(path)
    made = make_figure(path, width_mm=80)
    _check(figure, made.layout)
    prints = dict(made.prints)
    a, b, c = prints[".panel-a"], prints[".panel-b"], prints[".panel-c"]
    assert a.report.relief_style == "channels" and "fluorescence composite" in a.report.relief_reason
    assert _encodings(a) == _encodings(make_lithograph(composite, width_mm=80))
    assert {e for e, _ in _encodings(a)} == {"domes", "ridges", "dots"}
    assert c.report.relief_style == "channels" and "stained brightfield slide" in c.report.relief_reason
    assert _encodings(c) == _encodings(make_lithograph(stained, width_mm=80))
    assert [e for e, _ in _encodings(c)][:2] == ["domes", "ridges"]  # haematoxylin, eosin
    assert b.report.relief_style != "channels" and not b.report.key and "key" not in b.report.as_dict()
    for litho in (a, c):
        assert "its own texture" in litho.description and "key" in litho.description
        assert litho.report.as_dict()["key"]  # the key's facts in the report, as for a picture alone
    for letter, litho in (("a", a), ("b", b), ("c", c)):
        x, y, w, h = litho.report.panels.box_px
        cut = tmp_path / f"cut-{letter}.png"
        Image.fromarray(figure.image[y:y + h, x:x + w]).save(cut)
        own = make_lithograph(cut, width_mm=80)
        assert own.report.relief_style == litho.report.relief_style and _encodings(own) == _encodings(litho)
        assert litho.heightmap.shape == own.heightmap.shape
        assert float(np.abs(litho.heightmap - own.heightmap).max()) <= 1e-6, letter
    # the grey figure path is unchanged: a grey figure's panels carry no colour
    grey = grid_white_boxes([sem, sem], cols=2, letters="ab")
    from tamp_os.lithograph.figure import figure_colour
    from tamp_os.read.image import read_array

    assert figure_colour(grey.image, read_array(grey.image), LithoParams()) is None
    rgb_grey = np.repeat(grey.image[..., None], 3, axis=2)  # grey stored as RGB
    assert figure_colour(rgb_grey, read_array(rgb_grey), LithoParams()) is None


@pytest.mark.timeout(600)
def test_a_colour_figure_is_read_once_and_prints_as_when_read_again(tmp_path, monkeypatch):
    """The colour pixels of an RGB figure come from its one read (read_image's keep_colour), not
    from reading the file again per colour plane; they are the pixels the channel path's read
    gives (8-bit PNG and 16-bit TIFF, same values and precision), so every print's heights are
    those made when the file is read again."""
    import tifffile
    from PIL import Image

    import tamp_os.lithograph.figure as figure_module
    import tamp_os.lithograph.pipeline as pipeline_module
    import tamp_os.read.image as read_module
    from tamp_os.lithograph.figure import figure_colour, make_figure

    sem = (sem_spheres(300, 400).image * 255).astype(np.uint8)
    figure = grid_colour([fluorescence_composite(300, 400), sem], cols=2, letters="ab")
    png, tif = tmp_path / "colour.png", tmp_path / "colour16.tif"
    Image.fromarray(figure.image).save(png)
    tifffile.imwrite(tif, figure.image.astype(np.uint16) * 257, photometric="rgb")
    for path in (png, tif):
        picture = read_module.read_image(path, keep_colour=True)
        kept = figure_colour(path, picture, LithoParams(), pixels=picture.colour)
        again = figure_colour(path, picture, LithoParams())
        assert kept is not None and again is not None
        assert kept.dtype == again.dtype and np.array_equal(kept, again), path.name
    reads = []
    original = read_module.read_image

    def counted(*args, **kwargs):
        reads.append(args[0])
        return original(*args, **kwargs)

    monkeypatch.setattr(read_module, "read_image", counted)
    monkeypatch.setattr(pipeline_module, "read_image", counted)
    made = make_figure(png, width_mm=60)
    assert made.split and len(reads) == 1, reads
    monkeypatch.setattr(figure_module, "read_source", lambda source, params, keep_colour=False: pipeline_module.read_source(source, params))
    reads.clear()
    reread = make_figure(png, width_mm=60)
    assert len(reads) == 5  # the figure, then its red, green and blue planes after a first read of the file
    assert [s for s, _ in made.prints] == [s for s, _ in reread.prints]
    for (suffix, litho), (_, other) in zip(made.prints, reread.prints):
        assert np.array_equal(litho.heightmap, other.heightmap), suffix


@pytest.mark.timeout(600)
def test_a_single_colour_or_multichannel_picture_keeps_its_channel_path(tmp_path):
    """Not split, a picture is printed as make_lithograph prints it alone: a fluorescence composite
    and a two-channel CZI take the channel path with the same key (they printed as one grey
    relief when the read picture, which keeps only its brightness, was passed on)."""
    from PIL import Image

    from tamp_os.lithograph.figure import make_figure
    from tamp_os.lithograph.pipeline import make_lithograph

    _need_fixtures("real/zeiss_dapi_gfp_2ch.czi")
    png = tmp_path / "composite.png"
    Image.fromarray(fluorescence_composite(300, 400)).save(png)
    for path in (png, FIXTURES / "real/zeiss_dapi_gfp_2ch.czi"):
        made = make_figure(path, width_mm=60)
        assert not made.split and made.prints[0][1].report.relief_style == "channels", path.name
        alone = make_lithograph(path, width_mm=60)
        assert _encodings(made.prints[0][1]) == _encodings(alone)
        assert np.array_equal(made.prints[0][1].heightmap, alone.heightmap)
    grey = tmp_path / "grey.png"
    Image.fromarray(np.repeat((sem_spheres(300, 400).image * 255).astype(np.uint8)[..., None], 3, axis=2)).save(grey)
    assert make_figure(grey, width_mm=60).prints[0][1].report.relief_style != "channels"  # grey stored as RGB


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_overview_says_what_each_panel_shows_whichever_panels_are_printed(tmp_path):
    """Panels of known kinds (a population of ten beads, a network of grain boundaries, faint grains
    beside a mount, a fluorescence composite): the overview's description names each kind after
    its place, the report holds the words typed, and printing only panel b gives the same
    overview description (and heights) as printing them all."""
    from PIL import Image

    from tamp_os.lithograph.figure import make_figure
    from tamp_os.lithograph.content_word import ContentWord

    _need_ocr()
    truth = [dim_and_bright_beads(300, 400), dark_line_network(300, 400), faint_grains(300, 400)]
    panels = [(t.image * 255).astype(np.uint8) for t in truth] + [fluorescence_composite(300, 400)]
    figure = grid_colour(panels, cols=2)
    path = tmp_path / "kinds.png"
    Image.fromarray(figure.image).save(path)
    every = make_figure(path, width_mm=60)
    _check(figure, every.layout)
    over = every.prints[-1][1]
    words = over.report.panels.contents
    assert list(words) == ["a", "b", "c", "d"] and all(isinstance(w, ContentWord) for w in words.values())
    assert [w.kind for w in words.values()] == ["members", "lines", "grains", "fluorescence"]
    beads = int(truth[0].members.max())
    assert abs(words["a"].count - beads) <= 2, words["a"]  # "about": a coarse grid
    assert words["d"].count == 3
    sentence = "; ".join(f"{k}, {where}, {w.words}" for (k, w), where in zip(words.items(), ("top left", "top right", "bottom left", "bottom right")))
    assert f"Four panels in two rows: {sentence}." in over.description
    assert "particles (about" in words["a"].words and words["b"].words == "a network of lines" and words["c"].words == "grains"
    assert words["d"].words == "fluorescence, 3 colours"
    assert over.report.as_dict()["panels"]["contents"]["c"] == {"kind": "grains", "words": "grains", "count": None}
    for suffix, litho in every.prints[:-1]:  # each panel's report holds its own word
        assert litho.report.panels.contents == {suffix[-1]: words[suffix[-1]]}
    only_b = make_figure(path, width_mm=60, panel="b")
    assert [s for s, _ in only_b.prints] == [".panel-b", ".overview"]
    assert only_b.prints[-1][1].description == over.description
    assert np.array_equal(only_b.prints[-1][1].heightmap, over.heightmap)


@pytest.mark.timeout(300)
def test_pdf_has_one_page_per_panel_plus_the_overview(tmp_path, capsys):
    import pypdf

    figure = grid_white_boxes([synthetic_texture(150, 200, s) for s in range(2)], cols=2, gutter=14, letters="")
    path = save(figure, tmp_path)
    code, out, err = run_cli(capsys, "convert", path, "-o", tmp_path / "out", "--formats", "pdf", "--width-mm", "50")
    assert code == 0, err
    reader = pypdf.PdfReader(tmp_path / "out" / "grid_white.pages.pdf")
    assert len(reader.pages) == 3
    overview = pypdf.PdfReader(tmp_path / "out" / "grid_white.overview.pdf").pages[0].mediabox
    panel = pypdf.PdfReader(tmp_path / "out" / "grid_white.panel-1.pdf").pages[0].mediabox
    assert [float(v) for v in reader.pages[0].mediabox] == pytest.approx([float(v) for v in overview])
    assert [float(v) for v in reader.pages[1].mediabox] == pytest.approx([float(v) for v in panel])
    assert "grid_white.pages.pdf" in out
    # Each result line says which print it is, so a screen-reader user knows which panel is which.
    heads = [line.split(":")[0] for line in out.splitlines() if not line.startswith(" ")]
    assert heads == ["grid_white.png, panel 1", "grid_white.png, panel 2", "grid_white.png, overview"], out


@pytest.mark.timeout(300)
def test_web_app_prints_a_figures_panels_and_shows_the_overview(tmp_path):
    from tamp_os.gui.forms import params_from_form
    from tamp_os.gui.jobs import run_library

    class Form(dict):
        def getlist(self, name):
            return []

    params, errors = params_from_form(Form(panel="2", width_mm="50"))
    assert not errors.by_field and params.panel == "2"
    bad, errors = params_from_form(Form(panels="two by two"))
    assert bad is None and "Panels of a figure" in errors.by_field["panels"]
    figure = grid_white_boxes([synthetic_texture(150, 200, s) for s in range(2)], cols=2, gutter=14, letters="")
    made = run_library(save(figure, tmp_path), params, tmp_path, stem="fig")
    names = {p.name for p in made.all_written}
    assert "fig.panel-2.stl" in names and "fig.overview.stl" in names and "fig.panel-1.stl" not in names
    assert made.litho.description.startswith("Overview of the figure")
    assert [each.suffix for each in made.panels] == [".panel-2"] and made.panels[0].litho.description.startswith("Panel 2 of two")


@pytest.mark.timeout(300)
def test_batch_converts_a_figure_and_a_rerun_skips_it(tmp_path):
    import json

    from tamp_os.lithograph.batch import convert_one

    figure = grid_white_boxes([synthetic_texture(150, 200, s) for s in range(2)], cols=2, gutter=14, letters="")
    path = save(figure, tmp_path)
    params = LithoParams(width_mm=50).to_json()
    first = convert_one(str(path), str(tmp_path / "out"), params, stem="grid_white")
    assert first["status"] == "converted"
    assert {"grid_white.panel-1.stl", "grid_white.panel-2.stl", "grid_white.overview.stl", "grid_white.tamp.json"} <= set(first["outputs"])
    recipe = json.loads((tmp_path / "out" / "grid_white.tamp.json").read_text())
    assert recipe["panels"]["boxes"] == "1=14,14,200,150;2=228,14,200,150"
    assert "grid_white.panel-2.stl" in recipe["outputs"]
    again = convert_one(str(path), str(tmp_path / "out"), params, stem="grid_white")
    assert again["status"] == "skipped (up to date)"


@pytest.mark.timeout(120)
def test_a_very_large_figure_is_looked_at_every_few_pixels(monkeypatch):
    from tamp_os.clean import panels

    figure = grid_white_boxes([synthetic_texture(300, 400, s) for s in range(4)], cols=2, gutter=24, letters="")
    monkeypatch.setattr(panels, "MAX_DETECT_PIXELS", figure.image.size / 5)  # step 3
    layout = detect_panels(figure.image.astype(np.float32), read_letters=False)
    assert layout.figure_px == (figure.image.shape[1], figure.image.shape[0])
    assert layout.boxes() == figure.boxes  # cut on every third pixel, the edges then found at full resolution


# --- speed: letters read in process, large figures cut coarse and refined ----------------------------


def _large_figures():
    """The benchmark's 4000 × 3000 figures (benchmarks/bench_panels.py): white gutters with
    letters in boxes, and black gutters with a dark panel found from its neighbours."""
    yield grid_white_boxes([synthetic_texture(1460, 1960, s) for s in range(4)], cols=2, gutter=26, size=120)
    yield row_on_black([synthetic_texture(2800, 1300, 5), dark_fluorescence(2800, 1300, 6), synthetic_texture(2800, 1300, 7)],
                       gutter=40, top=160, size=120)


@pytest.mark.timeout(60)
def test_letters_are_read_in_process_by_tesserocr():
    """The OCR backend is the in-process API (the model loaded once), not the command: under
    TAMP_STRICT a missing tesserocr or model fails here."""
    from PIL import Image, ImageDraw

    from conftest import need_module
    from figures import font
    from tamp_os.clean import ocr

    need_module("tesserocr")
    need(ocr.tessdata_dir() is not None, "the eng Tesseract model (tesseract-ocr-eng)")
    assert ocr.backend() == "tesserocr", ocr._state.get("failed")
    page = Image.new("L", (90, 90), 255)
    ImageDraw.Draw(page).text((30, 25), "K", fill=0, font=font(30))
    assert ocr.read_text(page, 10, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ").strip() == "K"


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_large_figures_exact_boxes_and_letters_by_both_backends(monkeypatch):
    """4000 × 3000: cut on every second pixel, edges found again at full resolution (exact
    boxes, the dark panel's from its neighbours), corners searched coarse and the glyphs read
    from full resolution; the tesseract command (the fallback) reads the same letters."""
    from tamp_os.clean import ocr

    _need_ocr()
    for figure in _large_figures():
        values = figure.image.astype(np.float32)
        layout = detect_panels(values)
        assert layout.boxes() == figure.boxes
        assert layout.labels() == figure.letters and all(p.letter_read for p in layout.panels), layout.notes
        with monkeypatch.context() as m:
            m.setattr(ocr, "_state", {"failed": "the test asks for the command"})
            assert ocr.backend() == "command"
            assert detect_panels(values).labels() == figure.letters


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_the_whole_detection_with_letters_on_a_4000_by_3000_figure():
    """Letters read in process on a large figure (its speed, at most 0.3 s: benchmarks/bench_panels.py)."""
    from conftest import need_module
    from tamp_os.clean import ocr

    need_module("tesserocr")
    need(ocr.backend() == "tesserocr", "tesserocr with the eng model")
    figure = next(_large_figures())
    values = figure.image.astype(np.float32)
    layout = detect_panels(values)  # its CPU time, best of 5: benchmarks/bench_panels.py
    assert layout.labels() == figure.letters


@pytest.mark.timeout(300)
@settings(max_examples=examples(20), deadline=None)
@given(rows=st.integers(1, 3), cols=st.integers(1, 3), gutter=st.integers(6, 30), ph=st.integers(90, 200), pw=st.integers(90, 200),
       black=st.booleans(), seed=st.integers(0, 1000), step=st.integers(2, 3))
def test_a_grid_cut_on_every_few_pixels_is_refined_exactly(rows, cols, gutter, ph, pw, black, seed, step):
    """The coarse cut then the edges at full resolution give the same boxes as the full cut."""
    from tamp_os.clean import panels

    n = rows * cols
    image, truth = _regular_grid(rows, cols, gutter, ph, pw, black, seed)
    saved = panels.MAX_DETECT_PIXELS
    panels.MAX_DETECT_PIXELS = 1.001 * image.size / step ** 2  # (hypothesis runs many examples in one test: no monkeypatch fixture)
    try:
        layout = detect_panels(image.astype(np.float32), read_letters=False)
    finally:
        panels.MAX_DETECT_PIXELS = saved
    if n == 1:
        assert not layout.split
    else:
        assert layout.boxes() == truth
