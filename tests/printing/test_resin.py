"""Resin printers (issue 38): their table rows and sources, presets from their XY resolution and layer,
PrusaSlicer's SLA export for the SL1S read back from its archive, materials and their footprint, and one
clear error for each thing a resin printer cannot do."""

from __future__ import annotations

import math
import re
import shutil
import zipfile

import numpy as np
import pytest

from conftest import FIXTURES, need, run_cli

from tamp_os.errors import ParameterError
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.params import LithoParams
from tamp_os.printing.printer_table import (ALL_PRINTERS, NOT_CHECKED, PRINTERS, RESIN_PRINTERS, TOUCH_FEATURE_MM,
                                            feature_mm, find_printer, sla_preset)
from tamp_os.printing.printers import PRESETS, PrinterProfile, get_printer, preset_resolution_px
from tamp_os.printing.slicer import MATERIALS, SlicerError, estimate, material, material_for, read_sla_archive

FEPT = FIXTURES / "fept_spheres_sem.png"
SL1S = "Original Prusa SL1S SPEED"


@pytest.fixture
def slicer_present():
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")


# --- the table ------------------------------------------------------------------------------------

def test_the_issue_s_resin_printers_are_in_the_table_by_their_short_names():
    for name in ("form 4", "form 3+", "sl1s", "saturn 4 ultra", "mars 5", "photon mono m7"):
        model = find_printer(name)
        assert model is not None and model.is_resin and model in RESIN_PRINTERS, name
    assert not any(p.is_resin for p in PRINTERS) and set(ALL_PRINTERS) == set(PRINTERS) | set(RESIN_PRINTERS)


def test_every_resin_row_is_sane_and_names_its_source():
    for p in RESIN_PRINTERS:
        assert p.technology in ("MSLA", "SLA") and 0.01 <= p.xy_mm <= 0.1, p
        assert all(50 <= v <= 300 for v in p.bed_mm), p
        low, high = p.layers_mm
        assert 0.005 <= low <= 0.05 <= high <= 0.3, p  # every one makes the usual 0.05 mm resin layer
        assert re.search(r"https://\S+", p.source), p.source  # the vendor's page, checked or not
        w, d, h = (f"{v:g}" for v in p.bed_mm)
        assert w in p.source and d in p.source and h in p.source, p
        if NOT_CHECKED not in p.source:
            assert "/usr/share/PrusaSlicer/profiles/" in p.source and all(f"{v:g}" in p.source for v in p.layers_mm), p


def test_the_sl1s_row_agrees_with_prusaslicer_s_own_bundle():
    from tamp_os.printing.prusa_presets import bed_size_mm, read_bundle, resolve, sla_layers_mm, sla_printers

    need(SL1S.lower() in sla_printers(), "PrusaSlicer's vendor bundles (apt-get install prusa-slicer)")
    model = find_printer("sl1s")
    name, bundle = sla_printers()[SL1S.lower()]
    options = resolve(read_bundle(bundle), "printer", name)
    assert bed_size_mm(options["bed_shape"]) == model.bed_mm[:2] and float(options["max_print_height"]) == model.bed_mm[2]
    assert float(options["display_width"]) / float(options["display_pixels_x"]) == pytest.approx(model.xy_mm)
    layers = sla_layers_mm(name)
    assert (min(layers), max(layers)) == model.layers_mm and sla_preset(model) == name


# --- presets --------------------------------------------------------------------------------------

def test_presets_follow_each_technology_s_feature_and_stop_where_touch_does():
    """Medium puts a grid point every feature width: a nozzle, or 4 resin pixels but never under the touch
    bound, so that High (half a feature) never goes finer than half that bound."""
    width_mm = 100.0
    for model in ALL_PRINTERS:
        profile = get_printer(model.model)
        expected = model.nozzle_mm if not model.is_resin else max(4 * model.xy_mm, TOUCH_FEATURE_MM)
        assert profile.nozzle_mm == pytest.approx(expected, abs=1e-4) == feature_mm(model), model
        pitch = {p: width_mm / preset_resolution_px(p, profile.nozzle_mm, width_mm) for p in PRESETS}
        assert pitch["low"] == pytest.approx(2 * pitch["medium"], rel=0.01) and pitch["high"] == pytest.approx(pitch["medium"] / 2, rel=0.01)
        assert pitch["high"] >= TOUCH_FEATURE_MM / 2 - 1e-3, model
        if model.is_resin:  # never coarser than a nozzle printer's grid
            assert pitch["medium"] <= 0.4 + 1e-6 and profile.is_resin
            assert model.layers_mm[0] <= profile.layer_mm <= model.layers_mm[1]


