"""PDF and SVG tactile graphics (swell paper, embossers): read back with pdfinfo, pypdf, pdftoppm and an XML parser."""

import importlib.util
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from conftest import need, examples
from tamp_os.errors import ParameterError
from tamp_os.export import textures as tx
from tamp_os.export.graphic2d import layout_graphic, regions_from_image
from tamp_os.tactile.braille import liblouis_available
from tamp_os.tactile.furniture import Furniture

MM_PER_PT = 25.4 / 72
CAPTION = "⠉⠕⠊⠝⠎⠀⠁⠞⠀⠞⠓⠑⠀⠍⠊⠉⠗⠕⠎⠉⠕⠏⠑"


def _cairo_ok():
    need(importlib.util.find_spec("cairo") is not None, "pycairo")


def _levels_map(rows=60, cols=80):
    """Three large blocks, one per level, plus background: the worst case for solid black."""
    regions = np.zeros((rows, cols), dtype=np.int32)
    regions[5:30, 5:35] = 1
    regions[5:30, 42:75] = 2
    regions[35:56, 10:70] = 3
    return regions


def _graphic(regions=None, mm_per_px=1.0, caption=CAPTION, bar=True):
    if bar:  # the scale value ("20 µm") is translated to braille by liblouis
        need(liblouis_available(), "liblouis")
    furniture = Furniture(caption=caption, scale_bar_m=20e-6 if bar else None, sample_m_per_print_mm=1e-6)
    return layout_graphic(_levels_map() if regions is None else regions, mm_per_px, furniture)


def _popcount_dots(*texts):
    """Braille dots counted straight from the Unicode cells (bits 0-7 of the code point)."""
    return sum(bin(ord(ch) - 0x2800).count("1") for text in texts for ch in text if "\u2800" <= ch <= "\u28ff")


def _pdfinfo_size_pt(path):
    out = subprocess.run(["pdfinfo", str(path)], capture_output=True, text=True, timeout=30).stdout
    w, h = re.search(r"Page size:\s+([0-9.]+) x ([0-9.]+) pts", out).groups()
    return float(w), float(h)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("page_size", [None, "a4", "letter"])
def test_pdf_page_size_in_pdfinfo(tmp_path, page_size):
    _cairo_ok()
    need(shutil.which("pdfinfo") is not None, "pdfinfo (poppler-utils)")
    from tamp_os.export.tactile2d import save_graphic

    g = _graphic(caption=None, bar=False)
    path = save_graphic(g, tmp_path / "g.pdf", page_size=page_size, metadata={"title": "blocks"})
    w_pt, h_pt = _pdfinfo_size_pt(path)
    expected_mm = {None: g.plate_mm, "a4": (210.0, 297.0), "letter": (215.9, 279.4)}[page_size]
    assert w_pt * MM_PER_PT == pytest.approx(expected_mm[0], abs=0.01)
    assert h_pt * MM_PER_PT == pytest.approx(expected_mm[1], abs=0.01)


@pytest.mark.timeout(60)
def test_wide_graphic_turns_the_page_and_too_large_one_fails(tmp_path):
    _cairo_ok()
    need(shutil.which("pdfinfo") is not None, "pdfinfo (poppler-utils)")
    from tamp_os.export.tactile2d import save_graphic

    wide = _graphic(np.zeros((40, 240), dtype=np.int32), caption=None, bar=False)  # 256 x 56 mm
    w_pt, h_pt = _pdfinfo_size_pt(save_graphic(wide, tmp_path / "wide.pdf", page_size="a4"))
    assert (w_pt * MM_PER_PT, h_pt * MM_PER_PT) == pytest.approx((297.0, 210.0), abs=0.01)
    huge = _graphic(np.zeros((300, 300), dtype=np.int32), caption=None, bar=False)
    with pytest.raises(ParameterError, match=r"page_size a4.*316\.0 × 316\.0 mm"):
        save_graphic(huge, tmp_path / "huge.pdf", page_size="a4")
    assert not list(tmp_path.glob("huge*"))
    with pytest.raises(ParameterError, match="page_size"):
        save_graphic(wide, tmp_path / "x.pdf", page_size="a3")


@pytest.mark.timeout(60)
def test_pdf_is_vector_with_title(tmp_path):
    _cairo_ok()
    need(importlib.util.find_spec("pypdf") is not None, "pypdf")
    import pypdf

    from tamp_os.export.tactile2d import save_graphic

    g = _graphic()
    reader = pypdf.PdfReader(save_graphic(g, tmp_path / "g.pdf", metadata={"title": "Coins & <dots>"}))
    assert len(reader.pages) == 1
    page = reader.pages[0]
    xobjects = page["/Resources"].get("/XObject", {})
    assert not any(xobjects[name].get_object().get("/Subtype") == "/Image" for name in xobjects)
    ops = [op for _, op in pypdf.generic.ContentStream(page.get_contents(), reader).operations]
    assert ops.count(b"c") >= 4 * g.braille_dots  # every braille dot is a curve, not a bitmap
    assert b"l" in ops and b"S" in ops and b"f" in ops  # lines stroked, dots filled
    assert reader.metadata.title == "Coins & <dots>"


