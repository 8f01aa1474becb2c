"""make_lithograph refuses a grid too large to mesh and a print too thin to read before any work, and says when a coarse mesh may flatten the relief."""

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


def test_a_grid_too_large_to_mesh_is_refused_before_any_work():
    with pytest.raises(ParameterError, match=r"resolution_px: a 16384×12288 grid would need about \d+\.\d GB"):
        make_lithograph(np.eye(100)[:75], resolution_px=16384, mesher="grid")
    with pytest.raises(ParameterError, match="adaptive mesher"):
        make_lithograph(np.eye(100)[:75], resolution_px=16384, mesher="adaptive")


def test_a_print_too_thin_to_read_is_refused_with_advice(tmp_path, capsys):
    with pytest.raises(ParameterError, match="thinner than 2 mm"):
        make_lithograph(np.zeros((2, 6000)))
    Image.fromarray(np.zeros((2, 6000), np.uint8)).save(tmp_path / "line.png")
    code, _, err = run(capsys, "convert", tmp_path / "line.png", "-o", tmp_path / "out")
    assert code == 1 and "--depth-mm" in err and "--fit pad" not in err
    # Given a depth, the same image is padded into a readable plate.
    litho = make_lithograph(np.zeros((2, 6000)), width_mm=60, depth_mm=20, fit="pad")
    assert litho.layout.depth_mm == pytest.approx(20)


def test_a_coarse_adaptive_mesh_says_it_may_flatten_the_relief():
    quiet = make_lithograph(np.eye(40), scale_bar="off")
    loud = make_lithograph(np.eye(40), scale_bar="off", max_error_mm=5)
    assert not any("max_error_mm" in w for w in quiet.report.warnings)
    assert any("max_error_mm 5" in w and "flattened" in w for w in loud.report.warnings)
