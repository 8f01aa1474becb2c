"""Issue 53, class 1: the data band names the detector the file may not record ("BSD Full … 10 kV",
"Det SE"), and the detector says which side of the picture is matter. Its text is read by OCR when
the file names no signal, and its words are matched whole ("SE" is not in "SEM")."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import need
from synthetic_content import bse_blood_cells, with_data_band
from tamp_os.clean import ocr
from tamp_os.clean.instrument import Instrument, instrument_from_text, matter_is_bright, with_band_words
from tamp_os.clean.stage import clean_picture
from tamp_os.read.image import read_array, read_image


@pytest.mark.parametrize("text, detector, signal", [
    ("BSD Full  10 kV  x2000", "BSD", "BSE"),
    ("Acc.V Spot Magn Det WD 200nm\n10.00 kV 4.0 63833x SE 9.9", "SE", "SE"),
    ("200 um EHT = 25.00 kV Signal A=HE-SE2 WD=14.8mm", "SE2", "SE"),
    ("HV 5.00kV | mode SE | det ETD | WD 4.0 mm", "SE", "SE"),
    ("STEM HAADF 300 kV 2.55 Mx", "HAADF", "STEM"),
    ("STEM BF 200 kV", "BF", "BF"),
    ("JEOL SEM 15kV x5,000 1um", None, None),  # a microscope, not a detector: SEM is no SE
    ("sample BASE layer 3", None, None),
])
def test_band_words_name_the_detector_as_whole_words(text, detector, signal):
    found = instrument_from_text(text)
    assert (found.detector if found else None) == detector
    assert (found.signal if found else None) == signal


def test_the_voltage_is_read_even_as_ocr_misreads_it():
    assert instrument_from_text("20.00 k¥ 5.0 1964x SE 10.0").kv == 20.0
    assert instrument_from_text("BSD Full 10 kV").kv == 10.0
    assert instrument_from_text("nothing to read here") is None


def test_which_side_is_matter_follows_the_signal():
    assert matter_is_bright("BSE") and matter_is_bright("SE") and matter_is_bright("STEM")
    assert matter_is_bright("BF") is False
    assert matter_is_bright(None) is None


def test_the_file_keeps_its_own_signal_and_the_band_fills_what_it_lacks():
    band = instrument_from_text("BSD Full 10 kV")
    recorded = Instrument(500.0, None, "ETD", "SE", "FEI/Thermo Fisher metadata")
    assert with_band_words(recorded, band) is recorded
    bare = Instrument(64000.0, None, None, None, "Olympus SIS")
    merged = with_band_words(bare, band)
    assert (merged.signal, merged.detector, merged.kv, merged.magnification) == ("BSE", "BSD", 10.0, 64000.0)
    assert "data band" in merged.source
    assert with_band_words(None, None) is None


@pytest.mark.timeout(60)
def test_a_backscatter_band_is_read_into_the_instrument():
    need(ocr.backend() is not None, "OCR (tesserocr with the eng model, or the tesseract command)")
    image = with_data_band(bse_blood_cells().image, "BSD Full  10 kV  x2000  WD 8 mm")
    cleaned = clean_picture(read_array((image * 255).astype(np.uint8)), pixel_size_m=None, remove_annotations=True)
    assert cleaned.band.bottom_rows >= 40
    assert cleaned.instrument is not None and cleaned.instrument.signal == "BSE", cleaned.instrument
    assert cleaned.instrument.kv == 10.0


@pytest.mark.timeout(60)
def test_without_a_band_nothing_is_read(monkeypatch):
    from tamp_os.clean import stage

    monkeypatch.setattr(stage, "band_text", lambda *a: pytest.fail("no band to read"))
    cleaned = clean_picture(read_array((bse_blood_cells(rows=200, cols=260).image * 255).astype(np.uint8)), pixel_size_m=None,
                            remove_annotations=True)
    assert cleaned.instrument is None


@pytest.mark.timeout(60)
def test_the_real_pearlite_band_says_secondary_electrons(fixture):
    """The Philips/FEI-style band of the pearlite micrograph reads "… Det SE …": the file's own
    metadata (Olympus SIS) gives the magnification and names no detector."""
    need(ocr.backend() is not None, "OCR (tesserocr with the eng model, or the tesseract command)")
    cleaned = clean_picture(read_image(fixture("real/sem_uhcs_pearlite_lamellae.tif")), pixel_size_m=None, remove_annotations=True)
    found = cleaned.instrument
    assert found.signal == "SE" and found.kv == 10.0 and found.magnification > 60000, found
