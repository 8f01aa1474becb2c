"""STEP export read back by OpenCASCADE (through the gmsh wheel) as one closed solid."""

import json
import subprocess
import sys

import numpy as np
import pytest

from tamp_os import make_lithograph
from tamp_os.errors import ExportError
from tamp_os.export import save_mesh
from tamp_os.export.step import _real, planar_faces
from tamp_os.mesh.solid import grid_solid
from conftest import need_module


# The reading runs in a child process: gmsh.initialize() resets the process's SIGSEGV, SIGFPE,
# SIGBUS and SIGINT handlers to the defaults (Python's fault handler among them) and switches the
# locale to "C", so in the test worker a later crash of any test would end it without a traceback.
READ_STEP = """
import json, sys
import gmsh
gmsh.initialize(["-noenv"])
gmsh.option.setNumber("General.Terminal", 0)
tags = gmsh.model.occ.importShapes(sys.argv[1])
gmsh.model.occ.synchronize()
solids = [t for d, t in tags if d == 3]
volumes = [gmsh.model.occ.getMass(3, t) for t in solids]
bbox = list(gmsh.model.getBoundingBox(3, solids[0])) if solids else None
print(json.dumps([volumes, bbox, len(gmsh.model.getEntities(2))]))
gmsh.finalize()
"""


def occ_solids(path):
    need_module("gmsh")
    done = subprocess.run([sys.executable, "-c", READ_STEP, str(path)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    volumes, bbox, n_faces = json.loads(done.stdout.splitlines()[-1])
    return volumes, bbox, n_faces


@pytest.mark.parametrize("mesher", ["adaptive", "grid"])
def test_step_is_one_solid_with_the_right_volume(tmp_path, gradient_image, mesher):
    litho = make_lithograph(gradient_image, width_mm=50, resolution_px=48, mesher=mesher)
    path = save_mesh(litho.mesh, tmp_path / "x.step", litho.metadata())
    volumes, bbox, n_faces = occ_solids(path)
    assert len(volumes) == 1
    assert volumes[0] == pytest.approx(litho.mesh.volume_mm3(), rel=1e-6)
    np.testing.assert_allclose(bbox, [0, 0, 0, 50, litho.layout.depth_mm, 4.0], atol=1e-5)
    # Walls and bottom are single polygonal faces, so there are fewer faces than triangles.
    assert n_faces < litho.mesh.n_triangles


def test_flat_plate_becomes_a_six_faced_box(tmp_path):
    mesh = grid_solid(np.full((20, 30), 2.0), 30.0, 20.0)
    assert len(planar_faces(mesh.vertices, mesh.faces)) == 6
    volumes, _, n_faces = occ_solids(save_mesh(mesh, tmp_path / "box.stp", {}))
    assert volumes == [pytest.approx(30 * 20 * 2)] and n_faces == 6


def test_holes_in_a_flat_region_become_inner_bounds():
    heights = np.full((9, 9), 1.0)
    heights[4, 4] = 2.0  # a bump in a flat plate: the flat top has a hole around it
    mesh = grid_solid(heights, 8.0, 8.0)
    faces = planar_faces(mesh.vertices, mesh.faces)
    flat_top = [loops for normal, loops in faces if normal[2] > 0.99 and len(loops) > 1]
    assert len(flat_top) == 1 and len(flat_top[0]) == 2


def test_too_many_triangles_refused_with_advice(tmp_path):
    mesh = grid_solid(np.random.default_rng(0).random((320, 320)) + 1, 10, 10)
    with pytest.raises(ExportError, match="max_error_mm"):
        save_mesh(mesh, tmp_path / "big.step", {})
    assert list(tmp_path.iterdir()) == []


def test_step_reals_always_have_a_decimal_point():
    assert _real(1.0) == "1." and _real(2.5) == "2.5" and _real(1e-7) == "1.E-07" and _real(-3.0) == "-3."
