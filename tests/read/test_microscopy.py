"""Physical scale from real and synthesized microscope files; data bands and burned-in labels."""

import json

import numpy as np
import pytest
import tifffile
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from tamp_os import make_lithograph
from tamp_os.cli.commands import main
from tamp_os.errors import ParameterError
from tamp_os.clean.band import band_from_metadata
from tamp_os.clean.scale import USER_GIVEN, read_pixel_size, scale_sentence
from tamp_os.read.image import read_image
from tamp_os.units import parse_length_m


def scale_of(path, override=None):
    f = read_image(path).file
    return read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width, pixel_size_m=override)


def band_of(path):
    f = read_image(path).file
    return band_from_metadata(f.metadata, f.tiff_tags, f.path, height_px=f.height)


def test_zeiss_pixel_size_and_data_zone(fixture):
    path = fixture("test_tiff_Zeiss_SEM_1k.tif")
    scale = scale_of(path)
    assert scale.metres == pytest.approx(2.677e-3 / 1024, rel=1e-9)
    assert scale.metres == pytest.approx(2.614e-6, rel=1e-3)
    litho = make_lithograph(path, mesher="grid")
    crop = litho.report["crop"]
    assert 76 <= crop["bottom_rows"] <= 84 and crop["top_rows"] == 0
    assert litho.layout.depth_mm == pytest.approx(100 * (768 - crop["bottom_rows"]) / 1024, rel=1e-9)
    # No raised text: the white data zone (the brightest part of the file) is gone, so the bottom
    # rows of the print look like the picture above them, not like a flat white band.
    bottom = litho.heightmap[-5:]
    assert bottom.std() > 0.05


def test_fei_pixel_size_and_exactly_442_rows(fixture):
    for name in ("FEI-Helios-Ebeam-8bits.tif", "FEI-Helios-Ebeam-16bits.tif"):
        path = fixture(name)
        scale = scale_of(path)
        assert scale.metres == pytest.approx(3.3724e-6, rel=1e-9)
        assert band_of(path).bottom_rows == 471 - 442
        litho = make_lithograph(path)
        assert litho.report["crop"]["bottom_rows"] == 29
        assert litho.layout.depth_mm == pytest.approx(100 * 442 / 512)
        # The image area is blank: a clear flat-plate answer, never NaN.
        assert litho.report["uniform"] and np.isfinite(litho.mesh.vertices).all()


def test_imagej_dm3_and_no_scale_fixtures(fixture):
    assert scale_of(fixture("test_loading_image_saved_with_imageJ.tif")).metres == pytest.approx(0.16867e-6, rel=1e-4)
    dm = scale_of(fixture("test_STEM_image.dm3"))
    assert dm.metres == pytest.approx(0.2485e-9, rel=1e-3) and "DigitalMicrograph" in dm.provenance
    fept = scale_of(fixture("fept_spheres_sem.png"))
    assert fept.metres is None and fept.provenance == "none"
    jeol = scale_of(fixture("JEOL-SightX-TEM-mag-dummy.tif"))
    assert jeol.metres is None  # its 93 dpi resolution tag is not a physical size
    assert any("not a physical pixel size" in w for w in jeol.warnings)


def test_fept_scale_bar_box_is_removed(fixture):
    path = fixture("fept_spheres_sem.png")
    kept = make_lithograph(path, keep_annotations=True, mesher="grid", resolution_px=256, relief_style="reference")
    clean = make_lithograph(path, mesher="grid", resolution_px=256, relief_style="reference")
    assert clean.report["annotations"] and "box" in clean.report["annotations"][0]
    rows, cols = clean.heightmap.shape
    # The box covers source rows 707-745 and columns 20-177 of 1024 x 768.
    r0, r1 = int(707 / 768 * rows), int(746 / 768 * rows)
    c0, c1 = int(20 / 1024 * cols), int(178 / 1024 * cols)
    box_kept = kept.heightmap[r0:r1, c0:c1]
    box_clean = clean.heightmap[r0:r1, c0:c1]
    assert box_kept.mean() > 3.5  # the reference prints this as a raised block near full height
    ring = np.zeros_like(clean.heightmap, bool)
    ring[max(0, r0 - 12) : r1 + 12, max(0, c0 - 12) : c1 + 12] = True
    ring[max(0, r0 - 4) : r1 + 4, max(0, c0 - 4) : c1 + 4] = False
    around = clean.heightmap[ring]
    assert around.min() - 0.1 <= box_clean.min() and box_clean.max() <= around.max() + 0.1


