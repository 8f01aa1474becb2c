"""clean/scale.py: every pixel-size source, read from real files and from small made-up metadata."""

import math
import numpy as np
import pytest
from conftest import need


# Real microscope files and the pixel size their README states (from the vendor's own metadata).
REAL_PIXEL_SIZES = [
    ("FEI-Helios-Ebeam-8bits.tif", 3.3724e-6, "FEI [Scan] PixelWidth"),
    ("FEI-Helios-Ebeam-16bits.tif", 3.3724e-6, "FEI [Scan] PixelWidth"),
    ("test_tiff_Zeiss_SEM_1k.tif", 2.677e-3 / 1024, "Zeiss SmartSEM ap_width ÷ image width"),
    ("test_loading_image_saved_with_imageJ.tif", 0.16867e-6, "ImageJ resolution (micron)"),
    ("test_STEM_image.dm3", 0.2485e-9, "DigitalMicrograph calibration"),
    ("real/tvips_bin4.tif", 1.4208e-9, "TVIPS tag 37706 PixelSizeX (nm)"),
    ("real/aperio_cmu1_he_skin.svs", 0.4990e-6, "Aperio SVS MPP"),
    ("real/confocal_beads_zstack_41z.tif", 0.022492e-6, "ImageJ resolution (µm)"),
    ("real/zeiss_sem_al2o3_grains.czi", 27.91e-9, "Zeiss CZI Scaling/Items/Distance[@Id='X'/'Y']/Value"),
    ("real/nikon_pbmc_4ch.nd2", 0.32339e-6, "Nikon ND2 voxel_size() x, y (µm)"),
    ("real/tia_talos_tem_search.emi", 5.2612e-9, "FEI TIA (.emi/.ser) axes['x'].scale (nm)"),
]


def _file_pixel_size(path, pixel_size_m=None):
    from tamp_os.clean.scale import read_pixel_size
    from tamp_os.read.image import read_image

    f = read_image(path).file
    return read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width, pixel_size_m=pixel_size_m)


@pytest.mark.timeout(20)
@pytest.mark.parametrize("name, metres, provenance", REAL_PIXEL_SIZES, ids=[r[0] for r in REAL_PIXEL_SIZES])
def test_pixel_size_of_real_files_is_the_readmes(fixtures_dir, name, metres, provenance):
    path = fixtures_dir / name
    need(path.is_file(), f"fixture {name}")
    found = _file_pixel_size(path)
    assert found.metres == pytest.approx(metres, rel=2e-4)
    assert found.provenance.startswith(provenance), found.provenance
    assert found.warnings == ()


@pytest.mark.timeout(20)
@pytest.mark.parametrize("name", ["JEOL-SightX-TEM-mag-dummy.tif", "real/confocal_membranes_cells3d.tif",
                                  "real/sem_fei_sio2_particles_35kx.tif"])
def test_files_with_only_a_dpi_tag_have_no_pixel_size_and_say_why(fixtures_dir, name):
    path = fixtures_dir / name
    need(path.is_file(), f"fixture {name}")
    found = _file_pixel_size(path)
    assert (found.metres, found.provenance) == (None, "none")
    assert found.warnings == ("the file's dpi/resolution tag is not a physical pixel size and was ignored.",)


@pytest.mark.timeout(20)
def test_a_czi_with_only_pixel_items_has_no_pixel_size(fixture):
    found = _file_pixel_size(fixture("real/zeiss_dapi_gfp_2ch.czi"))
    assert (found.metres, found.provenance, found.warnings) == (None, "none", ())


@pytest.mark.timeout(20)
def test_the_users_pixel_size_wins_and_a_different_one_is_said(fixture):
    from tamp_os.clean.scale import USER_GIVEN

    path = fixture("FEI-Helios-Ebeam-8bits.tif")
    same = _file_pixel_size(path, 3.3724e-6 * 1.009)  # within 1 %: no warning
    assert (same.metres, same.provenance, same.warnings) == (3.3724e-6 * 1.009, USER_GIVEN, ())
    other = _file_pixel_size(path, 3.3724e-6 * 1.02)
    assert other.metres == 3.3724e-6 * 1.02 and other.provenance == USER_GIVEN
    assert [str(w) for w in other.warnings] == ["pixel_size 3.44 µm (given by the user) overrides 3.372 µm from FEI [Scan] PixelWidth."]
    lower = _file_pixel_size(path, 3.3724e-6 / 1.02)
    assert len(lower.warnings) == 1 and "overrides 3.372 µm" in lower.warnings[0]


def _size(metadata=None, tags=None, path=None, width=100, user=None):
    from tamp_os.clean.scale import read_pixel_size

    return read_pixel_size(metadata or {}, tags or {}, path, width_px=width, pixel_size_m=user)


