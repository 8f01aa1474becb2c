"""The demo entry point (scripts/demo.py, `make demo`) runs."""

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


@pytest.mark.slow
def test_the_demo_entry_point_runs(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "demo.py"), str(tmp_path / "demo")],
                          capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = [line for line in done.stdout.splitlines() if line and not line.startswith(("  ", "demo:"))]
    fixtures = [p for p in FIXTURES.iterdir() if p.is_file() and p.suffix != ".md"] if FIXTURES.is_dir() else []
    assert len(lines) == 3 + len(fixtures) + 2
    assert (tmp_path / "demo" / "cell.stl").is_file() and (tmp_path / "demo" / "cell.pdf").is_file()


@pytest.mark.slow
def test_the_demo_without_fixtures_says_so_and_still_makes_every_kind_of_print(tmp_path):
    """Issue 33.10: with no fixtures folder the demo says it converts only the built-in pictures, and
    still makes the two-colour and the tiled print (from a built-in picture), not skips them unsaid."""
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), TAMP_FIXTURES=str(tmp_path / "no-fixtures"))
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "demo.py"), str(tmp_path / "demo")],
                          capture_output=True, text=True, timeout=600, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    assert f"the real microscope files ({tmp_path / 'no-fixtures'}) are not here" in done.stdout, done.stdout
    assert list((tmp_path / "demo" / "two-colours").glob("*.3mf")) and len(list((tmp_path / "demo" / "tiles").glob("*.tile-*.stl"))) >= 2
