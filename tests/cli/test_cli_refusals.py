"""The command line refuses plainly: option values that start with a dash reach the range check, mesh commands refuse what is not a mesh, a text file's bytes are never echoed."""

import json
import os
import subprocess
import sys
from pathlib import Path
import numpy as np
import pytest
import tifffile
from PIL import Image
from cli_support import one_error_line, run_cli_child
from conftest import FIXTURES, ROOT, run_cli as run
from synthetic_content import fluorescence_composite
from tamp_os import make_lithograph
from tamp_os.errors import ParameterError
from tamp_os.relief.heightmap import heights_mm
from tamp_os.relief.preprocess import prepare, resample, stretch


pytestmark = pytest.mark.timeout(240)


def test_option_values_that_start_with_a_dash_reach_the_range_check(tmp_path, capsys):
    Image.fromarray(np.eye(30, dtype=np.uint8) * 255).save(tmp_path / "e.png")
    code, _, err = run(capsys, "convert", tmp_path / "e.png", "-o", tmp_path / "o", "--pixel-size", "-5um")
    assert code == 2 and "--pixel-size: must be a length greater than 0 (between 1 pm and 1 m); got '-5um'" in err


@pytest.mark.parametrize("command", ["estimate", "slice", "render", "check"])
def test_mesh_commands_refuse_what_is_not_a_mesh(tmp_path, capsys, command):
    text = tmp_path / "notes.stl"
    text.write_text("this is not a mesh")
    image = tmp_path / "picture.png"
    Image.fromarray(np.eye(20, dtype=np.uint8)).save(image)
    nan = tmp_path / "nan.stl"
    nan.write_text("solid x\nfacet normal 0 0 0\nouter loop\nvertex nan 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid\n")
    items = [text, nan] + ([] if command == "check" else [image])  # check reads images too
    code, out, err = run(capsys, command, *items)
    assert code == 1 and "Traceback" not in err
    assert err.count("error:") == len(items), err
    assert " g of " not in out  # no mass estimated from garbage


def test_reading_a_text_file_never_echoes_its_bytes(tmp_path, capsys):
    secret = tmp_path / "secret.png"
    secret.write_text("password=hunter2")
    code, _, err = run(capsys, "convert", secret, "-o", tmp_path / "o")
    assert code == 1 and "hunter2" not in err and "it holds text, not pixels" in err


# ---- issue 51: settings that cannot be printed, and error lines that repeat the argument -------

def _picture(tmp_path, name="p.png") -> Path:
    path = tmp_path / name
    Image.fromarray((np.random.default_rng(0).random((40, 50)) * 255).astype(np.uint8)).save(path)
    return path


def _channels_picture(tmp_path) -> Path:
    path = tmp_path / "fluo.png"
    Image.fromarray(fluorescence_composite()).save(path)
    return path


def refusal(out: Path, *argv, code: int, timeout_s: float = 120) -> str:
    """The command line in a child process: it exits with `code`, says one error line and no
    traceback, and leaves `out` (the output folder) without a file. Returns the line."""
    status, err, _, _, _ = run_cli_child(*argv, timeout_s=timeout_s)
    assert status == code, err
    line = one_error_line(err)
    assert not out.exists() or not any(out.iterdir()), sorted(p.name for p in out.iterdir())
    return line


@pytest.mark.parametrize("command", ["convert", "batch"])
def test_a_resin_on_a_nozzle_printer_is_refused_by_convert_as_by_estimate(tmp_path, command):
    out = tmp_path / "out"
    line = refusal(out, command, _picture(tmp_path), "-o", out, "--printer", "mk4", "--material", "resin", code=2)
    assert "--material" in line and "nozzle printer" in line and "'resin'" in line and "PLA" in line, line
    line = refusal(out, command, _picture(tmp_path), "-o", out, "--material", "plant-resin", code=2)  # the default printer
    assert "'standard' is a nozzle printer" in line and "'plant-resin'" in line, line


def test_key_labels_that_name_no_channel_are_refused_and_the_others_said(tmp_path):
    out = tmp_path / "out"
    fluo = _channels_picture(tmp_path)
    line = refusal(out, "convert", fluo, "-o", out, "--key-labels", "DAPI=nuclei,GFP=actin", "--preset", "low", code=1)
    assert "--key-labels: no channel named dapi, gfp in this picture; its channels are red, green, blue" in line, line
    status, err, _, _, _ = run_cli_child("convert", fluo, "-o", out, "--key-labels", "blue=nuclei,GFP=actin", "--preset", "low")
    assert status == 0 and "Traceback" not in err, err
    assert "warning: --key-labels: no channel named gfp in this picture" in err and "error:" not in err, err
    status, err, _, _, _ = run_cli_child("convert", _picture(tmp_path), "-o", tmp_path / "grey", "--key-labels", "DAPI=nuclei")
    assert status == 0 and "warning: --key-labels: this print has no channel key" in err, err


