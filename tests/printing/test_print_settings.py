"""Issue 24.1/24.2: the 3MF carries its print settings, and today's printers are known.

PrusaSlicer (the real one, Debian's 2.5) slices our 3MF files with no --load and must use the
layer height the relief was designed for; Bambu Studio / OrcaSlicer's project settings are
checked on the written bytes against the layout their ConfigBase::save_to_json writes.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import need, run_cli, examples
from tamp_os.errors import ParameterError
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.printing.printer_table import NOT_CHECKED, PRINTERS, find_printer, printers_of
from tamp_os.printing.printers import get_printer


def _image():
    img = np.zeros((40, 60))
    img[8:30, 10:28] = 1.0  # one raised block, left of centre
    return img


def _write(tmp_path, name, **changes):
    litho = make_lithograph(_image(), width_mm=50, formats=("3mf",), **changes)
    paths = litho.save(tmp_path / name, stem="p")
    return litho, next(p for p in paths if p.suffix == ".3mf")


def _slice_without_load(path: Path) -> str:
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")
    gcode = path.with_suffix(".gcode")
    done = subprocess.run(["prusa-slicer", "--export-gcode", "--output", str(gcode), str(path)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return gcode.read_text(encoding="utf-8", errors="replace")


def _layer_steps_mm(gcode: str) -> tuple[float, float]:
    """(first layer top, median step between layers) measured from the ;Z: markers PrusaSlicer writes."""
    zs = [float(z) for z in re.findall(r"^;Z:([0-9.]+)", gcode, re.M)]
    return zs[0], float(np.median(np.diff(zs)))


@pytest.mark.timeout(300)
@pytest.mark.parametrize("multicolour", [False, True], ids=["one-colour", "two-colour"])
def test_prusaslicer_slices_the_3mf_at_its_layer_height_without_load(tmp_path, multicolour):
    litho, path = _write(tmp_path, "m", printer="mk4", multicolour=multicolour)
    gcode = _slice_without_load(path)
    assert re.search(r"^; layer_height = 0\.12$", gcode, re.M)
    assert re.search(r"^; support_material = 0$", gcode, re.M)
    assert re.search(r"^; perimeters = 2$", gcode, re.M)
    assert re.search(r"^; fill_density = 15%$", gcode, re.M)
    # every key we write is one PrusaSlicer read: its value comes back in the G-code's settings
    for key, value in (("fill_pattern", "gyroid"), ("top_solid_layers", "3"), ("bottom_solid_layers", "3"),
                       ("first_layer_height", "0.2"), ("nozzle_diameter", "0.4")):
        assert re.search(rf"^; {key} = {re.escape(value)}$", gcode, re.M), key
    # The MK4's bed from the printer table (PrusaSlicer 2.5 has no MK4 preset to take it from).
    assert re.search(r"^; bed_shape = 0x0,250x0,250x210,0x210$", gcode, re.M)
    first, step = _layer_steps_mm(gcode)
    assert first == pytest.approx(0.2) and step == pytest.approx(0.12, abs=1e-6)
    top = float(litho.mesh.vertices[:, 2].max())
    layers = len(re.findall(r"^;Z:", gcode, re.M))
    assert abs(layers - (1 + (top - 0.2) / 0.12)) <= 1.5  # the whole height, in 0.12 mm layers


@pytest.mark.timeout(300)
def test_3mf_for_an_installed_preset_carries_that_printer(tmp_path):
    need(Path("/usr/share/PrusaSlicer/profiles/PrusaResearch.ini").is_file(), "PrusaSlicer's vendor bundles")
    _, path = _write(tmp_path, "mini", printer="mini")
    gcode = _slice_without_load(path)
    assert re.search(r"^; printer_settings_id = Original Prusa MINI & MINI\+$", gcode, re.M)
    assert re.search(r"^; bed_shape = 0x0,180x0,180x180,0x180$", gcode, re.M)
    assert re.search(r"^; layer_height = 0\.12$", gcode, re.M)
    assert "M862.3 P \"MINI\"" in gcode  # the MINI's own start G-code, not PrusaSlicer's default


@pytest.mark.timeout(120)
@pytest.mark.parametrize("multicolour", [False, True], ids=["one-colour", "two-colour"])
def test_bambu_orca_project_settings_layout_on_the_written_bytes(tmp_path, multicolour):
    _, path = _write(tmp_path, "a1", printer="a1", multicolour=multicolour)
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        data = json.loads(z.read("Metadata/project_settings.config").decode("utf-8"))
        types = z.read("[Content_Types].xml").decode("utf-8")
        model = z.read("3D/3dmodel.model").decode("utf-8")
    # save_to_json's header, and every value text or a list of text
    assert (data["name"], data["from"]) == ("project_settings", "project") and isinstance(data["version"], str)
    assert all(isinstance(v, str) or (isinstance(v, list) and all(isinstance(x, str) for x in v)) for v in data.values())
    assert data["layer_height"] == "0.12" and data["initial_layer_print_height"] == "0.2"
    assert (data["wall_loops"], data["sparse_infill_density"], data["enable_support"]) == ("2", "15%", "0")
    assert data["nozzle_diameter"] == ["0.4"]
    assert data["printable_area"] == ["0x0", "256x0", "256x256", "0x256"]  # the A1's 256 mm bed
    assert data["printer_model"] == "Bambu Lab A1"
    # Found by name: no model relationships (Bambu/Orca would look for model parts in them), a content type for .config.
    assert "3D/_rels/3dmodel.model.rels" not in names and "Metadata/Slic3r_PE.config" in names
    assert 'Extension="config"' in types
    # The one-colour file goes through Bambu/Orca's own importer (no "PrusaSlicer" in Application);
    # the two-colour one keeps PrusaSlicer's layout so that its two volumes survive there.
    application = re.search(r'<metadata name="Application"[^>]*>([^<]*)</metadata>', model).group(1)
    assert ("PrusaSlicer" in application) == multicolour


@pytest.mark.timeout(120)
def test_3mf_with_settings_is_byte_reproducible(tmp_path):
    digests = {hashlib.sha256(_write(tmp_path, f"r{i}", printer="a1 mini")[1].read_bytes()).hexdigest() for i in range(2)}
    assert len(digests) == 1


@pytest.mark.timeout(60)
def test_prusa_config_lines_parse_back_to_the_settings(tmp_path):
    litho, path = _write(tmp_path, "x", printer="x1c", layer_mm=0.16)
    text = zipfile.ZipFile(path).read("Metadata/Slic3r_PE.config").decode("utf-8")
    pairs = dict(re.findall(r"^; (\w+) = (.*)$", text, re.M))
    assert pairs["layer_height"] == "0.16" and pairs["nozzle_diameter"] == "0.4"
    assert pairs["bed_shape"] == "0x0,256x0,256x256,0x256"
    assert litho.printer.layer_mm == pytest.approx(0.16)


# --- today's printers ---------------------------------------------------------------------------

def test_every_printer_has_a_sane_bed_nozzle_and_layer_range():
    for p in PRINTERS:
        assert all(100 <= v <= 500 for v in p.bed_mm) and p.nozzle_mm == 0.4, p
        # a range a 0.4 mm nozzle can print: thinner than the nozzle, and one that holds the 0.12 mm design layer
        assert len(p.layers_mm) == 2 and 0.05 <= p.layers_mm[0] < 0.12 < p.layers_mm[1] < p.nozzle_mm, p
    asked = {"mk4", "mk4s", "mk3.9", "core one", "mini", "xl", "a1", "a1 mini", "p1s", "x1c"}
    assert all(find_printer(n) is not None for n in asked)
    assert len({find_printer(n).model for n in asked}) == len(asked)


# A source names a repository file (owner/name then a path) or a URL, or says the row was not checked.
_WHERE = re.compile(r"(https://\S+|github\.com/[\w.-]+/[\w.-]+ \S+|/usr/share/PrusaSlicer/profiles/\S+)")


def test_every_row_names_where_its_facts_were_checked():
    for p in PRINTERS:
        assert p.source.strip(), p
        assert p.source == NOT_CHECKED or _WHERE.search(p.source), p.source
        if p.source != NOT_CHECKED:
            # the numbers the row states can be found in its source
            w, d, h = (f"{v:g}" for v in p.bed_mm)
            assert h in p.source and (f"{w}x{d}" in p.source or w in p.source and d in p.source), p
            assert all(f"{v:g}" in p.source for v in p.layers_mm), p


def test_every_bed_is_one_the_sizing_and_tiling_code_accepts():
    from tamp_os.printing.printers import _bed
    from tamp_os.tactile.tiles import plan_grid
    from tamp_os.units import parse_bed_mm

    for p in PRINTERS:
        w, d, _ = p.bed_mm
        assert parse_bed_mm(f"{w:g}x{d:g}") == (w, d) and _bed([w, d]) == (w, d)
        profile = get_printer(p.model)
        assert profile.bed_mm == (w, d) and 0 < profile.width_mm <= min(w, d) - 20
        assert plan_grid((w / 2, d / 2), (w, d))[:2] == (1, 1)  # a plate inside the bed: one tile
        rows, cols, _ = plan_grid((2.5 * w, 2.5 * d), (w, d))
        assert rows >= 3 and cols >= 3  # a plate 2.5 beds across: at least three tiles each way


def test_rows_agree_with_the_installed_prusaslicer_bundles():
    """Where Debian's PrusaSlicer bundle has the printer, its own preset says the same bed, height and layers."""
    from tamp_os.printing.printer_table import installed_preset
    from tamp_os.printing.prusa_presets import find_system_printer, read_bundle, resolve

    checked = 0
    for p in PRINTERS:
        preset = installed_preset(p)
        if preset is None:
            continue
        system = find_system_printer(preset)
        options = resolve(read_bundle(system.bundle), "printer", system.name)
        assert system.bed_mm == p.bed_mm[:2] and float(options["max_print_height"]) == p.bed_mm[2], p
        assert (float(options["min_layer_height"].split(",")[0]), float(options["max_layer_height"].split(",")[0])) == p.layers_mm
        assert system.nozzle_mm == p.nozzle_mm
        checked += 1
    need(checked > 0, "PrusaSlicer's vendor bundles (apt-get install prusa-slicer)")


