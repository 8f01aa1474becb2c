"""convert.py: the one conversion path (make, save, slice when asked, summary) that the CLI, batch,
sweep, the web app and the demo use. Slicing tests need PrusaSlicer."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil

import numpy as np
import pytest
from PIL import Image

from conftest import need, run_cli
from tamp_os import make_lithograph
from tamp_os.lithograph.convert import convert

pytestmark = pytest.mark.timeout(600)


def _picture(path, seed=3):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:60, 0:80]
    img = 200 * np.exp(-((xx - 30) ** 2 + (yy - 25) ** 2) / 90) + rng.normal(0, 2, (60, 80))
    Image.fromarray(np.clip(img + 20, 0, 255).astype(np.uint8)).save(path)
    return path


def _slicer():
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")


def _layers(gcode_path):
    zs = [float(z) for z in re.findall(r"^;Z:([0-9.]+)", gcode_path.read_text(), re.M)]
    return len(zs), np.diff(zs)


def test_convert_returns_the_files_and_the_report_it_wrote(tmp_path):
    image = _picture(tmp_path / "spot.png")
    done = convert(image, None, tmp_path / "out", formats=("stl", "3mf"))
    assert done.names == ["spot.stl", "spot.3mf", "spot.description.txt", "spot.tamp.json"]
    assert all(p.is_file() for p in done.written) and done.report.print is None and done.printing == ""
    assert done.summary().startswith("spot.png: ") and "wrote spot.{stl,3mf}, its description and recipe" in done.summary()
    recipe = json.loads((tmp_path / "out" / "spot.tamp.json").read_text(encoding="utf-8"))
    assert recipe["outputs"] == done.names[:-1] and recipe["print"] is None


def test_save_with_gcode_slices_and_records_it(tmp_path):
    """Bug: make_lithograph(img, gcode=True).save(...) wrote no G-code."""
    _slicer()
    litho = make_lithograph(np.pad(np.ones((20, 20)), 10), gcode=True, preset="low", width_mm=30, scale_bar="off")
    before = litho.report
    written, sliced = litho.save_sliced(tmp_path)
    gcode = tmp_path / "array.gcode"
    assert gcode in written and written[-1].name == "array.tamp.json"
    count, steps = _layers(gcode)
    assert count > 10 and np.allclose(steps, 0.12, atol=1e-6)
    assert before.print is None and litho.report is before, "the lithograph a caller holds is never changed"
    assert sliced.report.print is not None and sliced.report.print.result.layers == count
    with pytest.raises(dataclasses.FrozenInstanceError):
        litho.report = sliced.report
    recipe = json.loads(written[-1].read_text(encoding="utf-8"))
    assert recipe["print"]["layers"] == count and "array.gcode" in recipe["outputs"]


def test_sweep_with_gcode_slices_every_variant(tmp_path, capsys):
    """Bug: `tamp-os sweep IMAGE --vary relief=2,3 --gcode` wrote no G-code while its recipes said gcode: true."""
    _slicer()
    image = _picture(tmp_path / "spot.png")
    code, out, err = run_cli(capsys, "sweep", image, "--vary", "relief=2,3", "--gcode", "--preset", "low",
                             "--width-mm", "30", "--no-render", "-o", tmp_path / "sw")
    assert code == 0, err
    for relief in ("2", "3"):
        gcode = tmp_path / "sw" / f"spot_relief_{relief}.gcode"
        assert gcode.is_file(), sorted(p.name for p in (tmp_path / "sw").iterdir())
        recipe = json.loads((tmp_path / "sw" / f"spot_relief_{relief}.tamp.json").read_text(encoding="utf-8"))
        assert recipe["params"]["gcode"] is True and recipe["print"]["gcode"] == gcode.name
        top_mm = max(float(z) for z in re.findall(r"^;Z:([0-9.]+)", gcode.read_text(), re.M))
        assert top_mm == pytest.approx(1.0 + float(relief), abs=0.13)  # base + relief, to a layer
    assert out.count("print: ") == 2


def test_sweep_takes_an_array(tmp_path):
    from tamp_os.params import LithoParams
    from tamp_os.lithograph.sweep import run_sweep

    yy, xx = np.mgrid[0:48, 0:64]
    result = run_sweep(np.hypot(xx - 20, yy - 30), LithoParams(preset="low"), {"relief_mm": [1.5, 2.5]}, out_dir=tmp_path,
                       render=False, name="ring")
    assert [c.names[0] for c in result.conversions] == ["ring_relief_1.5.stl", "ring_relief_2.5.stl"]
    tops = [c.report.print_mm[2] for c in result.conversions]
    assert tops[1] - tops[0] == pytest.approx(1.0, abs=0.01)
    assert (tmp_path / "ring_sweep_heightmaps.png").is_file() and (tmp_path / "ring_sweep_heightmaps.alt.txt").is_file()


def test_every_front_end_converts_through_convert():
    """One conversion path: no front end makes, saves or slices a lithograph itself."""
    from conftest import ROOT

    for rel in ("cli/commands.py", "lithograph/batch.py", "lithograph/sweep.py", "gui/jobs.py", "gui/routes.py"):
        text = (ROOT / "src" / "tamp_os" / rel).read_text(encoding="utf-8")
        assert "slice_outputs" not in text and ".save(" not in text, rel
    demo = (ROOT / "scripts" / "demo.py").read_text(encoding="utf-8")
    assert "convert" in demo and ".save(" not in demo and "make_lithograph" not in demo


@pytest.mark.timeout(120)
def test_prints_in_one_process_are_the_bytes_each_makes_alone(tmp_path):
    """Prints made one after another in one process (a batch, a sweep) share kept work, such as
    the furnished plate: each must be byte for byte the print made with nothing kept, whether the
    next print has the same furniture on another picture or other furniture on the same one."""
    from tamp_os import LithoParams
    from tamp_os.tactile import furniture

    yy, xx = np.mgrid[0:90, 0:120]
    waves = ((np.sin(xx / 7) * np.cos(yy / 9) + 1) * 120).astype(np.uint8)
    block = np.zeros((90, 120), np.uint8)
    block[20:70, 30:90] = 220
    same = {"caption": "first", "frame_mm": 2.0, "pixel_size": "0.5um"}
    jobs = [(waves, same), (block, {**same, "caption": "other words", "frame_mm": 3.0}), (block, same),
            (waves, {**same, "dot_height_mm": 0.8}), (waves, {**same, "scale_bar": "40um"})]

    def written(i, picture, settings, folder):
        convert(picture, LithoParams(**settings, formats=("stl", "3mf")), folder / str(i), stem="p")
        return {p.name: p.read_bytes() for p in (folder / str(i)).iterdir() if p.suffix in (".stl", ".3mf")}

    furniture.clear_plate_cache()
    together = [written(i, picture, settings, tmp_path / "one") for i, (picture, settings) in enumerate(jobs)]
    assert furniture._pocketed_plate.cache_info().hits >= 1  # the plate was kept and used, so this tests the keeping
    for i, (picture, settings) in enumerate(jobs):
        furniture.clear_plate_cache()
        alone = written(i, picture, settings, tmp_path / "alone")
        assert sorted(alone) == ["p.3mf", "p.stl"] and alone == together[i], (i, settings)


@pytest.mark.timeout(300)
def test_obj_and_ply_written_side_by_side_in_a_fresh_process(tmp_path):
    """trimesh's modules import each other: two writer threads importing it at once, in a process
    that had not imported it yet, once failed with "partially initialized module"."""
    from cli_support import run_tamp

    Image.fromarray((np.random.default_rng(0).random((120, 160)) * 255).astype(np.uint8)).save(tmp_path / "noise.png")
    done = run_tamp("convert", "noise.png", "-o", "out", "--formats", "stl,obj,ply", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert sorted(p.suffix for p in (tmp_path / "out").iterdir()) == [".json", ".obj", ".ply", ".stl", ".txt"]
    assert "triangles" in (tmp_path / "out" / "noise.tamp.json").read_text()
