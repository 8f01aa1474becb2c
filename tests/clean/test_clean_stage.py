"""clean/stage.py and what it leans on: scale bars read from real data bands, black margins, EXIF
orientation, Ångström and picometre lengths, and more."""

import shutil

import numpy as np
import pytest
import tifffile
from PIL import Image

from conftest import need
from tamp_os.clean.stage import clean_picture
from tamp_os.read.image import read_image


def stripped(fixture, tmp_path, name) -> tuple:
    """The fixture's pixels in a plain TIFF without its vendor metadata, and the metadata's pixel size."""
    truth = clean_picture(read_image(fixture(name)), pixel_size_m=None, remove_annotations=True).pixel_size
    path = tmp_path / f"stripped-{name}.tif"
    tifffile.imwrite(path, tifffile.imread(fixture(name)))
    return path, truth


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", ["test_tiff_Zeiss_SEM_1k.tif", "FEI-Helios-Ebeam-8bits.tif", "FEI-Helios-Ebeam-16bits.tif"])
def test_scale_bar_of_stripped_fixtures_within_5_percent(fixture, tmp_path, name):
    need(shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    path, truth = stripped(fixture, tmp_path, name)
    assert truth.metres and "bar" not in truth.provenance  # metadata first when present
    found = clean_picture(read_image(path), pixel_size_m=None, remove_annotations=True).pixel_size
    assert found.provenance == "scale bar label"
    assert found.metres == pytest.approx(truth.metres, rel=0.05)


@pytest.mark.timeout(120)
def test_fept_label_box_is_the_bar(fixture):
    need(shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    found = clean_picture(read_image(fixture("fept_spheres_sem.png")), pixel_size_m=None, remove_annotations=True)
    # The white box spans columns 20-177: 158 px labelled "4 µm".
    assert found.pixel_size.provenance == "scale bar label"
    assert found.pixel_size.metres == pytest.approx(4e-6 / 158, rel=0.05)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name, bar_m, bar_px", [("sem_fei_sio2_particles_10kx.tif", 5e-6, 116), ("sem_fei_sio2_particles_35kx.tif", 2e-6, 162)])
def test_fei_databar_box_removed_whole_and_its_bar_read(fixture, name, bar_m, bar_px):
    """The FEI XL databar (fixtures README): a black box at rows 423-462, columns 43-618, white
    words, the bar on its top edge with its label beside it. The whole box goes (not only the
    bar), and the label beside the bar gives the scale."""
    need(shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    cleaned = clean_picture(read_image(fixture(f"real/{name}")), pixel_size_m=None, remove_annotations=True)
    boxes = [(a.rows, a.cols) for a in cleaned.annotations]
    assert boxes == [((423, 463), (43, 619))]
    assert cleaned.mask[423:463, 43:619].all() and not cleaned.mask[:400].any()
    assert cleaned.pixel_size.provenance == "scale bar label"
    assert cleaned.pixel_size.metres == pytest.approx(bar_m / bar_px, rel=0.03)


@pytest.mark.timeout(60)
def test_saturated_disc_on_black_is_picture_not_a_box():
    """Two-tone counts as a box only inside a rectangular frame: a saturated bead on a black
    ground (its bounding box's corners are the ground) stays in the picture."""
    from tamp_os.clean.annotations import detect_annotations

    yy, xx = np.mgrid[:200, :300]
    values = np.full((200, 300), 0.0, np.float32)
    values[60:200, 150:300] = 0.5  # some picture, so that black and white are both extremes
    values[(yy - 60) ** 2 + (xx - 70) ** 2 < 30 ** 2] = 1.0
    mask, found = detect_annotations(values)
    assert not mask[40:80, 50:90].any() and found == []


@pytest.mark.timeout(60)
def test_natural_pictures_get_no_scale_and_no_warning():
    import skimage.data

    from tamp_os.read.image import read_array

    for name in ("cell", "moon", "coins", "camera"):
        cleaned = clean_picture(read_array(getattr(skimage.data, name)()), pixel_size_m=None, remove_annotations=True)
        assert cleaned.pixel_size.metres is None and cleaned.pixel_size.warnings == (), name


@pytest.mark.timeout(60)
def test_black_margins_are_not_data_bands_and_zeiss_band_still_is(fixture):
    import skimage.data

    from tamp_os.clean.band import detect_info_band

    coins = np.pad(skimage.data.coins(), ((60, 0), (0, 0))).astype(np.float32)
    assert detect_info_band(coins) == (0, 0)
    ramp = np.tile(np.linspace(30, 220, 200, dtype=np.float32), (200, 1))
    ramp[:40] = 0
    assert detect_info_band(ramp) == (0, 0)
    zeiss = read_image(fixture("test_tiff_Zeiss_SEM_1k.tif")).values
    top, bottom = detect_info_band(zeiss)
    assert top == 0 and 76 <= bottom <= 84


@pytest.mark.timeout(120)
def test_glass_with_tissue_reaching_into_it_is_not_a_data_band(fixture):
    """The white glass above a slide's tissue, with the tissue's ragged edge and a few fragments
    in it, is the picture, not a data band: marks that run on into the picture are its content.
    The frozen section TCGA-CR-7395 lost its top 246 rows (14 %) of tissue to this before."""
    from tamp_os.clean.band import detect_info_band

    rng = np.random.default_rng(1)
    slide = np.full((400, 500), 250, np.float32)
    yy, xx = np.mgrid[0:400, 0:500]
    tissue = (yy - 260) ** 2 / 200 ** 2 + (xx - 250) ** 2 / 230 ** 2 < 1  # reaches up to row 60
    for cx in (120, 250, 380):  # three lobes reaching into the top rows
        tissue |= (yy < 80) & (np.abs(xx - cx) < 12)
    slide[tissue] = 150 + rng.normal(0, 20, int(tissue.sum()))
    assert detect_info_band(slide) == (0, 0)
    band = slide.copy()  # the same slide with a white data band holding text at the bottom
    band[360:] = 250
    for x0 in (40, 90, 140, 190):
        band[375:385, x0:x0 + 20] = 10
    assert detect_info_band(band)[1] > 0
    cr = read_image(fixture("real/aperio_tcga_cr7395_j2k_no_mpp.svs")).values
    assert detect_info_band(cr) == (0, 0)


@pytest.mark.timeout(30)
@pytest.mark.parametrize("orientation, turn", [(6, lambda a: np.rot90(a, -1)), (3, lambda a: np.rot90(a, 2)), (8, lambda a: np.rot90(a, 1))])
def test_exif_orientation_is_applied_and_said(tmp_path, orientation, turn):
    upright = np.zeros((30, 50), np.uint8)
    upright[:10, :15] = 255  # bright block at the top left, as a viewer shows it
    stored = {6: np.rot90(upright, 1), 3: np.rot90(upright, 2), 8: np.rot90(upright, -1)}[orientation]
    exif = Image.Exif()
    exif[0x0112] = orientation
    path = tmp_path / "phone.jpg"
    Image.fromarray(np.ascontiguousarray(stored)).save(path, exif=exif, quality=100)
    pic = read_image(path)
    assert pic.values.shape == (30, 50)
    assert pic.values[:10, :15].mean() > 200 and pic.values[20:, 30:].mean() < 50
    assert any("EXIF orientation" in n for n in pic.file.notes)


@pytest.mark.timeout(30)
@pytest.mark.parametrize("text, metres", [("12Å", 1.2e-9), ("12 \u212b", 1.2e-9), ("300pm", 3e-10), ("2cm", 2e-2), ("5 angstrom", 5e-10)])
def test_angstrom_picometre_and_centimetre_lengths(text, metres):
    from tamp_os.units import parse_length_m

    assert parse_length_m(text) == pytest.approx(metres, rel=1e-12)


@pytest.mark.timeout(30)
@pytest.mark.parametrize("text, words", [("-5um", "greater than 0"), ("0nm", "greater than 0"), ("1e300m", "between 1 pm and 1 m"),
                                         ("1e-300m", "between 1 pm and 1 m"), ("0.5pm", "between 1 pm and 1 m")])
def test_pixel_size_out_of_range_is_refused_naming_the_parameter(text, words):
    from tamp_os.errors import ParameterError
    from tamp_os.units import parse_length_m

    with pytest.raises(ParameterError, match="pixel_size") as err:
        parse_length_m(text)
    assert words in str(err.value) and text in str(err.value)


@pytest.mark.timeout(30)
def test_ome_without_unit_means_micrometres_and_imagej_picometres(tmp_path):
    from tamp_os.clean.scale import read_pixel_size

    data = np.zeros((8, 8), np.uint8)
    ome = tmp_path / "nounit.ome.tif"
    tifffile.imwrite(ome, data, ome=True, metadata={"PhysicalSizeX": 0.25})
    f = read_image(ome).file
    assert "PhysicalSizeXUnit" not in f.metadata["ome_metadata"]
    assert read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width).metres == pytest.approx(0.25e-6)
    ij = tmp_path / "ij.tif"
    tifffile.imwrite(ij, data, imagej=True, resolution=(0.5, 0.5), metadata={"unit": "pm"})
    f = read_image(ij).file
    assert read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width).metres == pytest.approx(2e-12)


@pytest.mark.timeout(30)
def test_cm_lengths_in_imagej_files(tmp_path):
    from tamp_os.clean.scale import read_pixel_size

    ij = tmp_path / "cm.tif"
    tifffile.imwrite(ij, np.zeros((8, 8), np.uint8), imagej=True, resolution=(100, 100), metadata={"unit": "cm"})
    f = read_image(ij).file
    assert read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width).metres == pytest.approx(1e-4)