def test_the_user_value_alone_and_no_source_at_all():
    from tamp_os.clean.scale import USER_GIVEN

    assert _size(user=2e-9) == type(_size())(2e-9, USER_GIVEN, ())
    nothing = _size()
    assert (nothing.metres, nothing.provenance, nothing.warnings) == (None, "none", ())
    assert _size({"dpi_not_physical": True}).warnings == ("the file's dpi/resolution tag is not a physical pixel size and was ignored.",)
    assert _size({"dpi_not_physical": True}, user=1e-6).warnings == ()  # a scale was given: nothing to say


@pytest.mark.parametrize("value, ok", [(1e-13, True), (1e-2, True), (0.99e-13, False), (1.01e-2, False), (0.0, False),
                                       (-1e-6, False)])
def test_plausible_pixel_sizes_are_inclusive_at_both_ends(value, ok):
    found = _size({"sis_metadata": {"pixelsizex": value}})
    assert (found.metres == value) == ok
    if ok:
        assert found.provenance == "Olympus SIS pixelsizex" and found.warnings == ()
    else:
        assert found.warnings == (f"Olympus SIS pixelsizex: pixel size {value:g} m is zero, negative or implausible; ignored.",)


def test_a_source_that_is_not_a_number_is_said_and_the_next_is_used():
    found = _size({"sis_metadata": {"pixelsizex": "n/a"}, "tvips_metadata": {"PixelSizeX": 2.5}})
    assert found.metres == pytest.approx(2.5e-9) and found.provenance == "TVIPS tag 37706 PixelSizeX (nm)"
    assert found.warnings == ("Olympus SIS pixelsizex: present but not a number; ignored.",)


def test_readers_go_most_specific_first():
    both = {"vendor": {"pixel_size_m": [4e-9, 4e-9], "format": "Zeiss CZI", "pixel_size_key": "Distance", "reader": "czifile"},
            "fei_metadata": {"Scan": {"PixelWidth": 5e-9}}, "sis_metadata": {"pixelsizex": 6e-9}}
    found = _size(both)
    assert found.metres == 4e-9 and found.provenance == "Zeiss CZI Distance (read by czifile)"
    del both["vendor"]
    assert _size(both).metres == 5e-9 and _size(both).provenance == "FEI [Scan] PixelWidth"
    both["fei_metadata"] = {"Scan": {}}
    assert _size(both).metres == 6e-9
    assert _size({"vendor": {"pixel_size_m": None, "format": "x"}}).provenance == "none"
    assert _size({"vendor": {"pixel_size_m": ["nan"], "format": "F", "pixel_size_key": "k", "reader": "r"}}).warnings == (
        "F k (read by r): present but not a number; ignored.",)


@pytest.mark.parametrize("entry, width, metres", [
    (("Width", 2.677, "mm"), 1024, 2.677e-3 / 1024), (("Width", "50", "µm"), 500, 1e-7), (("Width", 3.0, "furlong"), 10, None),
    (("Width",), 10, None), (("Width", None, None), 10, None),
])
def test_zeiss_field_width_divided_by_the_image_width(entry, width, metres):
    found = _size({"sem_metadata": {"ap_width": entry}}, width=width)
    assert found.metres == (pytest.approx(metres) if metres else None)
    if metres is None:
        assert found.warnings == ("Zeiss SmartSEM ap_width ÷ image width: present but not a number; ignored.",)
    assert _size({"sem_metadata": {"ap_mag": 1}}).provenance == "none"


def test_tvips_nanometres_and_svs_micrometres_with_their_pyramid_level():
    assert _size({"tvips_metadata": {"PixelSizeX": "1.25"}}).metres == pytest.approx(1.25e-9)
    assert _size({"tvips_metadata": {"PixelSizeX": "x"}}).warnings[0].startswith("TVIPS tag 37706 PixelSizeX (nm): present")
    assert _size({"tvips_metadata": {"PixelSizeY": 1}}).provenance == "none"
    level0 = _size({"svs_metadata": {"MPP": "0.499"}})
    assert level0.metres == pytest.approx(0.499e-6) and level0.provenance == "Aperio SVS MPP"
    level2 = _size({"svs_metadata": {"MPP": 0.499}, "pyramid_downsample": 4.0, "pyramid_level": 2})
    assert level2.metres == pytest.approx(4 * 0.499e-6) and level2.provenance == "Aperio SVS MPP × 4 (pyramid level 2)"
    assert _size({"svs_metadata": {"MPP": "?"}}).warnings[0].startswith("Aperio SVS MPP: present but not a number")
    assert _size({"svs_metadata": {"AppMag": 20}}).provenance == "none"


