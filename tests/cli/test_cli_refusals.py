"""The command line refuses plainly: option values that start with a dash reach the range check, mesh commands refuse what is not a mesh, a text file's bytes are never echoed."""

import json
import os
import subprocess
import sys
import numpy as np
import pytest
from PIL import Image
from conftest import FIXTURES, ROOT, run_cli as run
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
