"""Guards that keep bad requests from costing memory or giving silent nonsense, and tests for
gaps a mutation study found (stretch percentiles, quantize rounding, antialiasing, uniform
invert, batch report and temporary files, the demo)."""

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


def test_the_stretch_maps_the_chosen_percentiles_of_the_source():
    values = np.arange(1000, dtype=np.float64).reshape(20, 50)
    image, (low, high), uniform = stretch(values, None, 2.0, 98.0)
    assert not uniform
    assert low == pytest.approx(np.percentile(values, 2)) and high == pytest.approx(np.percentile(values, 98))
    assert image.min() == 0 and image.max() == 1
    # A pixel half-way between the percentiles maps to 0.5.
    mid = np.argmin(np.abs(values - (low + high) / 2))
    assert image.ravel()[mid] == pytest.approx(0.5, abs=1e-3)


def test_quantize_rounds_to_the_nearest_layer_not_down():
    image = np.array([[0.0, 0.1, 0.149, 0.151, 1.0]])
    h = heights_mm(image, base_mm=1.0, relief_mm=1.0, layer_mm=0.1)
    np.testing.assert_allclose((h - 1.0)[0], [0.0, 0.1, 0.1, 0.2, 1.0], atol=1e-12)


def test_resampling_is_antialiased():
    stripes = np.tile(np.array([0.0, 1.0], np.float32), (64, 32))  # 1-pixel stripes
    small = resample(stripes, 16, 16)
    # Point sampling would give all 0 or all 1; an antialiased filter averages to the mean.
    assert np.allclose(small, 0.5, atol=0.1)


def test_invert_of_a_uniform_image_is_still_a_flat_plate_at_base():
    prepared = prepare(np.full((10, 12), 7.0), None, rows=10, cols=12, target_aspect=10 / 12, fit="pad",
                       low_pct=2, high_pct=98, sigma_px=1.0, invert=True, flip_x=False)
    assert prepared.uniform and np.all(prepared.image == 0)
    litho = make_lithograph(np.full((10, 12), 7.0), invert=True, orientation_corner="none")
    assert np.all(litho.heightmap == litho.params.base_mm)


def test_the_batch_report_is_rewritten_after_each_input_and_stale_parts_go(tmp_path, capsys):
    from tamp_os.lithograph.batch import Job, run_batch
    from tamp_os.params import LithoParams

    src = tmp_path / "in"
    src.mkdir()
    for i in range(3):
        Image.fromarray((np.random.default_rng(i).random((30, 40)) * 255).astype(np.uint8)).save(src / f"p{i}.png")
    out = tmp_path / "out"
    out.mkdir()
    stale = out / ".p0.stl.abc.part"
    stale.write_bytes(b"half a file")
    seen = []

    def watch(outcome, count, total):
        rows = json.loads((out / "batch-report.json").read_text(encoding="utf-8"))
        seen.append(len(rows))

    jobs = [Job(src / f"p{i}.png", out, LithoParams(preset="low")) for i in range(3)]
    run_batch(jobs, out, workers=1, on_done=watch)
    assert seen == [1, 2, 3]  # the report on disk grew with every finished input
    assert not stale.exists()


@pytest.mark.slow
def test_the_demo_entry_point_runs(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "demo.py"), str(tmp_path / "demo")],
                          capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = [line for line in done.stdout.splitlines() if line and not line.startswith(("  ", "demo:"))]
    fixtures = [p for p in FIXTURES.iterdir() if p.is_file() and p.suffix != ".md"] if FIXTURES.is_dir() else []
    assert len(lines) == 3 + len(fixtures) + (2 if fixtures else 0)
    assert (tmp_path / "demo" / "cell.stl").is_file() and (tmp_path / "demo" / "cell.pdf").is_file()