@pytest.mark.parametrize("tags, metres", [
    ({65009: 0.5, 65003: "nm"}, 0.5e-9), ({65009: (2.0,), 65012: b"\xb5m\x00"}, 2e-6), ({65009: b"3", 65003: ("um",)}, 3e-6),
    ({65010: 4.0, 65003: "\u00b5m".encode()}, 4e-6), ({65009: 1.5, 65003: "pixel", 65012: " nm\x00"}, 1.5e-9),
])
def test_digitalmicrograph_tiff_tags(tags, metres):
    found = _size(tags=tags)
    assert found.metres == pytest.approx(metres) and found.provenance == "DigitalMicrograph TIFF tags"
    assert found.warnings == ()


def test_digitalmicrograph_tiff_tags_without_a_length_unit():
    assert _size(tags={65009: 1.0, 65003: "pixel"}).warnings == (
        "DigitalMicrograph TIFF tags: unit 'pixel' is not a length; no scale.",)
    assert _size(tags={65009: 1.0}).warnings == ("DigitalMicrograph TIFF tags: unit 'missing' is not a length; no scale.",)
    assert _size(tags={65009: "x", 65003: "nm"}).warnings == ("DigitalMicrograph TIFF tags: present but not a number; ignored.",)
    assert _size(tags={65003: "nm"}).provenance == "none"


def test_tag_text_of_each_form_tifffile_gives():
    from tamp_os.clean.scale import _tag_text

    assert _tag_text(("nm\x00",)) == "nm"
    assert _tag_text(["µm"]) == "µm"
    assert _tag_text(("a", "b")) == "('a', 'b')"  # not a 1-tuple: its text as it is
    assert _tag_text(b"\xc2\xb5m") == "µm" and _tag_text(b"\xb5m") == "µm"
    assert _tag_text(" \tnm \x00") == "nm" and _tag_text(7) == "7"


def test_tescan_pixel_size_from_its_tag_and_from_its_sidecar(tmp_path):
    text = "[MAIN]\nDevice=VEGA\nPixelSizeX=2.5e-08\n"
    found = _size(tags={50431: text.encode()})
    assert found.metres == pytest.approx(2.5e-8) and found.provenance == "TESCAN tag 50431 [MAIN] PixelSizeX"
    image = tmp_path / "vega.tif"
    image.write_bytes(b"")
    (tmp_path / "vega.hdr").write_text(text)
    found = _size(path=str(image))
    assert found.metres == pytest.approx(2.5e-8) and found.provenance == "TESCAN sidecar vega.hdr [MAIN] PixelSizeX"
    assert _size(tags={50431: "[MAIN]\nDevice=VEGA\n"}).warnings == ("TESCAN tag 50431 [MAIN] PixelSizeX: present but not a number; ignored.",)


def test_sidecar_provenance_names_the_file_and_the_keys(tmp_path):
    image = tmp_path / "s4800.tif"
    image.write_bytes(b"")
    sidecar = tmp_path / "s4800.txt"
    sidecar.write_text("PixelSize=4\n")
    found = _size(path=str(image))
    assert found.metres == pytest.approx(4e-9) and found.provenance == "Hitachi sidecar s4800.txt PixelSize (nm)"
    sidecar.write_text("$$SM_MICRON_BAR 100\n$$SM_MICRON_MARKER 2 mm\n")
    found = _size(path=str(image))
    assert found.metres == pytest.approx(2e-5) and found.provenance == "JEOL sidecar s4800.txt SM_MICRON_MARKER ÷ SM_MICRON_BAR"
    sidecar.write_text("x" * 2_000_000)  # larger than any sidecar: ignored with a warning
    assert "too large for a microscope sidecar" in _size(path=str(image)).warnings[0]
    assert _size(path=str(tmp_path / "none.tif")).provenance == "none"


@pytest.mark.parametrize("text, expected", [
    ("10um", (10.0, "um")), (" 10 um ", (10.0, "um")), ("2.5µm bar", (2.5, "µm")), ("500nm", (500.0, "nm")),
    ("um", (None, "um")), ("", (None, "")), ("7", (7.0, "")), ("3 μm", (3.0, "μm")), ("1.5Å", (1.5, "")),
    ("12 MM2", (12.0, "MM")),
])
def test_number_and_unit_of_a_jeol_marker(text, expected):
    from tamp_os.clean.scale import _number_and_unit

    assert _number_and_unit(text) == expected


@pytest.mark.parametrize("res, unit, metres", [
    ((4, 1), "micron", 0.25e-6), ((8, 2), "nm", 0.25e-9), (2.0, "mm", 0.5e-3), ((5928571, 1000000), "micron", 0.16867e-6),
    ((1, 0), "micron", None), ((0, 1), "micron", None), ((-2, 1), "micron", None), (("a", "b"), "micron", None),
    ((4,), "micron", None),
])
def test_imagej_resolution_is_pixels_per_unit(res, unit, metres):
    found = _size({"imagej_metadata": {"unit": unit}}, {282: res})
    if metres is None:
        assert found.metres is None
        assert found.warnings == (f"ImageJ resolution ({unit}): present but not a number; ignored.",
                                  "the file's dpi/resolution tag is not a physical pixel size and was ignored.")
    else:
        assert found.metres == pytest.approx(metres, rel=1e-4) and found.provenance == f"ImageJ resolution ({unit})"


