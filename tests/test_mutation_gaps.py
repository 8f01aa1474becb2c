"""Tests the mutation study of issue 25 found missing in mesh/validate.py, tactile/braille.py,
relief/legibility.py and clean/scale.py (scripts/mutation.py measures the kill rate)."""

import math

import numpy as np
import pytest

from conftest import need

# --- clean/scale.py: every source, read from real files and from small made-up metadata ----------

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
    return read_pixel_size(f.metadata, f.tiff_tags, f.path, f.width, pixel_size_m)


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

    return read_pixel_size(metadata or {}, tags or {}, path, width, user)


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


# --- relief/legibility.py: figures of synthetic reliefs with known answers, and every verdict ----

def _figures(**changes) -> dict:
    """Figures of a relief that reads well (no advice), changed where a test says."""
    base = dict(fine_share=0.1, levels_used=3, smallest_step_mm=1.0, narrow_area_mm2=0.0, narrow_share=0.0,
                steepest_slope_deg=44.6, object_count=0, object_lift_mm=None, lowest_lift_mm=None, relief_span_mm=2.0,
                period_mm=None)
    return {**base, **changes}


def _verdicts(style=None, nozzle_mm=0.4, **changes) -> list[str]:
    from tamp_os.relief.legibility import verdicts

    return [str(v) for v in verdicts(_figures(**changes), nozzle_mm, style)]


def test_verdicts_of_a_relief_that_reads_well():
    assert _verdicts() == [
        "Most of the relief is shape a fingertip can follow: only 10% of its variation is finer than about 1 mm.",
        "3 distinct height levels, at least 1 mm apart: easy to tell apart by touch.",
        "The steepest slope is 45 degrees.",
    ]


@pytest.mark.parametrize("span, levels, flat", [(0.049, 1, True), (0.049, 0, True), (0.05, 1, False), (0.01, 2, False)])
def test_a_flat_plate_is_only_said_when_nothing_is_raised(span, levels, flat):
    said = _verdicts(relief_span_mm=span, levels_used=levels, smallest_step_mm=None)
    assert (said == ["This print is a flat plate: there is nothing raised to feel."]) == flat


def test_fine_share_verdicts_at_and_above_the_warning():
    assert _verdicts(fine_share=0.2)[0].startswith("Most of the relief is shape")  # 0.2 is not above the warning
    rough = "21% of this relief's height variation is finer than a fingertip resolves (about 1 mm), so it is felt as roughness, not as shape; "
    assert _verdicts(fine_share=0.21)[0] == rough + "try relief_style structure, or a larger detail_mm."
    assert _verdicts(fine_share=0.21, style="structure")[0] == rough + "try a larger detail_mm or a lower texture_mm."
    assert _verdicts(fine_share=0.5, style="content")[0] == (
        "50% of this relief's height variation is finer than a fingertip resolves (about 1 mm): it is the edges of the "
        "drawn content (raised lines, members' outlines), kept on purpose; a wider print spreads it out.")
    assert _verdicts(fine_share=0.5, period_mm=3.04, style="content")[0] == (
        "50% of this relief's height variation is finer than a 1 mm low-pass keeps, but it is a lattice of 3.0 mm pitch, "
        "which fingers feel as a pattern (braille dots are 2.5 mm apart), not as roughness.")
    assert _verdicts(fine_share=0.1, period_mm=3.0)[0].startswith("Most of the relief")  # a period only matters when rough


def test_the_advice_names_parameters_in_each_front_ends_words():
    from tamp_os.relief.legibility import verdicts

    said = verdicts(_figures(fine_share=0.3), 0.4)[0]
    assert "`relief_style` structure" in said.template and "`detail_mm`" in said.template


def test_level_verdicts_at_their_thresholds():
    assert _verdicts(levels_used=9)[1] == (
        "The heights vary continuously (9 layer levels in use): read it as a landscape, not as distinct levels.")
    assert _verdicts(levels_used=8)[1] == "8 distinct height levels, at least 1 mm apart: easy to tell apart by touch."
    assert _verdicts(levels_used=2, smallest_step_mm=0.3)[1] == (
        "2 height levels; the smallest step between neighbouring regions is 0.3 mm, under the 0.5 mm fingers tell "
        "apart reliably; try fewer levels or a taller relief.")
    assert _verdicts(smallest_step_mm=0.5)[1] == "3 distinct height levels, at least 0.5 mm apart: easy to tell apart by touch."
    assert _verdicts(smallest_step_mm=0.4999999)[1].startswith("3 height levels; the smallest step")
    assert len(_verdicts(levels_used=1, smallest_step_mm=None)) == 2  # no level sentence


