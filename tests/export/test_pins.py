"""Pin displays (issue 34): every file decodes back to the pages meant, by readers written here
from the vendors' documentation (not from our writers), and the pages keep the design rules.

Readers follow:
- Dot Pad: dotincorp/dotpad-sdk-guide (the sample .dtms files of the Android demo app, the Web
  SDK README): 300 cells, 30 × 10, two hex digits a cell, pin (row r, column c) of a cell at bit
  r + 4c; text: one byte a braille cell (dots 1-6 as bits 0-5), lines of 20 cells.
- Graphiti: Orbit-Research/Graphiti-API-Library, 'Graphiti API Specification v1.2': 0x1B start,
  command 0x15, 2400 × (height 0-4, blink), checksum = two's complement of the byte sum without
  the start byte, a 0x1B data byte sent twice; worked examples in its section 7.
- Monarch: Shared-Reality-Lab/IMAGE-Monarch README: one <title>, layers as g[data-image-layer],
  regions with aria-label and aria-description; rasterised at 96 × 40, alpha > 0 is a raised pin.
"""

from __future__ import annotations

import json
import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from synthetic_content import dark_line_network, dim_and_bright_beads  # noqa: E402

from tamp_os.errors import ExportError
from tamp_os.export.pin_files import checksum, frame, save_pins
from tamp_os.export.pins import DEVICES, Layer, PinSource, pin_pages

pytestmark = pytest.mark.timeout(120)

from conftest import FIXTURES  # noqa: E402


# ------------------------------------------------------------------------------------------------
# Readers, from the vendors' documents