@settings(max_examples=examples(60), deadline=None)
@given(name=st.sampled_from(["mk4", "a1 mini", "Bambu Lab A1", "Original Prusa MK4S", "core one", "x1c"]),
       flips=st.lists(st.booleans(), min_size=20, max_size=20), dash=st.booleans())
def test_names_match_in_any_case_and_spacing(name, flips, dash):
    typed = "".join(c.upper() if f else c.lower() for c, f in zip(name, flips + [False] * len(name)))
    typed = typed.replace(" ", "-") if dash else typed
    assert find_printer(typed) is find_printer(name) is not None


def test_short_names_give_the_printer_its_bed_and_a_fitting_width():
    mini = get_printer("A1 Mini")
    assert mini.name == "Bambu Lab A1 mini" and mini.bed_mm == (180.0, 180.0) and mini.layer_mm == pytest.approx(0.12)
    assert mini.width_mm <= 180 - 20
    assert get_printer("mk4").bed_mm == (250.0, 210.0)
    with pytest.raises(ParameterError, match="Did you mean 'Original Prusa MK4'"):
        get_printer("mk5")


@pytest.mark.timeout(300)
def test_a_plate_larger_than_the_printers_bed_comes_in_tiles():
    litho = make_lithograph(_image(), width_mm=240, printer="a1 mini")
    assert litho.tiles is not None and litho.tiles.bed_mm == (180.0, 180.0)
    for tile in litho.tiles.tiles:
        w, d = np.ptp(tile.mesh.vertices[:, :2], axis=0)
        assert w <= 180 + 1e-6 and d <= 180 + 1e-6  # a square bed: either way round