def test_narrow_feature_verdict_above_five_percent():
    assert not any("narrower" in v for v in _verdicts(narrow_share=0.05, narrow_area_mm2=50))
    assert _verdicts(narrow_share=0.051, narrow_area_mm2=51.2, nozzle_mm=0.6)[2] == (
        "51 mm² (5% of the picture) is ridges or grooves narrower than two nozzle widths (1.2 mm): they may not print "
        "and read as noise; a larger detail_mm removes them.")


def test_object_verdicts_singular_plural_low_and_high():
    one_low = _verdicts(object_count=1, object_lift_mm=0.4, lowest_lift_mm=0.4)
    assert one_low[2] == ("The 1 object stands only 0.4 mm (median) above the ground around it; a finger may not find it; "
                          "try relief_style objects.")
    two_low = _verdicts(object_count=2, object_lift_mm=0.99, lowest_lift_mm=0.5, style="objects")
    assert two_low[2] == ("The 2 objects stand only 0.99 mm (median) above the ground around them; a finger may not find "
                          "them; try a taller relief_mm.")
    # The content style's own check measures its members against the picture (issue 32: a dense
    # lattice's "stand only 0 mm (median)" beside "392 members, all raised at least 2.0 mm").
    assert not any("stand only" in v for v in _verdicts(object_count=2, object_lift_mm=0.0, lowest_lift_mm=0.0, style="content"))
    assert _verdicts(object_count=2, object_lift_mm=0.5, lowest_lift_mm=0.5, style="objects")[2].endswith("try a taller relief_mm.")
    assert _verdicts(object_count=1, object_lift_mm=1.0, lowest_lift_mm=1.0)[2] == (
        "1 object stands 1 mm (median; lowest 1 mm) above the ground around it.")
    assert _verdicts(object_count=3, object_lift_mm=2.0, lowest_lift_mm=1.5)[2] == (
        "3 objects stand 2 mm (median; lowest 1.5 mm) above the ground around them.")
    # The content style says its members' height once, in its own check ("Found 3 members, all raised ...").
    assert not any("objects stand" in v for v in _verdicts(object_count=3, object_lift_mm=2.0, lowest_lift_mm=1.5, style="content"))


MM = 0.4