@pytest.mark.timeout(30)
def test_fifo_and_devices_are_refused_before_opening(tmp_path):
    import os

    from tamp_os.errors import InputError

    fifo = tmp_path / "pipe.png"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="named pipe"):
        read_image(fifo)
    with pytest.raises(InputError, match="not a regular file"):
        read_image("/dev/zero")


@pytest.mark.timeout(30)
def test_cmyk_tiff_black_is_ink_not_alpha(tmp_path):
    cmyk = np.zeros((8, 8, 4), np.uint8)
    cmyk[..., 3] = 255  # full black ink
    cmyk[:4, :, 3] = 0  # top half: no ink at all, white paper
    path = tmp_path / "cmyk.tif"
    tifffile.imwrite(path, cmyk, photometric="separated")
    pic = read_image(path)
    assert pic.alpha is None
    assert pic.values[:4].mean() == pytest.approx(255) and pic.values[4:].mean() == pytest.approx(0)


@pytest.mark.timeout(30)
def test_luminance_weights_and_alpha_weighting(tmp_path):
    rgb = np.zeros((4, 3, 4), np.uint8)
    rgb[:, 0, 0], rgb[:, 1, 1], rgb[:, 2, 2] = 200, 200, 200
    rgb[..., 3] = 255
    rgb[0, :, 3] = 51  # first row 20 % opaque
    path = tmp_path / "rgba.png"
    Image.fromarray(rgb, "RGBA").save(path)
    pic = read_image(path)
    np.testing.assert_allclose(pic.values[1], [0.299 * 200, 0.587 * 200, 0.114 * 200], rtol=1e-5)
    np.testing.assert_allclose(pic.alpha[0], 0.2, rtol=1e-6)
    np.testing.assert_allclose(pic.alpha[1:], 1.0)