def test_lengths_given_as_a_number_of_metres_are_read(tmp_path):
    stack = tmp_path / "stack.tif"
    z = np.zeros((8, 16, 16), np.uint8)
    z[2:6, 4:12, 4:12] = 200
    tifffile.imwrite(stack, z, imagej=True, metadata={"axes": "ZYX"})
    out = tmp_path / "out"
    status, err, _, _, _ = run_cli_child("convert", stack, "--volume", "-o", out, "--z-step", "1e-9", "--pixel-size", "2e-9",
                                         "--size-mm", "20", timeout_s=180)
    assert status == 0 and "Traceback" not in err, err
    assert "voxels 2 nm × 2 nm × 1 nm" in (out / "stack.description.txt").read_text()
    line = refusal(tmp_path / "o2", "convert", stack, "--volume", "-o", tmp_path / "o2", "--z-step", "5", code=2)
    assert "--z-step: must be a length from 1 pm to 1 m" in line and "got '5' (metres)" in line and "such as 4.2nm" in line, line


def _float_picture(path: Path, values: np.ndarray) -> Path:
    tifffile.imwrite(path, values)
    return path


def _height_range_mm(stl: Path) -> float:
    records = np.frombuffer(stl.read_bytes()[84:], dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]))
    z = records["v"][..., 2]
    return float(z.max() - z.min())


def test_finite_values_past_single_precision_print_as_a_relief(tmp_path):
    huge = np.zeros((40, 50))
    huge[:20], huge[20:] = 1e299, -1e299
    huge[5:15, 5:25] = 0.0
    out = tmp_path / "out"
    status, err, _, _, _ = run_cli_child("convert", _float_picture(tmp_path / "huge.tif", huge), "-o", out, "--verbose")
    assert status == 0 and "NaN" not in err and "Traceback" not in err, err
    assert _height_range_mm(out / "huge.stl") > 2.0  # the relief of the picture, not a flat plate
    holes = huge.copy()
    holes[30:35, 30:40] = np.nan
    status, err, _, _, _ = run_cli_child("convert", _float_picture(tmp_path / "holes.tif", holes), "-o", out)
    assert status == 0 and "50 pixels were NaN or infinite" in err, err
    infinite = np.where(np.arange(40 * 50).reshape(40, 50) % 2, np.inf, -np.inf)
    line = refusal(tmp_path / "o2", "convert", _float_picture(tmp_path / "inf.tif", infinite), "-o", tmp_path / "o2", code=1)
    assert "inf.tif: every pixel is NaN or infinite" in line, line


def test_a_grid_too_coarse_for_a_relief_names_the_resolution(tmp_path):
    out = tmp_path / "out"
    line = refusal(out, "sweep", _picture(tmp_path), "-o", out, "--vary", "resolution=2,16384", code=2)
    assert "--resolution-px: 2 grid points across 100 mm are 100 mm apart" in line and "at least 3" in line, line
    assert "between the grid pitch" not in line
    line = refusal(out, "convert", _picture(tmp_path), "-o", out, "--resolution-px", "3", "--width-mm", "200", code=1)
    assert "give --resolution-px 5 or more" in line.lower(), line


LONG = 100_000


@pytest.mark.parametrize("argv, prefix", [
    (("convert", "{image}", "--printer", "p" * 10_000), "--printer: unknown profile 'ppp"),
    (("convert", "{fluo}", "--key-labels", "k" * LONG), "--key-labels: 'kkk"),
    (("convert", "{fluo}", "--key-labels", "A" * LONG + "=nuclei"), "--key-labels: no channel named aaa"),
    (("convert", "{image}", "--relief-style", "r" * LONG), "--relief-style: must be one of"),
    (("convert", "{image}", "--channel", "c" * LONG), "p.png: channel ccc"),
    (("convert", "{image}", "--formats", "f" * LONG), "is not a format TAMP-OS writes"),
    (("render", "{image}", "--theme", "t" * LONG), "argument --theme: invalid choice: 'ttt"),
])
def test_an_error_line_quotes_a_short_prefix_of_a_long_value(tmp_path, argv, prefix):
    out = tmp_path / "out"
    files = {"image": _picture(tmp_path), "fluo": _channels_picture(tmp_path)}
    argv = [str(a).format(**files) if str(a).startswith("{") else a for a in argv]
    status, err, _, _, _ = run_cli_child(*argv, "-o", out, "--preset", "low", timeout_s=120)
    line = next(line for line in err.splitlines() if "error:" in line)
    assert status in (1, 2) and "Traceback" not in err, err[:2000]
    assert prefix in line and len(line) < 400, line[:600]
    assert " characters)" in line, line
    assert not out.exists() or not any(out.iterdir())


def test_a_warning_line_quotes_a_short_prefix_of_a_long_value(tmp_path):
    out = tmp_path / "out"
    status, err, _, _, _ = run_cli_child("convert", _channels_picture(tmp_path), "-o", out, "--preset", "low",
                                         "--key-labels", "blue=nuclei," + "G" * LONG + "=actin", timeout_s=120)
    warning = next(line for line in err.splitlines() if line.startswith("warning: --key-labels"))
    assert status == 0 and "no channel named ggg" in warning and "(100,000 characters)" in warning and len(warning) < 400, warning[:600]
