"""The core install converts; the web app, rendering, Dask and the napari plugin are extras, and a
missing one is named in one line (`pip install 'tamp-os[gui]'`), never a traceback."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from conftest import ROOT

CHILD = """
import sys
for name in {missing!r}:
    sys.modules[name] = None  # as if the extra were not installed: importing it raises ImportError
from tamp_os.cli import main
code = main({argv!r})
print("EXIT", code)
print("LOADED", sorted(m for m in ("fastapi", "uvicorn", "pyvista", "vtk", "distributed", "dask", "napari", "magicgui", "PyQt5")
                      if sys.modules.get(m)))
"""


def run_child(missing: list[str], argv: list[str], cwd) -> subprocess.CompletedProcess:
    code = textwrap.dedent(CHILD.format(missing=missing, argv=argv))
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=240,
                          env={"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"})


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_converting_needs_no_extra(tmp_path, gradient_image):
    from PIL import Image

    Image.fromarray(gradient_image).save(tmp_path / "ramp.png")
    done = run_child(["fastapi", "uvicorn", "jinja2", "pyvista", "vtk", "dask", "distributed", "napari", "magicgui", "npe2", "PyQt5"],
                     ["convert", "ramp.png", "-o", "out", "--formats", "stl,3mf,pdf"], tmp_path)
    assert "EXIT 0" in done.stdout, done.stdout + done.stderr
    assert "LOADED []" in done.stdout
    assert sorted(p.suffix for p in (tmp_path / "out").iterdir()) == [".3mf", ".json", ".pdf", ".stl", ".txt"]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("extra, missing, argv", [
    ("render", "pyvista", ["render", "mesh.stl", "-o", "renders"]),
    ("gui", "fastapi", ["gui", "--no-browser", "--port", "0"]),
    ("dask", "distributed", ["batch", ".", "-o", "out", "--dask-scheduler", "tcp://127.0.0.1:1"]),
])
def test_a_missing_extra_is_named_in_one_line(tmp_path, gradient_image, extra, missing, argv):
    import trimesh
    from PIL import Image

    trimesh.creation.box((10, 10, 2)).export(tmp_path / "mesh.stl")
    Image.fromarray(gradient_image).save(tmp_path / "ramp.png")
    done = run_child([missing], argv, tmp_path)
    assert "EXIT 1" in done.stdout, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and f"pip install 'tamp-os[{extra}]'" in lines[0], lines