def test_a_diagrams_strokes_stay_and_its_words_go():
    """On empty paper, drawn strokes are the picture (a noisy stroke's darkest fragment once passed
    for an arrow and was inpainted, opening the drawn box); the printed words are removed."""
    from synthetic_content import line_diagram

    from tamp_os.read.image import read_array

    truth = line_diagram()
    cleaned = clean_picture(read_array((truth.image * 255).astype(np.uint8)), pixel_size_m=None, remove_annotations=True)
    assert sorted(a.kind for a in cleaned.annotations) == ["text"] * 3
    assert not cleaned.mask[truth.lines].any()
    assert cleaned.mask[truth.text].all()
    assert np.median(cleaned.values[truth.text]) > 200  # inpainted with the paper around them


@pytest.mark.timeout(120)
def test_one_core_reads_the_scale_bar_in_place_with_the_same_result(fixture, monkeypatch):
    """TAMP_THREADS=1 (a batch worker with one core to itself): the scale bar's label is read before
    clean_picture returns, on this thread, and gives what the reading beside the relief gives."""
    import threading
    from concurrent.futures import Future

    from tamp_os.clean import stage

    need(shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    picture = read_image(fixture("fept_spheres_sem.png"))
    beside = clean_picture(picture, pixel_size_m=None, remove_annotations=True).pixel_size
    monkeypatch.setenv("TAMP_THREADS", "1")
    stage._reader.cache_clear()
    try:
        threads = {t.name for t in threading.enumerate()}
        found = clean_picture(picture, pixel_size_m=None, remove_annotations=True)
        assert not isinstance(found.pixel_size_found, Future) or found.pixel_size_found.done()
        assert {t.name for t in threading.enumerate()} <= threads
    finally:
        stage._reader.cache_clear()
    assert found.pixel_size == beside and beside.provenance == "scale bar label"