def test_save_masks_writes_the_mask(fixture, tmp_path, capsys):
    assert main(["convert", str(fixture("fept_spheres_sem.png")), "-o", str(tmp_path), "--save-masks", "--preset", "low"]) == 0
    out = capsys.readouterr().out
    assert "removed burned-in annotations: box at rows 707–745" in out
    mask = np.asarray(Image.open(tmp_path / "fept_spheres_sem.annotations.png"))
    assert mask.shape == (768, 1024) and mask[720, 100] == 255 and mask[100, 500] == 0


def test_info_json_reports_scale_crop_annotations(fixture, capsys):
    assert main(["info", "--json", str(fixture("test_tiff_Zeiss_SEM_1k.tif"))]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["pixel_size_m"] == pytest.approx(2.614e-6, rel=1e-3)
    assert "Zeiss" in facts["pixel_size_source"]
    assert 76 <= facts["crop"]["bottom_rows"] <= 84 and facts["annotations"] == []
    assert main(["info", "--json", str(fixture("fept_spheres_sem.png")), "--pixel-size", "25nm"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["pixel_size_m"] == pytest.approx(25e-9) and facts["pixel_size_source"] == USER_GIVEN
    assert len(facts["annotations"]) == 1


def write_tiff(path, **kw):
    data = (np.random.default_rng(0).random((40, 60)) * 200).astype(np.uint8)
    tifffile.imwrite(path, data, **kw)
    return path


def test_tescan_tag_and_sidecar(tmp_path):
    text = "[MAIN]\nDevice=TESCAN MIRA\nPixelSizeX=4.5e-09\nPixelSizeY=4.5e-09\nImageStripSize=6\n"
    tagged = write_tiff(tmp_path / "tescan.tif", extratags=[(50431, "s", 0, text, True)])
    scale = scale_of(tagged)
    assert scale.metres == pytest.approx(4.5e-9) and "50431" in scale.provenance
    assert band_of(tagged).bottom_rows == 6
    plain = write_tiff(tmp_path / "tescan2.tif")
    (tmp_path / "tescan2.hdr").write_text(text)
    scale = scale_of(plain)
    assert scale.metres == pytest.approx(4.5e-9) and "tescan2.hdr" in scale.provenance


def test_jeol_and_hitachi_sidecars(tmp_path):
    jeol = write_tiff(tmp_path / "jeol.tif")
    (tmp_path / "jeol.txt").write_text("$CM_FORMAT JEOL/SEM\n$$SM_MICRON_BAR 120\n$$SM_MICRON_MARKER 10um\n")
    assert scale_of(jeol).metres == pytest.approx(10e-6 / 120)
    hitachi = write_tiff(tmp_path / "hitachi.tif")
    (tmp_path / "hitachi.txt").write_text("[SemImageFile]\nInstructName=S-4800\nPixelSize=7.8125\n")
    scale = scale_of(hitachi)
    assert scale.metres == pytest.approx(7.8125e-9) and "Hitachi" in scale.provenance


def test_ome_and_imagej_variants(tmp_path):
    ome = write_tiff(tmp_path / "a.ome.tif", ome=True, metadata={"axes": "YX", "PhysicalSizeX": 65.0, "PhysicalSizeXUnit": "nm"})
    assert scale_of(ome).metres == pytest.approx(65e-9)
    for unit, per_unit, expected in (("um", 2.0, 0.5e-6), ("\\u00B5m", 4.0, 0.25e-6), ("micron", 5.0, 0.2e-6), ("nm", 0.1, 10e-9)):
        path = write_tiff(tmp_path / f"ij_{per_unit}.tif", imagej=True, resolution=(per_unit, per_unit), metadata={"unit": unit})
        assert scale_of(path).metres == pytest.approx(expected, rel=1e-6), unit


@pytest.mark.parametrize("bad", ["-4.5e-09", "0", "abc", "1e5"])
def test_broken_metadata_falls_back_with_a_warning(tmp_path, bad):
    path = write_tiff(tmp_path / "t.tif", extratags=[(50431, "s", 0, f"[MAIN]\nPixelSizeX={bad}\n", True)])
    scale = scale_of(path)
    assert scale.metres is None and scale.warnings
    litho = make_lithograph(path)  # still converts
    assert litho.report["scale"] == "no physical scale is known"
    (tmp_path / "t.txt").write_text("PixelSize=12\n")  # a valid fallback source
    assert scale_of(path).metres == pytest.approx(12e-9)


def test_contradictory_fei_rows_are_ignored(tmp_path):
    meta = "[Scan]\nPixelWidth=2e-9\n[Image]\nResolutionY=5000\n"
    path = write_tiff(tmp_path / "fei.tif", extratags=[(34682, "s", 0, meta, True)])
    scale = scale_of(path)
    assert scale.metres == pytest.approx(2e-9) and band_of(path) is None


def test_override_and_the_scale_sentence(fixture):
    litho = make_lithograph(fixture("test_tiff_Zeiss_SEM_1k.tif"), pixel_size="1um")
    assert litho.report["pixel_size_source"] == USER_GIVEN
    assert any("overrides" in w for w in litho.report["warnings"])
    # 1024 source pixels across 100 mm: 1 mm of print = 10.24 px = 10.24 µm; magnification ≈ 97.7×
    assert litho.report["scale"] == "1 mm on the print = 10.24 µm in the sample (magnification 97.7×)"
    assert scale_sentence(0.42e-6 / 10, 10) == "1 mm on the print = 420 nm in the sample (magnification 2,381×)"
    assert "1 mm on the print" in litho.metadata()["description"]


@given(st.floats(1e-3, 1e3), st.sampled_from([("nm", 1e-9), ("µm", 1e-6), ("um", 1e-6), ("micron", 1e-6), ("mm", 1e-3)]))
def test_parse_length(value, unit):
    name, factor = unit
    assert parse_length_m(f"{value!r}{name}") == pytest.approx(value * factor, rel=1e-12)
    assert parse_length_m(f"{value!r} {name}") == pytest.approx(value * factor, rel=1e-12)


@pytest.mark.parametrize("text", ["", "4.2", "nm", "4.2 parsecs", "-3nm", "0um"])
def test_parse_length_refuses_with_a_clear_message(text):
    with pytest.raises(ParameterError, match="pixel_size"):
        parse_length_m(text)


def test_z_stack_projection_and_slice_from_the_cli(tmp_path, capsys):
    stack = np.zeros((3, 30, 40), np.uint16)
    stack[1, 5:25, 5:35] = 1000
    path = tmp_path / "stack.ome.tif"
    tifffile.imwrite(path, stack, ome=True, photometric="minisblack", metadata={"axes": "ZYX"})
    assert main(["convert", str(path), "-o", str(tmp_path / "o"), "--preset", "low", "--verbose"]) == 0
    said = capsys.readouterr()
    # a decision, not a warning (issue 33.9): said with --verbose and kept in the report
    assert "note: z-stack of 3 slices: maximum-intensity projection" in said.out and "maximum-intensity" not in said.err
    described = (tmp_path / "o" / "stack.ome.description.txt").read_text()
    assert "How it was made: z-stack of 3 slices: maximum-intensity projection" in described
    assert main(["convert", str(path), "-o", str(tmp_path / "o2"), "--slice", "0"]) == 0
    assert "uniform" in capsys.readouterr().err


def picture_with_scale_bar(tmp_path, label: str, bar_px: int = 200):
    import shutil as _shutil

    from PIL import ImageDraw, ImageFont

    from conftest import need

    need(_shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    font_path = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"
    need(__import__("os").path.exists(font_path), "the DejaVu font (fonts-dejavu-core)")
    rng = np.random.default_rng(3)
    img = (90 + 40 * rng.random((480, 640))).astype(np.uint8)
    im = Image.fromarray(img)
    draw = ImageDraw.Draw(im)
    draw.rectangle([400, 430, 400 + bar_px - 1, 437], fill=255)  # an 8 px thick white bar
    draw.text((450, 392), label, fill=255, font=ImageFont.truetype(font_path, 28))
    path = tmp_path / "bar.png"
    im.save(path)
    return path


def test_scale_bar_label_supplies_the_pixel_size_when_it_reads_cleanly(tmp_path):
    path = picture_with_scale_bar(tmp_path, "10 µm")
    litho = make_lithograph(path, preset="low")
    assert litho.report["pixel_size_m"] == pytest.approx(10e-6 / 200, rel=1e-6)
    assert litho.report["pixel_size_source"] == "scale bar label"
    assert any("bar" in a for a in litho.report["annotations"])  # and the bar is removed


def test_unreadable_scale_bar_label_gives_no_scale(tmp_path):
    path = picture_with_scale_bar(tmp_path, "~~ ##")
    litho = make_lithograph(path, preset="low")
    assert litho.report["pixel_size_m"] is None
    assert litho.report["scale"] == "no physical scale is known"
    assert any("did not read cleanly" in w for w in litho.report["warnings"])


def test_parse_label_accepts_only_one_clean_length():
    from tamp_os.clean.scalebar import parse_label

    assert parse_label("10 µm\n") == pytest.approx(1e-5)
    assert parse_label("500nm") == pytest.approx(5e-7)
    assert parse_label("2,5 um") == pytest.approx(2.5e-6)
    for bad in ("10 pm", "10 µm 20 µm", "about 10 µm", "10\nµm", ""):
        assert parse_label(bad) is None, bad


@pytest.mark.parametrize("fill, points", [(255, [(400, 300), (300, 400)]), (0, [(120, 240), (300, 240)])])
def test_drawn_arrows_are_removed(fill, points):
    from PIL import ImageDraw

    from tamp_os.clean.annotations import detect_annotations

    rng = np.random.default_rng(0)
    image = Image.fromarray((90 + 40 * rng.random((480, 640))).astype(np.uint8))
    draw = ImageDraw.Draw(image)
    (x0, y0), (x1, y1) = points
    draw.line(points, fill=fill, width=6)
    # A triangular head at the second point, pointing along the shaft.
    dx, dy = (x1 - x0) / np.hypot(x1 - x0, y1 - y0), (y1 - y0) / np.hypot(x1 - x0, y1 - y0)
    tip = (x1 + 20 * dx, y1 + 20 * dy)
    draw.polygon([tip, (x1 - 12 * dy, y1 + 12 * dx), (x1 + 12 * dy, y1 - 12 * dx)], fill=fill)
    values = np.asarray(image).astype(np.float32)
    mask, found = detect_annotations(values)
    assert [a.kind for a in found] == ["arrow"]
    drawn = np.asarray(image) == fill
    assert mask[drawn].mean() > 0.99 and mask.sum() < 3 * drawn.sum()


@pytest.mark.timeout(30)
@pytest.mark.parametrize("side", ["bottom", "left"])
def test_a_strip_along_the_edge_is_no_arrow(side):
    """A bright strip lying along the picture's edge and widening at one end (an Aperio slide's flat
    glass rows at its bottom edge) is no drawn arrow; the same shape inside the picture is one."""
    from tamp_os.clean.annotations import detect_annotations

    rng = np.random.default_rng(1)
    image = (90 + 40 * rng.random((480, 640))).astype(np.float32)
    strip = np.zeros((24, 320), bool)
    strip[-6:, :300] = True  # a shaft 6 pixels high, then a head 24 high
    strip[:, 300:] = np.arange(24)[:, None] >= np.linspace(0, 20, 20)[None, :]
    inside = image.copy()
    inside[200:224, 100:420][strip] = 255
    assert [a.kind for a in detect_annotations(inside)[1]] == ["arrow"]  # the shape is an arrow
    edge = image.copy()
    if side == "bottom":
        edge[-24:, 100:420][strip] = 255
    else:
        edge[100:420, :24][strip.T[:, ::-1]] = 255
    mask, found = detect_annotations(edge)
    assert found == [] and not mask.any()


def test_no_false_annotations_on_natural_pictures(fixture):
    import skimage.data

    from tamp_os.clean.annotations import detect_annotations
    from tamp_os.clean.stage import clean_picture

    for name in ("cell", "moon", "coins", "camera", "retina", "hubble_deep_field", "astronaut", "brick", "gravel", "horse", "clock"):
        _, found = detect_annotations(read_image_array(getattr(skimage.data, name)()))
        assert found == [], name
    zeiss = clean_picture(read_image(fixture("test_tiff_Zeiss_SEM_1k.tif")), pixel_size_m=None, remove_annotations=True)
    assert zeiss.annotations == []  # its bright sample edge is not an arrow or a label


def read_image_array(array):
    from tamp_os.read.image import read_array

    return read_array(array).values