def test_fept_at_medium_on_the_sl1s_follows_the_rule(fixture_fept):
    litho = make_lithograph(FEPT, printer="sl1s", preset="medium")
    model, report = find_printer("sl1s"), litho.report
    feature = max(4 * model.xy_mm, TOUCH_FEATURE_MM)
    assert report.mm_per_px == pytest.approx(feature, rel=0.02)  # one grid point per feature width
    assert report.grid[0] == round(report.relief_mm[0] / feature)
    layer = litho.printer.layer_mm
    assert model.layers_mm[0] <= layer <= model.layers_mm[1]
    assert report.height_levels == math.floor(litho.params.relief_mm / layer + 1e-9)
    nozzle = make_lithograph(FEPT, printer="mk4", preset="medium").report
    assert report.height_levels > nozzle.height_levels and report.mm_per_px < nozzle.mm_per_px
    # the furniture keeps its tactile sizes on resin: the same braille cells, dots of the same size
    assert report.tactile.braille_dots == nozzle.tactile.braille_dots
    assert litho.params.braille_spec() == LithoParams().braille_spec()


@pytest.fixture
def fixture_fept():
    need(FEPT.is_file(), "fixture fept_spheres_sem.png")


# --- slicing with PrusaSlicer's SLA export --------------------------------------------------------

@pytest.mark.slow
@pytest.mark.timeout(300)
def test_fept_sliced_for_the_sl1s_reports_what_the_archive_says(tmp_path, slicer_present, fixture_fept):
    import trimesh

    litho = make_lithograph(FEPT, printer="sl1s", preset="medium", gcode=True)
    written, litho = litho.save_sliced(tmp_path)
    archive = tmp_path / "fept_spheres_sem.sl1s"
    assert archive in written and zipfile.is_zipfile(archive)
    with zipfile.ZipFile(archive) as z:
        config = dict(line.split(" = ", 1) for line in z.read("config.ini").decode().splitlines() if " = " in line)
        layers = [n for n in z.namelist() if n.endswith(".png") and not n.startswith("thumbnail")]
    assert config["printerModel"] == "SL1S" and "PrusaSlicer" in config["prusaSlicerVersion"]
    printing = litho.report["print"]
    assert printing["print_time_s"] == pytest.approx(float(config["printTime"]))
    assert printing["resin_ml"] == pytest.approx(float(config["usedMaterial"]))
    assert printing["layer_mm"] == pytest.approx(float(config["layerHeight"])) == pytest.approx(litho.printer.layer_mm)
    assert printing["layers"] == len(layers)
    # independent checks: the layers stack to the print's height, the resin is the solid's volume
    mesh = trimesh.load(tmp_path / "fept_spheres_sem.stl")
    assert printing["layers"] * printing["layer_mm"] == pytest.approx(mesh.bounds[1][2] - mesh.bounds[0][2], abs=2 * printing["layer_mm"])
    assert printing["resin_ml"] == pytest.approx(mesh.volume / 1000, rel=0.05)
    words = litho.report.print.summary
    assert f"{printing['resin_ml']:.1f} mL" in words and "CO₂e" in words and SL1S in words


@pytest.mark.slicer
def test_a_file_that_is_not_an_sla_archive_is_refused(tmp_path):
    bad = tmp_path / "x.sl1s"
    bad.write_bytes(b"not a zip")
    with pytest.raises(SlicerError, match="not an SLA print archive"):
        read_sla_archive(bad, material("resin"))
    with zipfile.ZipFile(tmp_path / "y.sl1s", "w") as z:
        z.writestr("config.ini", "printTime = 3\n")
    with pytest.raises(SlicerError, match="lacks"):
        read_sla_archive(tmp_path / "y.sl1s", material("resin"))


# --- materials and footprint ----------------------------------------------------------------------

def test_every_material_the_issue_names_has_a_density_a_price_and_a_sourced_footprint():
    for name in ("PLA", "PETG", "rPLA", "rPETG", "resin", "plant-resin"):
        m = material(name)
        assert 0.9 < m.density_g_cm3 < 1.5 and m.price_per_kg > 0
        assert m.co2e_kg_per_kg is not None and 0 < m.co2e_kg_per_kg < 10 and len(m.co2e_source) > 20, m
    assert material("rPLA").co2e_kg_per_kg < material("PLA").co2e_kg_per_kg
    assert material("rPETG").co2e_kg_per_kg < material("PETG").co2e_kg_per_kg
    assert material("plant-resin").co2e_kg_per_kg < material("resin").co2e_kg_per_kg
    assert {m.name for m in MATERIALS.values() if m.is_resin} == {"resin", "plant-resin"}


