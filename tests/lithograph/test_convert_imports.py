"""A mesh conversion imports only what it uses: a new process converts the FePt fixture and reports
which heavy modules it loaded. (Each of these cost 0.05-0.7 s of every `tamp-os convert`.)"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.timeout(300)

CHILD = """
import json, sys
from pathlib import Path
from tamp_os.lithograph.convert import convert
from tamp_os.params import LithoParams
done = convert(Path(sys.argv[1]), LithoParams(formats=tuple(sys.argv[3].split(","))), Path(sys.argv[2]))
print(json.dumps({"written": [p.name for p in done.written], "modules": sorted(sys.modules)}))
"""

# Used only by other formats, other front ends or opt-in stages.
NEVER = {
    "trimesh": "OBJ/PLY, renders and mesh reading",
    "networkx": "trimesh's graphs",
    "pyvista": "renders",
    "vtk": "renders",
    "cairo": "PDF/SVG graphics",
    "scipy.interpolate": "the touch check",
    "scipy.sparse.csgraph": "STEP",
    "xml.sax": "SVG text",
    "urllib.request": "nothing on this path",
    "skimage.color": "channels (opt-in)",
    "PIL.PdfImagePlugin": "Pillow's rarer formats",
    "tamp_os.tactile.tiles": "a bed smaller than the plate",
    "tamp_os.tactile.parts": "two-colour prints",
    "tamp_os.lithograph.content_word": "the panels of a figure",
}


def _loaded(fixture, tmp_path, formats: str) -> tuple[list[str], set[str]]:
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-c", CHILD, str(fixture("fept_spheres_sem.png")), str(tmp_path), formats],
                         capture_output=True, text=True, env=env, timeout=240, check=True)
    report = json.loads(out.stdout.strip().splitlines()[-1])
    return report["written"], set(report["modules"])


def test_stl_3mf_glb_convert_imports_no_trimesh_renderer_or_graphics(fixture, tmp_path):
    written, modules = _loaded(fixture, tmp_path, "stl,3mf,glb")
    assert {"fept_spheres_sem.stl", "fept_spheres_sem.3mf", "fept_spheres_sem.glb"} <= set(written)
    assert "tamp_os.export.threemf" in modules  # the 3MF writer was imported: the check below does see imports
    assert "lib3mf" not in modules  # the 3MF is written directly (export/threemf.py); lib3mf reads it back in tests
    assert not {m for m in NEVER if m in modules}, {m: NEVER[m] for m in NEVER if m in modules}


def test_stl_convert_does_not_load_lib3mf(fixture, tmp_path):
    written, modules = _loaded(fixture, tmp_path, "stl")
    assert "fept_spheres_sem.stl" in written
    assert "lib3mf" not in modules
    assert not {m for m in NEVER if m in modules}
