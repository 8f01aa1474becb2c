"""PrusaSlicer system printer presets: inheritance, listing, and G-code for a real printer."""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import need, examples
from tamp_os.printing import prusa_presets as pp
from tamp_os.errors import ParameterError

MINI = "Original Prusa MINI & MINI+"
MK3S = "Original Prusa i3 MK3S & MK3S+"
BUNDLE = """[vendor]
name = Test Vendor

[printer:*common*]
printer_technology = FFF
bed_shape = 0x0,200x0,200x200,0x200
gcode_flavor = marlin
nozzle_diameter = 0.4
default_print_profile = 0.20mm TEST

[printer:*big*]
bed_shape = 0x0,300x0,300x250,0x250
max_print_height = 300

[printer:Tester Big]
inherits = *common*; *big*
gcode_flavor = klipper

[printer:Tester Small 0.6]
inherits = *common*
nozzle_diameter = 0.6,0.6

[printer:Tester Resin]
printer_technology = SLA
bed_shape = 0x0,68x0,68x120,0x120

[print:*p*]
layer_height = 0.3

[print:0.20mm TEST]
inherits = *p*
layer_height = 0.2

[filament:Generic PETG]
filament_type = PETG
temperature = 235
"""


@pytest.fixture
def test_bundle(tmp_path, monkeypatch):
    (tmp_path / "TestVendor.ini").write_text(BUNDLE, encoding="utf-8")
    monkeypatch.setenv("TAMP_PRUSA_PROFILES", str(tmp_path))
    pp.system_printers.cache_clear()
    yield tmp_path
    pp.system_printers.cache_clear()


@pytest.mark.timeout(30)
def test_inheritance_later_parents_and_own_values_win(test_bundle):
    sections = pp.read_bundle(test_bundle / "TestVendor.ini")
    big = pp.resolve(sections, "printer", "Tester Big")
    assert big["bed_shape"] == "0x0,300x0,300x250,0x250"  # the second parent overrides the first
    assert big["gcode_flavor"] == "klipper" and big["max_print_height"] == "300" and big["nozzle_diameter"] == "0.4"
    printers = {p.name: p for p in pp.system_printers()}
    assert set(printers) == {"Tester Big", "Tester Small 0.6"}  # abstract and SLA presets are not printers
    assert printers["Tester Big"].bed_mm == (300, 250) and printers["Tester Small 0.6"].nozzle_mm == 0.6
    config = pp.preset_config("tester big", "PETG")  # names match case-insensitively
    assert config.layer_mm == 0.2 and config.filament_preset == "Generic PETG" and config.options["temperature"] == "235"
    assert not pp.NOT_OPTIONS & set(config.options)
    with pytest.raises(ParameterError, match="Did you mean 'Tester Big'"):
        pp.find_system_printer("Tester Bigg")


@pytest.mark.timeout(30)
@settings(max_examples=examples(50), deadline=None)
@given(x0=st.integers(-50, 50), y0=st.integers(-50, 50), w=st.integers(1, 1000), d=st.integers(1, 1000))
def test_bed_size_from_bed_shape(x0, y0, w, d):
    shape = f"{x0}x{y0},{x0 + w}x{y0},{x0 + w}x{y0 + d},{x0}x{y0 + d}"
    assert pp.bed_size_mm(shape) == (w, d)


def _debian_bundles():
    need(Path("/usr/share/PrusaSlicer/profiles/PrusaResearch.ini").is_file(), "PrusaSlicer's vendor bundles (apt-get install prusa-slicer)")


@pytest.mark.timeout(60)
def test_system_printer_becomes_a_printer_profile():
    _debian_bundles()
    from tamp_os.printing.printers import get_printer

    mini = get_printer(MINI)
    assert mini.prusa_preset == MINI and mini.nozzle_mm == 0.4 and 0 < mini.layer_mm <= 0.3
    assert mini.width_mm <= 180 - 20  # the default print fits the MINI's 180 mm bed with a margin
    mk3 = {p.name: p for p in pp.system_printers()}[MK3S]
    assert mk3.bed_mm == (250, 210) and mk3.gcode_flavor == "marlin"
    with pytest.raises(ParameterError, match="printers command"):
        get_printer("No Such Printer 3000")


