"""The parameters object: what a wrong value is told."""

import dataclasses

import pytest

from tamp_os.errors import ParameterError
from tamp_os.params import LithoParams


def test_an_unreadable_scale_bar_names_auto_and_off_beside_a_length():
    # --scale-bar takes auto, off or a length; the message named only "a number and a unit"
    with pytest.raises(ParameterError) as info:
        LithoParams(scale_bar="5furlongs")
    text = str(info.value)
    assert "scale_bar" in text and "'5furlongs'" in text
    assert "auto" in text and "off" in text, text
    assert "auto" in info.value.allowed and "off" in info.value.allowed


def test_pixel_size_names_no_words_it_does_not_take():
    with pytest.raises(ParameterError) as info:
        LithoParams(pixel_size="5furlongs")
    assert "auto" not in str(info.value) and "off" not in str(info.value)


def test_every_parameter_sits_in_exactly_one_stage_section_in_field_order():
    from tamp_os.params import SECTIONS

    in_sections = [name for _, names in SECTIONS for name in names]
    assert in_sections == [f.name for f in dataclasses.fields(LithoParams)]
    assert len({title for title, _ in SECTIONS}) == len(SECTIONS)
    p = LithoParams(relief_mm=2.0, mesher="grid")
    assert p.section("heights and contrast")["relief_mm"] == 2.0
    assert p.section("mesh") == {"mesher": "grid", "max_error_mm": None}
    with pytest.raises(ParameterError, match="no section 'meshes'"):
        p.section("meshes")


def test_the_parameters_check_themselves_without_importing_a_stage():
    import subprocess
    import sys

    code = ("import sys, tamp_os.params as p; p.LithoParams(panels='2x3', panel_boxes='a=0,0,50,50;b=50,0,50,50'); "
            "print(sorted({m.split('.')[1] for m in sys.modules if m.startswith('tamp_os.') and m.count('.') >= 2}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True).stdout
    stages = {"read", "clean", "relief", "mesh", "tactile", "export", "lithograph"}
    assert not stages & set(eval(out)), out


def test_read_options_are_what_read_image_takes_with_the_parameters_values():
    import inspect

    from tamp_os.read.image import read_image

    p = LithoParams(page=2, scene="xz", max_megapixels=7.0)
    options = p.read_options(z_slice=0)
    assert set(options) <= set(inspect.signature(read_image).parameters)
    assert options["page"] == 2 and options["scene"] == "xz" and options["max_megapixels"] == 7.0 and options["z_slice"] == 0
    assert options["max_memory_gb"] == p.max_memory_gb and options["channel"] == "luminance"