def test_resin_estimate_is_the_solid_s_volume_and_the_footprint_scales_with_mass():
    import trimesh

    box = trimesh.creation.box((40, 30, 3))
    printer = get_printer("form 4")
    e = estimate(float(box.volume), box.vertices, box.faces, printer=printer, mat=material("resin"))
    assert e["resin_ml"] == pytest.approx(3.6) and e["filament_g"] == pytest.approx(3.6 * material("resin").density_g_cm3, rel=1e-3)
    assert e["co2e_kg"] == pytest.approx(e["filament_g"] / 1000 * material("resin").co2e_kg_per_kg)
    fdm = estimate(float(box.volume), box.vertices, box.faces, printer=get_printer("mk4"), mat=material("PLA"))
    assert fdm["filament_cm3"] < 3.6  # a nozzle printer's infill is not solid


def test_the_material_must_suit_the_technology():
    assert material_for(get_printer("sl1s"), "PLA").name == "resin"  # the default on a resin printer
    assert material_for(get_printer("sl1s"), "plant-resin").name == "plant-resin"
    with pytest.raises(ParameterError, match="resin printer.*resin, plant-resin"):
        material_for(get_printer("sl1s"), "PETG")
    with pytest.raises(ParameterError, match="nozzle printer"):
        material_for(get_printer("mk4"), "resin")


# --- bad input: one clear message each ------------------------------------------------------------

@pytest.mark.parametrize("options, words", [
    ({"multicolour": True}, "multicolour: .* resin printer"),
    ({"layer_mm": 0.3}, r"layer_mm: .* makes layers of 0.025 to 0.1 mm; got 0.3 mm"),
    ({"nozzle_mm": 0.4}, "nozzle_mm: .* has no nozzle"),
    ({"material": "PETG"}, "material: .* resin printer"),
])
def test_what_a_resin_printer_cannot_do_is_refused_before_anything_is_made(options, words):
    from tamp_os.lithograph.sizing import resolve_printer

    with pytest.raises(ParameterError, match=words):
        resolve_printer(LithoParams(printer="sl1s", **options))


def test_a_layer_prusaslicer_has_no_preset_for_is_refused_when_slicing():
    from tamp_os.lithograph.sizing import resolve_printer
    from tamp_os.printing.prusa_presets import sla_printers

    need(SL1S.lower() in sla_printers(), "PrusaSlicer's vendor bundles (apt-get install prusa-slicer)")
    assert resolve_printer(LithoParams(printer="sl1s", layer_mm=0.07)).layer_mm == pytest.approx(0.07)  # in range: a 3MF is fine
    with pytest.raises(ParameterError, match="layers of 0.025, 0.05, 0.1 mm; got 0.07 mm"):
        resolve_printer(LithoParams(printer="sl1s", layer_mm=0.07, gcode=True))


def test_the_command_line_says_each_in_one_line(tmp_path, capsys):
    for extra, option in ((["--multicolour"], "--multicolour"), (["--layer-mm", "0.3"], "--layer-mm"),
                          (["--nozzle-mm", "0.4"], "--nozzle-mm")):
        code, out, err = run_cli(capsys, "convert", tmp_path / "missing.png", "--printer", "sl1s", *extra, "-o", tmp_path)
        lines = err.strip().splitlines()
        assert code != 0 and len(lines) == 1 and lines[0].startswith(f"error: {option}:") and "Traceback" not in err, err


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_a_plate_larger_than_the_build_area_is_split_into_tiles_that_fit(tmp_path, fixture_fept):
    model = find_printer("sl1s")
    litho = make_lithograph(FEPT, printer="sl1s", width_mm=120)
    assert litho.tiles is not None and len(litho.tiles.tiles) >= 2
    for tile in litho.tiles.tiles:
        size = sorted(np.ptp(tile.mesh.vertices, axis=0)[:2])  # a tile may lie turned on the bed
        assert size[0] <= min(model.bed_mm[:2]) + 1e-6 and size[1] <= max(model.bed_mm[:2]) + 1e-6


# --- listing and the web app ----------------------------------------------------------------------

def test_printers_lists_resin_printers_by_technology_with_short_names(capsys):
    code, out, _ = run_cli(capsys, "printers")
    assert code == 0
    nozzle, resin = out.index("nozzle (FDM) printers"), out.index("resin (MSLA and SLA) printers")
    assert nozzle < resin
    for p in RESIN_PRINTERS:
        at = out.index(p.line())
        assert at > resin and p.short_names[0] in out[at:at + 600]


def test_the_web_app_offers_resin_printers_and_says_what_suits_them():
    from tamp_os.gui.forms import printer_choices

    choices = printer_choices()
    for p in RESIN_PRINTERS:
        profile = choices[p.model]
        assert profile.is_resin and "resin" in profile.description
        assert (".sl1s" if sla_preset(p) else "vendor's own slicer") in profile.description


def test_a_nozzle_printer_s_recipe_profile_is_unchanged_and_a_resin_one_round_trips():
    assert "technology" not in get_printer("mk4").as_dict() and "layers_mm" not in get_printer("standard").as_dict()
    resin = get_printer("form 4")
    again = PrinterProfile.from_dict(resin.as_dict())
    assert again == resin
