"""clean/scale.py: Hitachi and JEOL sidecar files, good and bad values, and falling through to the next source."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tamp_os.mesh.solid import Mesh
from tamp_os.mesh.validate import check_as_written, check_solid, merge_float32
from conftest import examples


def _scale_with_sidecar(tmp_path, text):
    from tamp_os.clean.scale import read_pixel_size

    image = tmp_path / "sem.tif"
    image.write_bytes(b"")
    (tmp_path / "sem.txt").write_text(text)
    return read_pixel_size({}, {}, str(image), width_px=100)


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
    found = read_pixel_size({"imagej_metadata": {"unit": "micron"}}, {282: (4, 1)}, str(image), width_px=100)
    assert found.metres == pytest.approx(0.25e-6) and "ImageJ" in found.provenance
    assert any("Hitachi" in w for w in found.warnings)
