"""Issue 14 (microscopy input, second pass) and issue 12 (input hardening): scale bars read from
real data bands, black margins, EXIF orientation, Ångström and picometre lengths, and more."""

import shutil

import numpy as np
import pytest
import tifffile
from PIL import Image

from conftest import need
from tamp_os.clean.stage import clean_picture
from tamp_os.read import read_image


def stripped(fixture, tmp_path, name) -> tuple:
    """The fixture's pixels in a plain TIFF without its vendor metadata, and the metadata's pixel size."""
    truth = clean_picture(read_image(fixture(name)), pixel_size=None, remove_annotations=True).pixel_size
    path = tmp_path / f"stripped-{name}.tif"
    tifffile.imwrite(path, tifffile.imread(fixture(name)))
    return path, truth


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", ["test_tiff_Zeiss_SEM_1k.tif", "FEI-Helios-Ebeam-8bits.tif", "FEI-Helios-Ebeam-16bits.tif"])
def test_scale_bar_of_stripped_fixtures_within_5_percent(fixture, tmp_path, name):
    need(shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    path, truth = stripped(fixture, tmp_path, name)
    assert truth.metres and "bar" not in truth.provenance  # metadata first when present
    found = clean_picture(read_image(path), pixel_size=None, remove_annotations=True).pixel_size
    assert found.provenance == "scale bar label"
    assert found.metres == pytest.approx(truth.metres, rel=0.05)


@pytest.mark.timeout(120)
def test_fept_label_box_is_the_bar(fixture):
    need(shutil.which("tesseract") is not None, "Tesseract OCR (apt-get install tesseract-ocr)")
    found = clean_picture(read_image(fixture("fept_spheres_sem.png")), pixel_size=None, remove_annotations=True)
    # The white box spans columns 20-177: 158 px labelled "4 µm".
    assert found.pixel_size.provenance == "scale bar label"
    assert found.pixel_size.metres == pytest.approx(4e-6 / 158, rel=0.05)


@pytest.mark.timeout(60)
def test_natural_pictures_get_no_scale_and_no_warning():
    import skimage.data

    from tamp_os.read import read_array

    for name in ("cell", "moon", "coins", "camera"):
        cleaned = clean_picture(read_array(getattr(skimage.data, name)()), pixel_size=None, remove_annotations=True)
        assert cleaned.pixel_size.metres is None and cleaned.pixel_size.warnings == (), name
