"""Slicing with the real PrusaSlicer, its mesh check, estimates and failure paths."""

import re
import shutil

import numpy as np
import pytest

from conftest import need

from tamp_os import make_lithograph
from tamp_os.cli.commands import main
from tamp_os.errors import MissingDependencyError
from tamp_os.printing.printers import get_printer
from tamp_os.printing.slicer import SlicerError, estimate, material, mesh_info, slice_mesh


@pytest.fixture(autouse=True)
def slicer_present():
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")


@pytest.fixture(scope="module")
def fept_low(tmp_path_factory, request):
    from conftest import FIXTURES

    need((FIXTURES / "fept_spheres_sem.png").is_file(), "fixture fept_spheres_sem.png")
    folder = tmp_path_factory.mktemp("slice")
    litho = make_lithograph(FIXTURES / "fept_spheres_sem.png", preset="low", gcode=True)
    _, sliced = litho.save_sliced(folder)  # gcode=True: saving slices too; the report returned holds the result
    return sliced, folder


def test_gcode_layers_and_figures(fept_low):
    litho, folder = fept_low
    gcode = (folder / "fept_spheres_sem.gcode").read_text()
    zs = [float(z) for z in re.findall(r"^;Z:([0-9.]+)", gcode, re.M)]
    assert zs[0] == pytest.approx(0.2) and np.allclose(np.diff(zs), 0.12, atol=1e-6)
    assert zs[-1] == pytest.approx(4.0, abs=0.13)
    p = litho.report["print"]
    assert p["layer_mm"] == pytest.approx(0.12) and p["layers"] == len(zs)
    for key in ("print_time_s", "filament_mm", "filament_cm3", "filament_g", "cost"):
        assert p[key] > 0, key
    assert p["filament_g"] == pytest.approx(p["filament_cm3"] * 1.24, abs=0.02)
    assert p["cost"] == pytest.approx(p["filament_g"] / 1000 * 25.0, abs=0.01)
    assert p["filament_cm3"] * 1000 < litho.mesh.volume_mm3()  # 15 % infill uses less than the solid
    import json

    recipe = json.loads((folder / "fept_spheres_sem.tamp.json").read_text(encoding="utf-8"))
    assert recipe["print"]["filament_g"] == p["filament_g"] and "fept_spheres_sem.gcode" in recipe["outputs"]


def test_estimate_is_within_25_percent_of_the_slicer(fept_low):
    litho, _ = fept_low
    e = estimate(litho.mesh.volume_mm3(), litho.mesh.vertices, litho.mesh.faces, printer=get_printer("standard"), mat=material("PLA"))
    assert e["filament_g"] == pytest.approx(litho.report["print"]["filament_g"], rel=0.25)
    assert "15% gyroid infill" in e["assumptions"]


@pytest.mark.parametrize("kind", ["grid", "adaptive", "tactile"])
def test_prusaslicer_finds_every_mesh_kind_manifold(tmp_path, kind):
    y, x = np.mgrid[0:50, 0:70]
    image = np.sin(x / 5) * np.cos(y / 7)
    extra = {"caption": "Test", "pixel_size": "2um", "frame_mm": 1.5} if kind == "tactile" else {}
    litho = make_lithograph(image, width_mm=70, mesher="adaptive" if kind != "grid" else "grid", **extra)
    path = litho.save(tmp_path / f"{kind}.stl")[0]
    info = mesh_info(path)
    assert info["manifold"] == "yes"
    assert info.get("number_of_parts", "1").strip() == "1"
    for problem in ("open_edges", "facets_reversed", "backwards_edges", "edges_fixed", "degenerate_facets"):
        assert info.get(problem, "0") in ("0", ""), (problem, info[problem])


def test_timeout_keeps_the_mesh(tmp_path):
    litho = make_lithograph(np.random.default_rng(0).random((200, 200)), mesher="grid", resolution_px=400)
    stl = litho.save(tmp_path / "slow.stl")[0]
    before = stl.read_bytes()
    with pytest.raises(SlicerError, match="timeout of 0.2 s"):
        slice_mesh(stl, get_printer("standard"), material("PLA"), timeout_s=0.2)
    assert stl.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["slow.description.txt", "slow.stl", "slow.tamp.json"]


def test_missing_slicer_is_a_clear_message_and_keeps_the_mesh(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(MissingDependencyError, match="apt-get install prusa-slicer"):
        slice_mesh(tmp_path / "x.stl", get_printer("standard"), material("PLA"))
    image = tmp_path / "img.png"
    from PIL import Image

    Image.fromarray((np.random.default_rng(1).random((30, 40)) * 255).astype(np.uint8)).save(image)
    code = main(["convert", str(image), "-o", str(tmp_path / "out"), "--gcode"])
    assert code == 1
    assert "prusa-slicer" in capsys.readouterr().err
    assert (tmp_path / "out" / "img.stl").is_file()


def test_slice_and_estimate_commands(fept_low, capsys):
    _, folder = fept_low
    assert main(["estimate", str(folder / "fept_spheres_sem.stl")]) == 0
    assert "g of PLA" in capsys.readouterr().out
    assert main(["slice", str(folder / "fept_spheres_sem.stl"), "--filament-price", "20"]) == 0
    out = capsys.readouterr().out
    assert "to print" in out and "at 20 per kg" in out and "layers of 0.12 mm" in out