def test_imagej_escaped_micro_sign_and_what_is_not_a_source():
    found = _size({"imagej_metadata": {"unit": "\\u00B5m"}}, {282: (2, 1)})
    assert found.metres == pytest.approx(0.5e-6) and found.provenance == "ImageJ resolution (µm)"
    assert _size({"imagej_metadata": {"unit": "pixel"}}, {282: (2, 1)}).metres is None
    assert _size({"imagej_metadata": {"unit": "nm"}}).metres is None  # no resolution tag
    assert _size({"imagej_metadata": {"spacing": 1}}, {282: (2, 1)}).warnings == (
        "the file's dpi/resolution tag is not a physical pixel size and was ignored.",)


OME = '<OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image><Pixels {}/></Image></OME>'


@pytest.mark.parametrize("attrs, meta, metres, provenance", [
    ('PhysicalSizeX="0.5" PhysicalSizeXUnit="nm"', {}, 0.5e-9, "OME PhysicalSizeX"),
    ('PhysicalSizeX="0.5"', {}, 0.5e-6, "OME PhysicalSizeX"),  # the schema's default unit is µm
    ('PhysicalSizeX="2" PhysicalSizeXUnit="mm"', {"pyramid_downsample": 2.0, "pyramid_level": 1}, 4e-3,
     "OME PhysicalSizeX × 2 (pyramid level 1)"),
])
def test_ome_physical_size(attrs, meta, metres, provenance):
    found = _size({"ome_metadata": OME.format(attrs), **meta})
    assert found.metres == pytest.approx(metres) and found.provenance == provenance


def test_ome_without_a_namespace_and_what_is_not_a_size():
    assert _size({"ome_metadata": '<OME><Pixels PhysicalSizeX="3"/></OME>'}).metres == pytest.approx(3e-6)
    assert _size({"ome_metadata": OME.format('SizeX="3"')}).warnings == ()
    assert _size({"ome_metadata": OME.format('PhysicalSizeX="3" PhysicalSizeXUnit="pixel"')}).warnings == (
        "OME PhysicalSizeX: present but not a number; ignored.",)
    assert _size({"ome_metadata": "<OME><Image>"}).warnings == ("OME-XML: cannot be parsed; ignored.",)
    assert _size({"ome_metadata": b"<OME/>"}).warnings == ("OME-XML: cannot be parsed; ignored.",)
    assert _size({"ome_metadata": "<OME><Image/></OME>"}).provenance == "none"


def test_digitalmicrograph_calibration_of_the_last_axis():
    axes = [{"scale": 9.0, "units": "µm"}, {"scale": 0.2485, "units": "nm"}]
    found = _size({"dm_axes": axes})
    assert found.metres == pytest.approx(0.2485e-9) and found.provenance == "DigitalMicrograph calibration"
    assert _size({"dm_axes": [{"scale": 1.0, "units": "1/nm"}]}).warnings == (
        "DigitalMicrograph: axis unit '1/nm' is not a length; no scale.",)
    assert _size({"dm_axes": [{"scale": "?", "units": "nm"}]}).warnings == (
        "DigitalMicrograph calibration: present but not a number; ignored.",)
    assert _size({"dm_axes": [{"scale": 2.0}]}).warnings == ("DigitalMicrograph: axis unit None is not a length; no scale.",)
    assert _size({"dm_axes": []}).provenance == "none"


@pytest.mark.parametrize("pixel_m, px_per_mm, sentence", [
    (1e-6, 10.0, "1 mm on the print = 10 µm in the sample (magnification 100×)"),
    (2.6142578125e-6, 10.24, "1 mm on the print = 26.77 µm in the sample (magnification 37.4×)"),
    (1e-9, 100.0, "1 mm on the print = 100 nm in the sample (magnification 10,000×)"),
    (1e-5, 10.0, "1 mm on the print = 100 µm in the sample (magnification 10×)"),
    (1.5e-7, 10.0, "1 mm on the print = 1.5 µm in the sample (magnification 667×)"),
])
def test_scale_sentence_of_known_magnifications(pixel_m, px_per_mm, sentence):
    from tamp_os.clean.scale import scale_sentence

    assert scale_sentence(pixel_m, px_per_mm) == sentence
    assert math.isclose(1e-3 / (pixel_m * px_per_mm), float(sentence.split("magnification ")[1].rstrip("×)").replace(",", "")),
                        rel_tol=5e-3)