def _svg_paths(root):
    ns = {"svg": "http://www.w3.org/2000/svg"}
    for path in root.iterfind(".//svg:path", ns):
        style, d = path.get("style", ""), path.get("d", "")
        numbers = np.array([float(v) for v in re.findall(r"-?[0-9.]+(?:e-?[0-9]+)?", d)]).reshape(-1, 2)
        yield style, d, numbers


def _braille_dot_circles(svg_bytes, diameter_mm):
    """Filled, single-subpath paths whose extent is one braille dot across."""
    count = 0
    for style, d, pts in _svg_paths(ET.fromstring(svg_bytes)):
        if "fill:none" in style or d.count("M") != 1 or len(pts) == 0:
            continue
        extent = pts.max(axis=0) - pts.min(axis=0)
        if np.allclose(extent, diameter_mm, atol=0.05):
            count += 1
    return count


@pytest.mark.timeout(120)
@settings(max_examples=examples(8), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(caption=st.text(alphabet=[chr(c) for c in range(0x2801, 0x2840)] + ["\u2800"], min_size=1, max_size=40))
def test_svg_size_in_mm_and_one_circle_per_braille_dot(tmp_path, caption):
    _cairo_ok()
    from tamp_os.export.tactile2d import save_graphic

    g = _graphic(caption=caption)
    data = save_graphic(g, tmp_path / "g.svg", metadata={"title": "a & b"}).read_bytes()
    root = ET.fromstring(data)
    assert root.get("width") == f"{g.plate_mm[0]:g}mm" or float(root.get("width")[:-2]) == pytest.approx(g.plate_mm[0])
    assert root.get("height").endswith("mm") and float(root.get("height")[:-2]) == pytest.approx(g.plate_mm[1], abs=1e-3)
    assert [float(v) for v in root.get("viewBox").split()] == pytest.approx([0, 0, *g.plate_mm], abs=1e-3)
    assert root.find("{http://www.w3.org/2000/svg}title").text == "a & b"
    expected = _popcount_dots(caption, g.scale_bar.label.lines[0])
    assert g.braille_dots == expected
    assert _braille_dot_circles(data, g.spec.dot_diameter_mm) == expected


def _render_gray(pdf, tmp_path, dpi):
    need(shutil.which("pdftoppm") is not None, "pdftoppm (poppler-utils)")
    from PIL import Image

    subprocess.run(["pdftoppm", "-r", str(dpi), "-gray", "-png", "-singlefile", str(pdf), str(tmp_path / "r")], check=True, timeout=60)
    return np.asarray(Image.open(tmp_path / "r.png").convert("L")) < 128


@pytest.mark.timeout(60)
def test_no_large_solid_black_area(tmp_path):
    """Swell paper blisters under large black areas: no black blob may hold a disc wider than 2.2 mm."""
    _cairo_ok()
    from tamp_os.export.tactile2d import save_graphic

    dpi = 200
    black = _render_gray(save_graphic(_graphic(), tmp_path / "g.pdf"), tmp_path, dpi)
    px_per_mm = dpi / 25.4
    assert black.mean() > 0.02  # something is drawn
    widest_mm = 2 * ndimage.distance_transform_edt(black).max() / px_per_mm
    assert widest_mm <= 2.2, f"a black area {widest_mm:.2f} mm across would blister"


@pytest.mark.timeout(60)
def test_top_of_map_is_top_of_page(tmp_path):
    """Orientation: a block at the map's top left is drawn at the page's top left, once."""
    _cairo_ok()
    from tamp_os.export.tactile2d import save_graphic

    regions = np.zeros((60, 90), dtype=np.int32)
    regions[2:20, 2:30] = 2
    g = layout_graphic(regions, 1.0, Furniture())
    dpi = 50
    black = _render_gray(save_graphic(g, tmp_path / "g.pdf"), tmp_path, dpi)
    s = dpi / 25.4
    x0, y0, x1, y1 = g.picture_box
    page_h = g.plate_mm[1]
    picture = black[int((page_h - y1) * s):int((page_h - y0) * s), int(x0 * s):int(x1 * s)]
    h, w = picture.shape
    assert picture[: h // 2, : w // 2].sum() > 0
    assert picture[h // 2:, :].sum() == 0 and picture[:, w // 2:].sum() == 0


def _box_gap(a, b):
    dx = max(a[0] - b[2], b[0] - a[2], 0.0)
    dy = max(a[1] - b[3], b[1] - a[3], 0.0)
    return float(np.hypot(dx, dy))


@pytest.mark.timeout(30)
@settings(max_examples=examples(25), deadline=None)
@given(rows=st.integers(10, 120), cols=st.integers(30, 160), mm_per_px=st.floats(0.3, 1.5),
       caption=st.text(alphabet=["⠁", "⠃", "⠉", "⠿", "\u2800"], min_size=0, max_size=60))
def test_layout_keeps_elements_apart_and_on_the_plate(rows, cols, mm_per_px, caption):
    need(liblouis_available(), "liblouis")
    try:
        g = layout_graphic(np.zeros((rows, cols), np.int32), mm_per_px, Furniture(caption=caption or None, scale_bar_m=10e-6, sample_m_per_print_mm=1e-6))
    except ParameterError as exc:  # as on the 3-D plate: a bar wider than a narrow plate, a caption deeper than the picture
        assert "scale_bar" in str(exc) or "caption" in str(exc)
        return
    boxes = list(g.element_boxes().values())
    for i, a in enumerate(boxes):
        assert a[0] >= 0 and a[1] >= 0 and a[2] <= g.plate_mm[0] + 1e-9 and a[3] <= g.plate_mm[1] + 1e-9
        for b in boxes[i + 1:]:
            assert _box_gap(a, b) >= 3.0 - 1e-9
    # The corner line (x + y = w + d - c) keeps 3 mm from the picture's top-right corner.
    w, d = g.plate_mm
    px1, py1 = g.picture_box[2:]
    assert (w + d - g.corner_cut_mm - (px1 + py1)) / np.sqrt(2) >= 3.0


@pytest.mark.timeout(30)
@settings(max_examples=examples(30), deadline=None)
@given(r0=st.integers(0, 30), c0=st.integers(0, 30), h=st.integers(1, 40), w=st.integers(1, 40), p=st.floats(0.2, 1.0))
def test_textures_stay_inside_their_region(r0, c0, h, w, p):
    mask = np.zeros((80, 80), bool)
    mask[r0:r0 + h, c0:c0 + w] = True
    origin = (7.0, 11.0)
    # The block's edges in mm (top row at the far edge).
    x0, x1 = origin[0] + c0 * p, origin[0] + (c0 + w) * p
    y1, y0 = origin[1] + (80 - r0) * p, origin[1] + (80 - r0 - h) * p

    def room(x, y):
        return min(x - x0, x1 - x, y - y0, y1 - y)

    dots = tx.texture_dots_mm(mask, p, origin)
    for x, y in dots:  # a thin part's dot sits nearer the outline, with paper still clear between them
        assert room(x, y) >= tx.THIN_INSET_MM + tx.DOT_DIAMETER_MM / 2 - p
    if len(dots) >= 2:
        gaps = np.hypot(*(dots[:, None, :] - dots[None, :, :]).transpose(2, 0, 1))
        assert gaps[~np.eye(len(dots), dtype=bool)].min() >= tx.DOT_PITCH_MM - 1e-6
    for a, b in tx.texture_lines_mm(mask, p, origin):
        assert np.hypot(*(b - a)) >= tx.MIN_SEGMENT_MM - 1e-9
        for point in (a, b):
            assert room(*point) >= tx.INSET_MM + tx.LINE_WIDTH_MM / 2 - p
    if min(h, w) * p < 2 * (tx.INSET_MM + tx.DOT_DIAMETER_MM):
        assert len(tx.texture_dots_mm(mask, p, origin)) <= max(1, int(max(h, w) * p / tx.DOT_PITCH_MM) + 1)


@pytest.mark.timeout(30)
def test_regions_from_image_levels_follow_brightness():
    ramp = np.tile(np.linspace(0, 1, 200), (20, 1))
    regions = regions_from_image(ramp, 3)
    assert regions.min() == 0 and regions.max() == 3
    assert np.all(np.diff(regions, axis=1) >= 0)  # brighter never maps lower
    assert np.unique(regions_from_image(np.full((10, 10), 0.5), 2)).size == 1  # uniform: one level, no error
    with pytest.raises(ParameterError, match="levels"):
        regions_from_image(ramp, 4)


@pytest.mark.timeout(30)
def test_small_specks_merge_into_their_surroundings():
    regions = np.ones((40, 40), np.int32)
    regions[10, 10] = 3  # one 0.5 x 0.5 mm speck: too small to feel
    regions[20:35, 20:35] = 2  # 7.5 x 7.5 mm: kept
    merged = tx.merge_small_regions(regions, 0.5)
    assert merged[10, 10] == 1
    assert (merged[20:35, 20:35] == 2).all() and (merged == 3).sum() == 0


def _cells_in_cytoplasm(mm_per_px=0.25):
    """Nuclei (discs 5 mm across, outline texture) each in a ring of cytoplasm 3 mm wide (dots):
    a channel print's thin region, where no dot fits INSET_MM from both of its outlines."""
    rows = cols = 240
    yy, xx = np.mgrid[:rows, :cols] * mm_per_px
    regions = np.zeros((rows, cols), np.int32)
    for cy in (10.0, 25.0, 40.0, 55.0):
        for cx in (10.0, 25.0, 40.0, 55.0):
            d = np.hypot(yy - cy, xx - cx)
            regions[(d < 5.5) & (regions == 0)] = 2
            regions[d < 2.5] = 1
    return regions


@pytest.mark.timeout(60)
def test_thin_dotted_region_keeps_its_dots_on_the_pdf(tmp_path):
    """Dots read back from the PDF: a 3 mm ring of cytoplasm carries dots along it, none in the
    nuclei or the background, every two at least 3 mm apart (BANA), each clear of the outline,
    and most of the ring within 3 mm of a dot; no black blob wide enough to blister."""
    _cairo_ok()
    from paper_support import dot_cover, filled_round_dots_mm
    from tamp_os.export.tactile2d import save_graphic

    p = 0.25
    regions = _cells_in_cytoplasm(p)
    g = layout_graphic(regions, p, Furniture(), textures={1: "outline", 2: "dots"})
    pdf = save_graphic(g, tmp_path / "cells.pdf")
    dots = np.array([(x, y) for x, y, d in filled_round_dots_mm(pdf) if abs(d - tx.DOT_DIAMETER_MM) < 0.05])
    ring, nuclei = dot_cover(regions == 2, p, g.picture_origin_mm, dots), dot_cover(regions == 1, p, g.picture_origin_mm, dots)
    background = dot_cover(regions == 0, p, g.picture_origin_mm, dots)
    assert nuclei.dots == 0 and background.dots == 0
    assert ring.dots == len(dots) >= 16  # at least one per cell; the grid alone placed none here
    assert ring.min_spacing_mm >= tx.DOT_PITCH_MM - 0.01
    assert ring.share_within_reach >= 0.9, ring
    room = ndimage.distance_transform_edt(np.pad(regions == 2, 1))[1:-1, 1:-1] * p
    rows = regions.shape[0]
    for x, y in dots:
        r, c = rows - 1 - int((y - g.picture_origin_mm[1]) / p), int((x - g.picture_origin_mm[0]) / p)
        assert room[r, c] - p / 2 >= tx.THIN_INSET_MM + tx.DOT_DIAMETER_MM / 2 - p
    black = _render_gray(pdf, tmp_path, 200)
    assert 2 * ndimage.distance_transform_edt(black).max() / (200 / 25.4) <= 2.2


@pytest.mark.timeout(120)
def test_two_channel_czi_pdf_tells_its_channels_apart(tmp_path, capsys, fixture):
    """The swell-paper PDF of a two-channel CZI (nuclei and a cytoplasm marker between them), read
    back: the dotted channel carries dots over most of its thin strips, 3 mm apart or more; the
    outlined channel none."""
    _cairo_ok()
    from conftest import run_cli
    from paper_support import dot_cover, filled_round_dots_mm
    from tamp_os.lithograph.outputs import tactile_graphic
    from tamp_os.lithograph.pipeline import make_lithograph

    path = fixture("real/zeiss_dapi_gfp_2ch.czi")
    code, _, err = run_cli(capsys, "convert", path, "-o", tmp_path, "--formats", "pdf")
    assert code == 0, err
    g = tactile_graphic(make_lithograph(path))
    regions = tx.merge_small_regions(g.regions, g.mm_per_px)
    dots = np.array([(x, y) for x, y, d in filled_round_dots_mm(tmp_path / "zeiss_dapi_gfp_2ch.pdf") if abs(d - tx.DOT_DIAMETER_MM) < 0.05])
    cover = {g.textures[v]: dot_cover(regions == v, g.mm_per_px, g.picture_origin_mm, dots) for v in g.textures}
    assert cover["outline"].dots == 0
    dotted = cover["dots"]
    assert dotted.per_100_mm2 >= 2.0 and dotted.share_within_reach >= 0.45, dotted  # was 0.2 per 100 mm², 6 %
    assert dotted.min_spacing_mm >= tx.DOT_PITCH_MM - 0.01