def _two_levels(low=1.0, high=3.0, shape=(60, 80)):
    h = np.full(shape, low)
    h[:, shape[1] // 2:] = high
    return h


def test_span_levels_and_shares_of_a_two_level_plate():
    from tamp_os.relief.legibility import assess

    report = assess(_two_levels(), MM)
    assert report.relief_span_mm == pytest.approx(2.0)
    assert report.levels_used == 2 and report.smallest_step_mm == pytest.approx(2.0)
    assert report.object_count == 0 and report.object_lift_mm is None and report.lowest_lift_mm is None
    assert report.narrow_area_mm2 == 0.0 and report.narrow_share == 0.0
    assert report.period_mm is None and report.levels_mm is None
    assert report.verdicts[1] == "2 distinct height levels, at least 2 mm apart: easy to tell apart by touch."
    # The step is 0.4 mm wide at 0.4 mm a pixel (one pixel): arctan(2 / 0.8) on the central difference.
    assert report.steepest_slope_deg == pytest.approx(np.degrees(np.arctan(2.0 / (2 * MM))), abs=0.5)


def test_a_level_must_cover_a_fingertips_area():
    from tamp_os.relief.legibility import assess

    h = np.full((50, 50), 1.0)  # 20 × 20 mm at 0.4 mm a pixel
    h[10:14, 10:14] = 2.0  # 16 px = 2.56 mm²: under the 6 mm² default
    assert assess(h, MM).levels_used == 1 and assess(h, MM).smallest_step_mm is None
    assert assess(h, MM, min_area_mm2=2.5).levels_used == 2
    h[10:17, 10:17] = 2.0  # 49 px = 7.84 mm²
    assert assess(h, MM).levels_used == 2 and assess(h, MM).smallest_step_mm == pytest.approx(1.0)


def test_heights_are_compared_to_the_layer_height():
    from tamp_os.relief.legibility import assess

    h = _two_levels(1.0, 1.06)
    assert assess(h, MM).levels_used == 2  # 0.06 mm rounds to one 0.1 mm layer
    assert assess(h, MM).smallest_step_mm == pytest.approx(0.1)
    assert assess(h, MM, layer_mm=0.2).levels_used == 1  # 0.06 mm rounds to no 0.2 mm layer
    assert assess(h, MM, layer_mm=0.03).smallest_step_mm == pytest.approx(0.06)
    fine = assess(_two_levels(1.0, 1.0005), MM, layer_mm=1e-6)  # the quantum is at least 1 µm
    assert fine.levels_used == 1


def test_levels_that_never_touch_have_no_step():
    from tamp_os.relief.legibility import _levels_and_step

    q = np.zeros((40, 40))
    q[:, 20:] = 1.0
    assert _levels_and_step(q, 0.1, 10) == (2, pytest.approx(1.0))
    assert _levels_and_step(q, 0.1, 801) == (0, None)
    # Two big regions separated by a thin strip that is too small to count: no step between big neighbours.
    q = np.zeros((40, 41))
    q[:, 20] = 0.5
    q[:, 21:] = 1.0
    levels, step = _levels_and_step(q, 0.1, 100)
    assert levels == 2 and step is None


def test_fine_share_of_a_flat_a_smooth_and_a_rough_relief():
    from tamp_os.relief.legibility import _fine_share

    assert _fine_share(np.full((30, 30), 2.0), MM) == 0.0
    assert _fine_share(np.full((30, 30), 2.0) + 1e-7 * (np.arange(30) % 2), MM) == 0.0  # variance under 1e-12
    checker = 1.0 + (np.indices((60, 60)).sum(0) % 2)  # a pixel checkerboard: almost all fine
    assert _fine_share(checker, MM) > 0.95
    wide = np.tile(np.sin(np.arange(200) * 2 * np.pi * MM / 40.0), (20, 1))  # 40 mm waves: a fingertip follows them
    assert _fine_share(wide, MM) < 0.01
    # The low-pass is sigma = 1 mm on the print: at a finer pitch the same waves are the same share.
    fine_pitch = np.tile(np.sin(np.arange(800) * 2 * np.pi * 0.1 / 4.0), (20, 1))
    coarse_pitch = np.tile(np.sin(np.arange(200) * 2 * np.pi * MM / 4.0), (20, 1))
    assert _fine_share(fine_pitch, 0.1) == pytest.approx(_fine_share(coarse_pitch, MM), abs=0.05)


def test_a_grating_a_finger_can_feel_has_its_period():
    from tamp_os.relief.legibility import assess

    x = np.arange(250) * MM
    grating = np.tile(1.0 + (np.sin(2 * np.pi * x / 4.0) > 0), (120, 1))  # 4 mm bars: rough by share, felt as a pattern
    report = assess(grating, MM)
    assert report.fine_share > 0.2
    assert report.period_mm == pytest.approx(4.0, rel=0.05)
    assert "lattice of 4.0 mm pitch" in report.verdicts[0]
    fine = np.tile(1.0 + (np.sin(2 * np.pi * x / 1.6) > 0), (120, 1))  # 1.6 mm bars: finer than 2.5 mm, roughness
    assert assess(fine, MM).period_mm is None


def test_feelable_period_of_a_flat_work_grid_is_none():
    from tamp_os.relief.legibility import _feelable_period

    assert _feelable_period(np.full((40, 40), 3.0), MM) is None


def test_narrow_area_counts_ridges_and_grooves_but_not_low_ones():
    from tamp_os.relief.legibility import _narrow_area

    pitch = 0.1
    h = np.ones((100, 100))
    h[:, 20:23] += 1.0  # a ridge 0.3 mm wide
    h[:, 60:63] -= 1.0  # a groove 0.3 mm wide
    area = _narrow_area(h, pitch, 0.4)
    assert area == pytest.approx(2 * 0.3 * 100 * pitch, rel=0.01)
    low = np.ones((100, 100))
    low[:, 20:23] += 0.25  # not higher than 0.25 mm: texture
    assert _narrow_area(low, pitch, 0.4) == 0.0
    low[:, 20:23] += 0.01
    assert _narrow_area(low, pitch, 0.4) == pytest.approx(0.3 * 100 * pitch, rel=0.01)


def test_narrow_share_is_of_the_whole_relief():
    from tamp_os.relief.legibility import assess

    pitch = 0.1
    h = np.ones((200, 200))
    h[:, 50:53] += 1.0
    report = assess(h, pitch, nozzle_mm=0.4)
    assert report.narrow_share == pytest.approx(report.narrow_area_mm2 / (200 * 200 * pitch**2))


def test_lift_of_labelled_objects_against_the_ground_they_own():
    from tamp_os.relief.legibility import _lifts

    yy, xx = np.mgrid[0:100, 0:200]
    a = (yy - 50) ** 2 + (xx - 50) ** 2 < 10**2
    b = (yy - 50) ** 2 + (xx - 150) ** 2 < 10**2
    h = np.where(xx < 100, 1.0, 2.0)  # each object's own ground: 1 mm on the left, 2 mm on the right
    h = h + 3.0 * a + 0.5 * b
    labels = a * 1 + b * 2
    n, median_lift, lowest = _lifts(h, labels, MM)
    assert n == 2 and lowest == pytest.approx(0.5) and median_lift == pytest.approx((3.0 + 0.5) / 2)
    assert _lifts(h, a | b, MM)[1:] == pytest.approx((1.75, 0.5))  # a mask is labelled first
    assert _lifts(h, np.zeros_like(labels), MM) == (0, None, None)
    assert _lifts(h, None, MM) == (0, None, None)


def test_lift_without_a_ring_of_ground_uses_all_the_ground():
    from tamp_os.relief.legibility import _lifts

    h = np.full((40, 40), 1.0)
    mask = np.zeros((40, 40), bool)
    mask[:, :39] = True  # the object leaves one column of ground, 0.4 mm away: no ring 1-3 mm out
    h[mask] = 2.5
    h[:, 39] = 1.5
    n, lift, lowest = _lifts(h, mask, MM)
    assert n == 1 and lift == pytest.approx(1.0) and lowest == pytest.approx(1.0)


def test_lift_ring_is_one_to_three_mm_around_the_object():
    from tamp_os.relief.legibility import _lifts

    pitch = 0.25
    yy, xx = np.mgrid[0:120, 0:120]
    r = np.hypot(yy - 60, xx - 60)
    mask = r < 12
    h = np.full((120, 120), 5.0)  # far ground: 5 mm, never in the ring
    h[r < 12 + 3 / pitch] = 1.0  # the ring 1-3 mm out (and the first mm) at 1 mm
    h[(r >= 12) & (r < 12 + 0.9 / pitch)] = 9.0  # the first millimetre next to the object is left out
    h[mask] = 2.0
    assert _lifts(h, mask, pitch)[1] == pytest.approx(1.0)


def test_the_report_as_a_dictionary():
    from tamp_os.relief.legibility import assess

    report = assess(_two_levels(), MM)
    d = report.as_dict()
    assert "levels_mm" not in d and isinstance(d["verdicts"], list) and d["verdicts"] == list(report.verdicts)
    assert d["levels_used"] == 2 and d["relief_span_mm"] == pytest.approx(2.0)
    import dataclasses

    with_levels = dataclasses.replace(report, levels_mm=(1.0, 3.0)).as_dict()
    assert with_levels["levels_mm"] == [1.0, 3.0]


def test_a_fine_grid_is_measured_on_a_working_grid_of_a_quarter_nozzle():
    from tamp_os.relief.legibility import assess

    pitch = 0.025  # 4 times finer than nozzle / 4
    h = np.ones((400, 400))
    h[:, 100:112] += 1.0  # a ridge 0.3 mm wide
    report = assess(h, pitch, nozzle_mm=0.4)
    assert report.narrow_area_mm2 == pytest.approx(0.3 * 400 * pitch, rel=0.35)
    assert report.levels_used == 1  # the ridge covers 3 mm², under a fingertip's 6 mm²


# --- tactile/braille.py: cells, dot positions against the standard's numbers, refusals -----------

def test_dots_of_a_cell_and_their_places():
    from tamp_os.tactile.braille import DOT_POSITION, cell_dots

    assert cell_dots("⠀") == [] and cell_dots("⠁") == [1] and cell_dots("⠿") == [1, 2, 3, 4, 5, 6]
    assert cell_dots("⣿") == list(range(1, 9)) and cell_dots("⢀") == [8] and cell_dots("⡀") == [7]
    assert cell_dots("⠚") == [2, 4, 5]  # j
    # Braille's own numbering: 1-2-3 down the left column, 4-5-6 down the right, 7 and 8 below.
    assert DOT_POSITION == {1: (0, 0), 2: (0, 1), 3: (0, 2), 4: (1, 0), 5: (1, 1), 6: (1, 2), 7: (0, 3), 8: (1, 3)}


def test_dot_centres_follow_the_spacing_of_the_standard():
    from tamp_os.tactile.braille import BrailleSpec, dot_centres

    spec = BrailleSpec(dot_diameter_mm=1.4, dot_spacing_mm=2.4, cell_spacing_mm=6.2, line_spacing_mm=10.5)
    r = 0.7
    centres = dot_centres(["⣿⠁", "⠈"], spec, 3.0, 50.0)
    first = [(3.0 + r + col * 2.4, 50.0 - r - row * 2.4) for col, row in
             ((0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (0, 3), (1, 3))]
    expected = first + [(3.0 + r + 6.2, 50.0 - r)] + [(3.0 + r + 2.4, 50.0 - r - 10.5)]
    assert np.allclose(np.array(centres), np.array(expected), atol=1e-12, rtol=0)
    assert dot_centres([], spec, 0.0, 0.0) == [] and dot_centres(["⠀⠀"], spec, 0.0, 0.0) == []


def test_block_size_of_one_cell_and_of_lines():
    from tamp_os.tactile.braille import BrailleSpec, block_size_mm

    spec = BrailleSpec()  # 1.5 mm dots 2.5 mm apart, cells 6 mm, lines 10 mm
    assert block_size_mm(["⠿"], spec) == pytest.approx((2.5 + 1.5, spec.cell_height_mm))
    assert block_size_mm(["⠿⠿⠿", "⠿"], spec) == pytest.approx((2 * 6.0 + 2.5 + 1.5, 10.0 + spec.cell_height_mm))
    assert block_size_mm(["⠿", "⣿"], spec)[1] == pytest.approx(10.0 + spec.cell_height_mm + 2.5)  # dots 7, 8 below
    assert block_size_mm(["⣿", "⠿"], spec)[1] == pytest.approx(10.0 + spec.cell_height_mm)  # only the last line's count
    assert block_size_mm(["⡀"], spec)[1] == pytest.approx(spec.cell_height_mm + 2.5)
    assert block_size_mm(["⢀"], spec)[1] == pytest.approx(spec.cell_height_mm + 2.5)
    assert block_size_mm(["⠀⠿ "], spec)[0] == pytest.approx(2 * 6.0 + 4.0)


def test_what_counts_as_unicode_braille():
    from tamp_os.tactile.braille import is_unicode_braille

    assert is_unicode_braille("⠁⠃ ⠉\n⠙") and is_unicode_braille("⠀") and is_unicode_braille("⣿")
    assert not is_unicode_braille("") and not is_unicode_braille("⠁a") and not is_unicode_braille("⠁\t")
    assert not is_unicode_braille("\u27ff") and not is_unicode_braille("\u2900")


def test_characters_no_braille_table_can_write():
    from tamp_os.tactile.braille import unwritable_characters

    assert unwritable_characters("two\nlines") == []
    assert unwritable_characters("a\tb\x00c\u200b\ue000\U000e0080\ud800\t") == sorted(
        {"\t", "\x00", "\u200b", "\ue000", "\U000e0080", "\ud800"})


def test_control_characters_are_refused_by_name_and_parameter():
    from tamp_os.errors import ParameterError
    from tamp_os.tactile.braille import to_braille

    with pytest.raises(ParameterError) as caught:
        to_braille("a\tb\u200b", what="caption")
    assert str(caught.value) == ("caption: control characters cannot be written in braille: U+0009 unnamed, "
                                 "U+200B ZERO WIDTH SPACE; remove them.")


def test_unicode_braille_passes_through_with_blank_cells():
    from tamp_os.tactile.braille import BLANK, Liblouis, to_braille

    never = Liblouis(binding=None, command=None)  # a translator would fail: it is not asked
    assert to_braille("⠁⠃ ⠉", translator=never) == f"⠁⠃{BLANK}⠉"
    assert BLANK == "\u2800"


class _Table:
    """A stand-in liblouis binding: letters a-c to cells, anything else to an escape."""

    dotsIO, ucBrl = 4, 8
    cells = {"a": "⠁", "b": "⠃", "c": "⠉", "q": "⠟", " ": " "}

    @classmethod
    def translateString(cls, tables, text, mode=0):
        assert tables == ["t.ctb"] and mode == cls.dotsIO | cls.ucBrl
        if text == "qq":  # a pair the table cannot write, though each letter alone it can
            return "\u2804\u2873\u282d"
        return "".join(cls.cells.get(ch, "\u2804\u2873\u282d") for ch in text)


def test_a_character_the_table_lacks_is_refused_by_name(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille

    monkeypatch.setattr(braille, "check_table_name", lambda table: None)
    louis = braille.Liblouis(binding=_Table, command=None)
    assert braille.to_braille("ab c", "t.ctb", translator=louis) == "⠁⠃⠀⠉"
    with pytest.raises(ParameterError) as caught:
        braille.to_braille("a€b ☃", "t.ctb", translator=louis, what="caption")
    assert str(caught.value) == (
        "caption: the braille table t.ctb cannot write U+20AC EURO SIGN (€), U+2603 SNOWMAN (☃) (liblouis would "
        "emboss escape codes); remove them, choose another braille_table, or give the text as Unicode braille.")


def test_escape_cells_are_dots_seven_and_eight_or_the_escape_sequence():
    from tamp_os.tactile.braille import _has_escape

    assert not _has_escape("⠁⠿⠀") and not _has_escape("")
    assert _has_escape("⡀") and _has_escape("⢀") and _has_escape("⣿")
    assert _has_escape("⠁\u2804\u2873\u282d⠁") and not _has_escape("\u2804\u282d")


def test_an_unknown_table_is_refused_before_liblouis_is_asked(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille, braille_tables

    monkeypatch.setattr(braille_tables, "table_exists", lambda table: False)
    monkeypatch.setattr(braille_tables, "closest_tables", lambda table: [])
    with pytest.raises(ParameterError) as caught:
        braille.check_table_name("nope.ctb")
    assert str(caught.value) == ("braille_table: liblouis has no table called 'nope.ctb'. "
                                 "Give a table's file name, such as en-ueb-g2.ctb.")
    monkeypatch.setattr(braille_tables, "table_exists", lambda table: None)  # cannot tell: liblouis decides
    braille.check_table_name("nope.ctb")


def test_an_unknown_table_names_the_closest(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille, braille_tables

    class Close:
        def __init__(self, name):
            self.name = name

        def line(self):
            return self.name

    monkeypatch.setattr(braille_tables, "table_exists", lambda table: False)
    monkeypatch.setattr(braille_tables, "closest_tables",
                        lambda table: [Close("en-ueb-g1.ctb"), Close("en-ueb-g2.ctb")] if table == "en-ueb.ctb" else [])
    with pytest.raises(ParameterError, match=r"The closest are: en-ueb-g1\.ctb; en-ueb-g2\.ctb\. Give"):
        braille.check_table_name("en-ueb.ctb")


def test_the_system_translator_is_found_once():
    from tamp_os.tactile.braille import Liblouis, liblouis_available

    assert Liblouis.system() is Liblouis.system()
    assert liblouis_available() == Liblouis.system().available
    assert Liblouis(binding=_Table).available and Liblouis(command="/bin/true").available


def test_the_command_output_is_read_as_braille_ascii(tmp_path):
    from tamp_os.tactile.braille import Liblouis

    def fake(output: str):
        script = tmp_path / "lou"
        script.write_text(f"#!/bin/sh\ncat > /dev/null\nprintf '{output}'\n")
        script.chmod(0o755)
        return Liblouis(binding=None, command=str(script))

    assert fake("ABC\\n\\n").translate("x", "t") == "⠁⠃⠉"
    assert fake("a b").translate("x", "t") == "⠁\u2800⠃"  # Braille ASCII is case-free; its space is the blank cell
    assert fake("#A").translate("x", "t") == "⠼⠁"
    assert fake("A\\\\X4E2D/").translate("x", "t") == "\u2873"
    assert fake("A\\\\y1f600/").translate("x", "t") == "\u2873"
    assert fake("A\\\\Z").translate("x", "t") == "⠁⠳⠵"


# --- mesh/validate.py ------------------------------------------------------------------------------

def test_a_face_of_exactly_the_smallest_area_is_a_sliver_and_a_larger_one_is_not():
    from tamp_os.mesh.validate import _small_faces_and_volume

    right = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 2.0, 0]])  # area exactly 1 mm²
    faces = np.array([[0, 1, 2]])
    assert _small_faces_and_volume(right, faces, 1.0)[0] == 1  # "at most" the smallest area
    assert _small_faces_and_volume(right, faces, 0.999)[0] == 0
    assert _small_faces_and_volume(right, faces, 0.7)[0] == 0  # 1.43 times the limit is a real face


def test_an_empty_mesh_has_no_bounds_and_no_volume():
    from tamp_os.mesh.solid import Mesh
    from tamp_os.mesh.validate import check_solid

    check = check_solid(Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64)))
    assert check.bounds_mm == [[], []] and check.volume_mm3 == 0.0 and not check.outward and not check.ok


