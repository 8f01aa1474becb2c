"""The core install converts; the web app, rendering, Dask and the napari plugin are extras, and a
missing one is named in one line with the command that installs it for how TAMP-OS was installed
(from a clone: `make setup` or `pip install -e '.[gui]'`; from the package index:
`pip install 'tamp-os[gui]'`), never a traceback."""

from __future__ import annotations

import json
import shutil
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


def run_child(missing: list[str], argv: list[str], cwd, path=ROOT / "src") -> subprocess.CompletedProcess:
    code = textwrap.dedent(CHILD.format(missing=missing, argv=argv))
    return subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True, text=True, timeout=240,
                          env={"PYTHONPATH": str(path), "PATH": "/usr/bin:/bin"})


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
def test_a_missing_extra_is_named_in_one_line_with_what_works_in_a_clone(tmp_path, gradient_image, extra, missing, argv):
    """Run from this clone (as `make test` does), the line says the clone's own commands: the
    package is not on the package index, so `pip install 'tamp-os[…]'` would fail there."""
    import trimesh
    from PIL import Image

    trimesh.creation.box((10, 10, 2)).export(tmp_path / "mesh.stl")
    Image.fromarray(gradient_image).save(tmp_path / "ramp.png")
    done = run_child([missing], argv, tmp_path)
    assert "EXIT 1" in done.stdout, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    assert f"the {extra!r} extra" in lines[0] and f"in {ROOT} run make setup" in lines[0], lines
    assert f"pip install -e '.[{extra}]'" in lines[0] and "tamp-os[" not in lines[0], lines


def installed_copy(site, direct_url: dict | None):
    """The package copied into `site` as pip installs it (no pyproject.toml beside it), with its
    dist-info, and PEP 610's direct_url.json when pip installed it from a folder."""
    shutil.copytree(ROOT / "src" / "tamp_os", site / "tamp_os", ignore=shutil.ignore_patterns("__pycache__"))
    info = site / "tamp_os-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: tamp-os\nVersion: 0.1.0\n", encoding="utf-8")
    if direct_url is not None:
        (info / "direct_url.json").write_text(json.dumps(direct_url), encoding="utf-8")


@pytest.mark.timeout(120)
@pytest.mark.parametrize("direct_url, command", [
    (None, "pip install 'tamp-os[gui]' (or 'tamp-os[all]')"),  # from the package index
    ({"url": "file:///home/me/tamp-os", "dir_info": {}}, "pip install '/home/me/tamp-os[gui]'"),  # pip install /home/me/tamp-os
], ids=["index", "folder"])
def test_an_installed_copy_names_the_install_that_made_it(tmp_path, direct_url, command):
    installed_copy(tmp_path / "site", direct_url)
    done = run_child(["fastapi"], ["gui", "--no-browser", "--port", "0"], tmp_path, path=tmp_path / "site")
    assert "EXIT 1" in done.stdout, done.stdout + done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].endswith(f"comes with the 'gui' extra: {command}."), lines
    assert "make setup" not in lines[0]


@pytest.mark.timeout(120)
def test_a_missing_vendor_reader_says_what_installs_it_in_a_clone(tmp_path):
    import numpy as np

    from czi_builder import write_czi

    write_czi(tmp_path / "cells.czi", np.zeros((2, 16, 16), np.uint16))
    done = run_child(["czifile"], ["info", "cells.czi"], tmp_path)
    assert "EXIT 1" in done.stdout, done.stdout + done.stderr
    lines = [line for line in done.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "czifile" in lines[0] and "the 'vendor' extra" in lines[0], lines
    assert f"in {ROOT} run make setup" in lines[0] and "pip install -e '.[vendor]'" in lines[0], lines