def read_dtms(path: Path) -> list[dict]:
    doc = json.loads(path.read_text(encoding="utf-8"))
    assert set(doc) >= {"title", "lang", "device", "items"} and doc["device"] == "dotpad320"
    pages = []
    for item in doc["items"]:
        assert set(item) >= {"page", "title", "graphic", "text"}
        data = item["graphic"]["data"]
        assert len(data) == 600 and re.fullmatch(r"[0-9a-fA-F]+", data)
        cells = bytes.fromhex(data)
        pins = np.zeros((40, 60), np.uint8)
        for k, value in enumerate(cells):
            cell_row, cell_col = divmod(k, 30)
            for bit in range(8):
                if value >> bit & 1:
                    pins[cell_row * 4 + bit % 4, cell_col * 2 + bit // 4] = 1
        text = bytes.fromhex(item["text"]["data"])
        assert len(text) % 20 == 0 and all(b < 64 for b in text)  # 6-dot cells, whole 20-cell lines
        lines = ["".join(chr(0x2800 + b) for b in text[i : i + 20]).rstrip("\u2800") for i in range(0, len(text), 20)]
        pages.append({"pins": pins, "braille": "\u2800".join(lines), "plain": item["text"]["plain"], "title": item["title"]})
    return pages


def read_graphiti(path: Path) -> list[np.ndarray]:
    """Every Update Display frame in the file as a 40 × 60 height array (checksums verified)."""
    data = path.read_bytes()
    pages, i = [], 0
    while i < len(data):
        assert data[i] == 0x1B, f"frame must start with ESC at byte {i}"
        i += 1
        payload = bytearray()
        need = 1 + 4800 + 1  # command, pixel pairs, checksum
        while len(payload) < need:
            b = data[i]
            if b == 0x1B:
                assert data[i + 1] == 0x1B, "a 0x1B inside a frame must be doubled"
                i += 1
            payload.append(b)
            i += 1
        assert payload[0] == 0x15
        body, check = bytes(payload[:-1]), payload[-1]
        assert (sum(body) + check) & 0xFF == 0, "checksum: the byte sum without the start byte, with it, is 0 mod 256"
        values = np.frombuffer(body[1:], np.uint8)
        heights, blink = values[0::2], values[1::2]
        assert heights.max() <= 4 and not blink.any()
        pages.append(heights.reshape(40, 60).copy())
    return pages


def _polygons(d: str) -> list[np.ndarray]:
    """Subpaths of an SVG path made of M, L, H, V and Z commands (absolute or relative)."""
    tokens = re.findall(r"[MLHVZmlhvz]|-?\d+(?:\.\d+)?", d)
    polys, current, x, y, i, cmd = [], [], 0.0, 0.0, 0, None
    while i < len(tokens):
        t = tokens[i]
        if t.isalpha():
            cmd = t
            i += 1
            if cmd in "Zz":
                if current:
                    polys.append(np.array(current))
                current = []
            continue
        rel = cmd.islower()
        if cmd in "MmLl":
            nx, ny = float(tokens[i]), float(tokens[i + 1])
            i += 2
            x, y = (x + nx, y + ny) if rel else (nx, ny)
            if cmd in "Mm" and current:
                polys.append(np.array(current))
                current = []
        elif cmd in "Hh":
            x = x + float(t) if rel else float(t)
            i += 1
        elif cmd in "Vv":
            y = y + float(t) if rel else float(t)
            i += 1
        current.append((x, y))
    if current:
        polys.append(np.array(current))
    return polys


def rasterise(d: str, cols: int = 96, rows: int = 40) -> np.ndarray:
    """Which pixel centres of a cols × rows raster a path covers (non-zero winding, via matplotlib)."""
    from matplotlib.path import Path as MPath

    yy, xx = np.mgrid[0:rows, 0:cols]
    centres = np.column_stack([xx.ravel() + 0.5, yy.ravel() + 0.5])
    covered = np.zeros(rows * cols, bool)
    for poly in _polygons(d):
        covered |= MPath(poly).contains_points(centres)
    return covered.reshape(rows, cols)


def read_monarch(path: Path) -> list[dict]:
    root = ET.parse(path).getroot()
    ns = "{http://www.w3.org/2000/svg}"
    assert root.get("viewBox") == "0 0 96 40"
    assert len(root.findall(f".//{ns}title")) == 1
    regions = []
    for g in root.iter(f"{ns}g"):
        layer = g.get("data-image-layer")
        if layer is None:
            continue
        for el in g:
            assert el.get("aria-label") and el.get("aria-description") is not None
            regions.append({"layer": layer, "label": el.get("aria-label"), "pins": rasterise(el.get("d"))})
    assert regions, "no g[data-image-layer] regions"
    return regions


# ------------------------------------------------------------------------------------------------
# The Graphiti checksum against the specification's worked examples (section 7)


def test_graphiti_checksum_reproduces_the_worked_examples():
    assert checksum(bytes([0x01])) == 0xFF  # 7.1.1 Get software version
    assert checksum(bytes([0x17, 0x0A, 0x0A, 0x04, 0x0A])) == 0xC7  # 7.1.2 blink pixel (10, 10)
    row5 = bytes([0x18, 0x05]) + bytes([0x04, 0x00]) * 60
    row6 = bytes([0x18, 0x06]) + bytes([0x04, 0x00]) * 60
    assert checksum(row5) == 0xF3 and checksum(row6) == 0xF2  # 7.1.3 and 7.1.4 whole rows
    assert frame(bytes([0x17, 0x0A, 0x0A, 0x04, 0x0A])) == bytes([0x1B, 0x17, 0x0A, 0x0A, 0x04, 0x0A, 0xC7])
    assert frame(bytes([0x16, 0x03])) == bytes([0x1B, 0x16, 0x03, 0xE7])  # Clear Display, as 4.3.2 lists it


def test_graphiti_escapes_0x1b_in_data_and_checksum():
    assert frame(bytes([0x1B])) == bytes([0x1B, 0x1B, 0x1B, 0xE5])
    payload = bytes([0xE5])  # checksum 0x1B: sent twice
    assert frame(payload) == bytes([0x1B, 0xE5, 0x1B, 0x1B])


# ------------------------------------------------------------------------------------------------
# A lithograph of beads, through the whole save


@pytest.fixture(scope="module")
def beads_litho():
    from tamp_os import make_lithograph

    truth = dim_and_bright_beads()
    return truth, make_lithograph(truth.image, pixel_size="50nm", caption="ten beads", preset="low")


@pytest.fixture(scope="module")
def written(beads_litho, tmp_path_factory):
    _, litho = beads_litho
    folder = tmp_path_factory.mktemp("pins")
    paths = litho.save(folder, formats=("stl", "dotpad", "graphiti", "monarch"), stem="beads")
    return folder, paths


def _sets(litho):
    from tamp_os.export.pin_files import pin_sets

    return pin_sets(litho, ["dotpad", "graphiti", "monarch"])


def test_every_file_decodes_to_the_pages_meant(beads_litho, written):
    _, litho = beads_litho
    folder, paths = written
    names = {p.name for p in paths}
    assert {"beads.dtms", "beads.graphiti", "beads.monarch.svg", "beads.dotpad-simulator.png",
            "beads.graphiti-simulator.png", "beads.monarch-simulator.png", "beads.graphiti-1.png"} <= names
    sets = _sets(litho)
    dot = read_dtms(folder / "beads.dtms")
    assert len(dot) == len(sets["dotpad"].pages) >= 3
    for decoded, page in zip(dot, sets["dotpad"].pages):
        assert int(((decoded["pins"] > 0) != (page.pins > 0)).sum()) == 0
        assert decoded["braille"] == page.braille and decoded["plain"] == page.plain
    graphiti = read_graphiti(folder / "beads.graphiti")
    assert len(graphiti) == len(sets["graphiti"].pages)
    for decoded, page in zip(graphiti, sets["graphiti"].pages):
        assert int((decoded != page.pins).sum()) == 0
    from PIL import Image

    for k, page in enumerate(sets["graphiti"].pages, start=1):  # the PNG Send Image takes: black = highest
        png = np.asarray(Image.open(folder / f"beads.graphiti-{k}.png"))
        assert png.shape == (40, 60) and int(((png < 255) != (page.pins > 0)).sum()) == 0
    monarch = [folder / "beads.monarch.svg"] + [folder / f"beads.monarch-{k}.svg" for k in range(2, len(sets["monarch"].pages) + 1)]
    for svg, page in zip(monarch, sets["monarch"].pages):
        raised = np.zeros((40, 96), bool)
        for r in read_monarch(svg):
            raised |= r["pins"]
        assert int((raised != (page.pins > 0)).sum()) == 0, svg.name


def _check_rules(pins: np.ndarray, regions, picture_page: bool):
    """Rules measured on a decoded page, with the regions the page labels."""
    up = pins > 0
    labelled = [r for r in regions if r.layer != "braille"]
    for r in labelled:
        assert (up[r.mask]).all(), f"{r.label}: labelled pins not raised in the file"
        assert r.mask.sum() >= 4, f"{r.label}: {r.mask.sum()} pins"
    for i, a in enumerate(labelled):
        grown = ndimage.binary_dilation(a.mask, np.ones((3, 3), bool))
        for b in labelled[i + 1 :]:
            assert not (grown & b.mask).any(), f"{a.label} touches {b.label}: no one-pin gap"
    if picture_page:
        neighbours = ndimage.convolve(up.astype(int), np.ones((3, 3), int), mode="constant") - up
        assert not (up & (neighbours == 0)).any(), "an isolated single pin"
    C = pins.shape[1]
    assert all(up[i, C - 4 + i] for i in range(4)), "orientation marker missing"
    assert not up[0, C - 5] and not up[1, C - 2], "the marker's corner must stand alone"


def test_pages_keep_the_design_rules(beads_litho, written):
    folder, _ = written
    _, litho = beads_litho
    sets = _sets(litho)
    for decoded, page in zip(read_dtms(folder / "beads.dtms"), sets["dotpad"].pages):
        _check_rules(decoded["pins"], page.regions, page.name != "key")
    for decoded, page in zip(read_graphiti(folder / "beads.graphiti"), sets["graphiti"].pages):
        _check_rules(decoded, page.regions, page.name != "key")
    levels = set(np.unique(read_graphiti(folder / "beads.graphiti")[0]))
    assert levels <= {0, 4} and 4 in levels  # domes and furniture at the top level
    overview = sets["dotpad"].overview
    members = [r for r in overview.regions if r.layer == "members"]
    assert len(members) >= 8, "the beads, each its own region, on the overview"


def test_monarch_every_labelled_region_covers_its_pins(beads_litho, written):
    folder, _ = written
    regions = read_monarch(folder / "beads.monarch.svg")
    layers = {r["layer"] for r in regions}
    assert {"members", "furniture"} <= layers
    for r in regions:
        assert r["pins"].sum() >= 4, r["label"]
    title = ET.parse(folder / "beads.monarch.svg").getroot().find("{http://www.w3.org/2000/svg}title").text
    assert "ten beads" in title and "1 pin =" in title


def test_scale_is_right_within_a_pin_on_every_page(beads_litho, written):
    truth, litho = beads_litho
    folder, _ = written
    sets = _sets(litho)
    um_per_px_picture = litho.furniture.sample_m_per_print_mm * litho.layout.mm_per_px * 1e6
    for decoded, page in zip(read_dtms(folder / "beads.dtms"), sets["dotpad"].pages):
        if page.window is None:
            continue
        _, _, s = page.placement
        assert page.um_per_pin == pytest.approx(um_per_px_picture / s)
        # the plate's own scale: sample µm per print mm × print mm per pin
        r0, r1, c0, c1 = page.window
        print_mm_per_pin = (c1 - c0) * litho.layout.mm_per_px / ((c1 - c0) * s)
        assert page.um_per_pin == pytest.approx(litho.furniture.sample_m_per_print_mm * 1e6 * print_mm_per_pin)
        row, col, length, metres = page.scale_bar
        measured = int(decoded["pins"][row].astype(bool)[col:].argmin()) if not decoded["pins"][row, col:].all() else 60 - col
        assert measured == length
        assert abs(measured - metres * 1e6 / page.um_per_pin) <= 1.0, "scale bar off by more than a pin"
        assert "1 pin = " in page.plain
    # a bead's width on the overview against its true width
    overview = sets["dotpad"].overview
    _, _, s = overview.placement
    sizes = ndimage.sum(np.ones_like(truth.members), truth.members, index=range(1, truth.members.max() + 1))
    biggest = int(np.argmax(sizes)) + 1
    ys, xs = np.nonzero(truth.members == biggest)
    true_px = (xs.max() - xs.min() + 1) * litho.heightmap.shape[1] / truth.image.shape[1]
    widths = [r.mask.any(axis=0).sum() for r in overview.regions if r.layer == "members"]
    assert max(widths) <= true_px * s + 2  # within a pin at each side


def test_braille_back_translates_to_the_caption_and_key(beads_litho, written):
    from tamp_os.tactile.braille import Liblouis

    louis = Liblouis.system().binding
    if louis is None:
        pytest.skip("liblouis' Python binding is not installed")
    folder, _ = written
    _, litho = beads_litho
    pages = read_dtms(folder / "beads.dtms")
    table = litho.params.braille_table
    back = [louis.backTranslateString([table], p["braille"], mode=louis.ucBrl) for p in pages]
    for text, page in zip(back, pages):
        assert text == page["plain"], (text, page["plain"])
    assert back[0].startswith("ten beads.")
    assert back[-1].startswith("Key:") and "members" in back[-1] and "scale bar" in back[-1]


def test_lines_stay_connected_and_thin_lines_are_kept():
    truth = dark_line_network(rows=384, cols=512)
    lines = truth.lines.astype(bool)
    source = PinSource(lines.shape, [Layer("lines", "lines", lines)], 0.1, "lines", "lines", "en-ueb-g2.ctb")
    found = ndimage.label(lines, np.ones((3, 3)))[1]
    pin_set = pin_pages(source, DEVICES["dotpad"])
    overview = pin_set.overview
    line_pins = np.zeros((40, 60), bool)
    for r in overview.regions:
        if r.layer == "lines":
            line_pins |= r.mask
    kept = ndimage.label(line_pins, np.ones((3, 3)))[1]
    assert kept >= 1 and kept <= found, (kept, found)
    # a line one pixel wide (far finer than a pin) survives: max-pooled, not averaged away
    thin = np.zeros((400, 600), bool)
    thin[200, 50:550] = True
    thin[50:350, 300] = True
    one = pin_pages(PinSource(thin.shape, [Layer("lines", "a cross", thin)], 0.1, "t", "t", "en-ueb-g2.ctb"), DEVICES["graphiti"])
    cross = [r for r in one.overview.regions if r.layer == "lines"]
    assert len(cross) == 1 and cross[0].mask.sum() >= 40
    assert set(np.unique(one.overview.pins[cross[0].mask])) == {3}  # lines at the middle level


def _specks() -> PinSource:
    labels = np.zeros((600, 800), np.int32)
    grid = labels[5::8, 5::8]
    labels[5::8, 5::8] = np.arange(1, grid.size + 1).reshape(grid.shape)  # one-pixel specks, 8 px apart
    return PinSource(labels.shape, [Layer("members", "specks", labels)], 0.01, "specks", "specks", "en-ueb-g2.ctb")


@pytest.mark.slow
def test_members_too_fine_for_any_zoom_say_the_zoom_needed():
    with pytest.raises(ExportError, match=r"finer than a pin on every page .* needs a zoom of about \d+×"):
        pin_pages(_specks(), DEVICES["dotpad"])


@pytest.mark.slow
def test_a_picture_too_fine_writes_no_file(beads_litho, tmp_path, monkeypatch):
    """The pages are made before any file is opened, so a refusal leaves the folder empty."""
    from tamp_os.export import pins

    _, litho = beads_litho
    monkeypatch.setattr(pins, "source_from_lithograph", lambda litho: _specks())
    with pytest.raises(ExportError, match="zoom"):
        litho.save(tmp_path, formats=("stl", "dotpad", "graphiti"))
    assert not list(tmp_path.iterdir())


@pytest.mark.real
@pytest.mark.skipif(not (FIXTURES / "real" / "zeiss_dapi_gfp_2ch.czi").is_file(), reason="real fixtures absent")
def test_real_channel_print_keeps_the_rules_on_every_page(tmp_path):
    """Nuclei (domes) on a cytoplasm plateau: on the Dot Pad the plateau is an outline, on the
    Graphiti a low fill with the domes on top; both keep every rule on the decoded files."""
    from tamp_os import make_lithograph
    from tamp_os.export.pin_files import pin_sets

    litho = make_lithograph(FIXTURES / "real" / "zeiss_dapi_gfp_2ch.czi", preset="low")
    sets = pin_sets(litho, ["dotpad", "graphiti"])
    for fmt, pin_set in sets.items():
        save_pins(pin_set, fmt, tmp_path, stem="cells", title="t")
    for decoded, page in zip(read_dtms(tmp_path / "cells.dtms"), sets["dotpad"].pages):
        _check_rules(decoded["pins"], page.regions, page.name != "key")
    g = read_graphiti(tmp_path / "cells.graphiti")
    for decoded, page in zip(g, sets["graphiti"].pages):
        _check_rules(decoded, page.regions, page.name != "key")
    assert {2, 4} <= set(np.unique(np.concatenate([p.ravel() for p in g[:-1]])))  # plateau low, domes high
    key = read_dtms(tmp_path / "cells.dtms")[-1]["plain"]
    assert "nuclei (DAPI)" in key and "diffuse (GFP)" in key


def test_writes_go_through_the_atomic_writer(beads_litho, tmp_path, monkeypatch):
    from conftest import spy_atomic_writes
    from tamp_os.export import pin_files

    calls = spy_atomic_writes(monkeypatch, pin_files)
    _, litho = beads_litho
    sets = _sets(litho)
    for fmt, pin_set in sets.items():
        save_pins(pin_set, fmt, tmp_path, stem="x", title="t")
    assert {"x.dtms", "x.graphiti", "x.monarch.svg", "x.monarch-2.svg", "x.dotpad-simulator.png"} <= set(calls)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left behind


@pytest.mark.real
@pytest.mark.skipif(not (FIXTURES / "real" / "zeiss_sem_al2o3_grains.czi").is_file(), reason="real fixtures absent")
def test_real_grain_network_stays_one_network_on_the_zoom_pages():
    from tamp_os import make_lithograph
    from tamp_os.export.pin_files import pin_sets

    litho = make_lithograph(FIXTURES / "real" / "zeiss_sem_al2o3_grains.czi")  # medium: a line network
    pin_set = pin_sets(litho, ["graphiti"])["graphiti"]
    for page in pin_set.pages[:-1]:
        lines = [r for r in page.regions if r.layer == "lines"]
        assert lines, page.name
        biggest = max(r.mask.sum() for r in lines)
        assert biggest >= 0.8 * sum(r.mask.sum() for r in lines), f"{page.name}: the network fell apart"
