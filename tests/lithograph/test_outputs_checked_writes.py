"""lithograph/outputs.py writes the mesh formats while the mesh's solid check runs beside them:
no file takes its name unless the check passes, the files are those of checking first, and a
refused mesh gives the same error as before and leaves nothing in the folder."""

from __future__ import annotations

import dataclasses
import hashlib
import threading
import time

import numpy as np
import pytest

from tamp_os import make_lithograph
from tamp_os.errors import ExportError
from tamp_os.lithograph import outputs
from tamp_os.mesh.solid import Mesh, grid_solid

FORMATS = ["stl", "3mf", "glb"]


@pytest.fixture(scope="module")
def mesh():
    return grid_solid(np.random.default_rng(4).random((40, 50)) + 1.0, 50.0, 40.0)


class _Refused(BaseException):
    """What a Ctrl-C during the check raises (a BaseException), without stopping the test run."""


def _refuse(after_s: float, error: BaseException):
    def check():
        time.sleep(after_s)
        raise error

    return check


@pytest.mark.timeout(120)
@pytest.mark.parametrize("side_by_side", [True, False])
@pytest.mark.parametrize("after_s, error", [(0.0, ExportError("not a solid")), (0.3, ExportError("not a solid")), (0.05, _Refused())])
def test_a_failing_check_leaves_no_file_and_no_part(tmp_path, monkeypatch, mesh, side_by_side, after_s, error):
    """The check failing at once, after the writers have finished their parts, or interrupted:
    its error reaches the caller, and the folder is empty (no file, no temporary part)."""
    monkeypatch.setattr(outputs, "PARALLEL_WRITE_TRIANGLES", 0 if side_by_side else 10**9)
    before = set(threading.enumerate())
    with pytest.raises(type(error)):
        outputs.write_meshes(mesh, tmp_path, "print", formats=FORMATS, meta={"title": "refused"}, check=_refuse(after_s, error))
    assert list(tmp_path.iterdir()) == []
    assert set(threading.enumerate()) <= before  # every writer thread has ended


@pytest.mark.timeout(120)
def test_files_written_beside_a_passing_check_are_those_of_checking_first(tmp_path, monkeypatch, mesh):
    monkeypatch.setattr(outputs, "PARALLEL_WRITE_TRIANGLES", 0)
    (tmp_path / "beside").mkdir()
    (tmp_path / "plain").mkdir()
    seen = []

    def check():
        time.sleep(0.2)  # the writers have finished their parts by now
        seen.append(sorted(p.name for p in (tmp_path / "beside").glob("print.*")))

    beside = outputs.write_meshes(mesh, tmp_path / "beside", "print", formats=FORMATS, meta={"title": "t"}, check=check)
    plain = outputs.write_meshes(mesh, tmp_path / "plain", "print", formats=FORMATS, meta={"title": "t"})
    assert seen == [[]]  # while the check ran, no file had its name
    for fmt in FORMATS:
        assert hashlib.sha256(beside[fmt][0].read_bytes()).digest() == hashlib.sha256(plain[fmt][0].read_bytes()).digest()


@pytest.mark.timeout(240)
def test_saving_an_open_mesh_is_refused_as_before_and_writes_nothing(tmp_path, monkeypatch):
    """A lithograph whose mesh is not a closed solid: save raises check_export's error (the
    solid's, naming every file) and the folder stays empty, side by side or not."""
    from tamp_os.export import check_export

    litho = make_lithograph(np.random.default_rng(2).random((30, 40)), width_mm=40, formats=tuple(FORMATS))
    mesh = litho.mesh
    opened = dataclasses.replace(litho, mesh=Mesh(vertices=mesh.vertices, faces=mesh.faces[1:]))
    with pytest.raises(ExportError) as expected:
        check_export(opened.mesh, [tmp_path / f"x.{fmt}" for fmt in FORMATS])
    for limit in (0, 10**9):
        monkeypatch.setattr(outputs, "PARALLEL_WRITE_TRIANGLES", limit)
        folder = tmp_path / f"out{limit}"
        with pytest.raises(ExportError) as refused:
            outputs.save(opened, folder, FORMATS, stem="x")
        assert str(refused.value).split(":", 1)[1] == str(expected.value).split(":", 1)[1] and "x.stl, x.3mf, x.glb" in str(refused.value)
        assert list(folder.iterdir()) == []