def test_faces_that_collapse_once_written_are_left_out_of_the_edge_count():
    from tamp_os.mesh.solid import Mesh
    from tamp_os.mesh.validate import check_as_written

    # A unit cube at 100 mm whose bottom half [0, 2, 1] comes with two more faces through a point
    # 1e-6 mm from corner 0: one position in float32, so [0, 2, 8] and [0, 8, 1] collapse and
    # [8, 2, 1] closes the bottom; the collapsed faces' self-edges must not count as pinches.
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float) + 100.0
    v = np.vstack([v, v[0] + [1e-6, 1e-6, 0]])
    faces = np.array([[0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6],
                      [3, 0, 4], [3, 4, 7], [0, 2, 8], [8, 2, 1], [0, 8, 1]])
    check = check_as_written(Mesh(v, faces))
    assert check.closed and check.manifold and check.degenerate_faces == 2
    assert check.problems == ["2 faces have an area of at most 1e-08 mm² (slivers)"]


def test_a_combination_the_table_cannot_write_is_refused_without_a_name(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille

    monkeypatch.setattr(braille, "check_table_name", lambda table: None)
    with pytest.raises(ParameterError, match="the braille table t.ctb cannot write some characters \\(liblouis"):
        braille.to_braille("qq", "t.ctb", translator=braille.Liblouis(binding=_Table), what="caption")


def test_refusals_name_text_by_default_and_the_install_hint():
    from tamp_os.errors import MissingDependencyError, ParameterError
    from tamp_os.tactile.braille import INSTALL_HINT, Liblouis, is_unicode_braille, to_braille

    with pytest.raises(ParameterError, match="^text: control characters"):
        to_braille("a\tb")
    with pytest.raises(MissingDependencyError) as caught:
        Liblouis(binding=None, command=None).translate("a", "t.ctb")
    assert INSTALL_HINT in str(caught.value) and "liblouis-bin" in INSTALL_HINT
    assert not is_unicode_braille("⠁X") and not is_unicode_braille("X")


def test_the_command_output_keeps_trailing_blanks_and_survives_bad_bytes(tmp_path):
    from tamp_os.tactile.braille import Liblouis

    script = tmp_path / "lou"
    script.write_text("#!/bin/sh\ncat > /dev/null\nprintf 'A  \\n'\n")
    script.chmod(0o755)
    assert Liblouis(command=str(script)).translate("a  ", "t") == "⠁\u2800\u2800"  # the spaces are cells
    script.write_text("#!/bin/sh\ncat > /dev/null\nprintf 'A\\377B\\177\\n'\n")  # not UTF-8, and a DEL
    assert Liblouis(command=str(script)).translate("ab", "t") == "⠁⠃⠸"  # bad bytes dropped; DEL folds onto '_'


def test_the_binding_is_found_in_debians_dist_packages(monkeypatch):
    import sys
    from pathlib import Path

    from tamp_os.tactile.braille import _load_binding

    need(Path("/usr/lib/python3/dist-packages/louis/__init__.py").is_file() or
         Path("/usr/local/lib/python3/dist-packages/louis/__init__.py").is_file(), "python3-louis (apt-get install python3-louis)")
    monkeypatch.setitem(sys.modules, "louis", None)  # `import louis` fails, as in a virtual environment
    louis = _load_binding()
    assert louis is not None and "dist-packages" in louis.__file__
    assert louis.translateString(["en-ueb-g1.ctb"], "abc", mode=louis.dotsIO | louis.ucBrl) == "⠁⠃⠉"