def test_printers_vendor_prusa_lists_todays_prusa_printers(capsys):
    code, out, _ = run_cli(capsys, "printers", "--vendor", "prusa")
    assert code == 0
    for model in ("Original Prusa MK4S", "Original Prusa MK4", "Original Prusa MK3.9", "Prusa CORE One", "Original Prusa MINI+", "Original Prusa XL"):
        assert model in out
    assert "Bambu Lab A1" not in out
    assert {p.vendor for p in printers_of("BAMBU")} == {"Bambu Lab"}


@pytest.mark.timeout(300)
def test_slicing_for_a_printer_without_an_installed_preset_says_so_in_one_sentence(tmp_path):
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")
    from tamp_os.printing.slicer import material, slice_mesh

    litho = make_lithograph(_image(), width_mm=30, formats=("stl",))
    stl = next(p for p in litho.save(tmp_path, stem="s") if p.suffix == ".stl")
    result = slice_mesh(stl, get_printer("a1"), material("PLA"), timeout_s=240)
    assert result.for_estimates_only
    assert "no PrusaSlicer preset for the Bambu Lab A1 here" in result.sentence() and "print from the 3MF" in result.sentence()
    assert Path(result.gcode).read_text(encoding="utf-8").startswith("; TAMP-OS: no PrusaSlicer preset for the Bambu Lab A1")