@pytest.fixture(scope="module")
def small_mesh(tmp_path_factory):
    from tamp_os import make_lithograph

    y, x = np.mgrid[0:30, 0:40]
    litho = make_lithograph(np.sin(x / 5) * np.cos(y / 7), width_mm=40, preset="low", mesher="adaptive")
    return litho.save(tmp_path_factory.mktemp("presets") / "small.stl")[0]


def _header(text: str, key: str) -> str:
    return re.search(rf"^; {key} = (.*)$", text, re.M).group(1)


@pytest.mark.timeout(180)
def test_gcode_from_a_system_preset_has_its_bed_firmware_and_temperatures(small_mesh):
    _debian_bundles()
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")
    from tamp_os.printing.printers import get_printer
    from tamp_os.printing.slicer import material, slice_mesh

    result = slice_mesh(small_mesh, get_printer(MINI), material("PLA"), timeout_s=150)
    text = Path(result.gcode).read_text(encoding="utf-8")
    expected = pp.preset_config(MINI, "PLA").options
    assert pp.bed_size_mm(_header(text, "bed_shape")) == (180, 180)
    assert _header(text, "gcode_flavor") == expected["gcode_flavor"] == "marlin2"
    assert _header(text, "temperature") == expected["temperature"] and _header(text, "bed_temperature") == expected["bed_temperature"]
    assert _header(text, "printer_settings_id") == MINI
    assert "M862.3" in text  # the MINI's own start G-code (printer model check) is in the file
    moves = np.array([(float(x), float(y)) for x, y in re.findall(r"^G1 X([-0-9.]+) Y([-0-9.]+) E", text, re.M)])
    assert moves[:, 0].min() >= 0 and moves[:, 0].max() <= 180 and moves[:, 1].min() >= 0 and moves[:, 1].max() <= 180
    assert not result.for_estimates_only and "estimates" not in result.sentence() and MINI in result.sentence()
    assert "for estimates only" not in text.splitlines()[0]


@pytest.mark.timeout(180)
def test_generic_gcode_says_it_is_for_estimates_only(small_mesh):
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")
    from tamp_os.printing.printers import get_printer
    from tamp_os.printing.slicer import material, slice_mesh

    result = slice_mesh(small_mesh, get_printer("standard"), material("PLA"), timeout_s=150)
    first = Path(result.gcode).read_text(encoding="utf-8").splitlines()[0]
    assert first.startswith(";") and "estimates only, not for sending to a printer" in first
    assert result.for_estimates_only and "not for sending to a printer" in result.sentence()


@pytest.mark.timeout(60)
def test_nozzle_that_contradicts_the_preset_is_refused(small_mesh):
    _debian_bundles()
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")
    from tamp_os.printing.printers import get_printer
    from tamp_os.printing.slicer import material, slice_mesh

    with pytest.raises(ParameterError, match=r"nozzle_mm.*0\.4 mm nozzle; got 0\.6"):
        slice_mesh(small_mesh, get_printer(MK3S), material("PLA"), nozzle_mm=0.6)


@pytest.mark.timeout(60)
def test_printers_command_lists_profiles_and_system_printers(capsys):
    _debian_bundles()
    from tamp_os.cli.commands import main

    assert main(["printers", "--vendor", "PrusaResearch"]) == 0
    out = capsys.readouterr().out
    assert "standard: nozzle 0.4 mm" in out and "estimates only" in out
    assert f"{MK3S} (PrusaResearch): bed 250 × 210 mm, nozzle 0.4 mm, marlin" in out
    assert "Creality" not in out
