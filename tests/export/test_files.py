"""export/files.py: a mesh's SHA-256 taken while it is written is the hash of the file on disk,
and is forgotten as soon as the file is not the one written."""

from __future__ import annotations

import hashlib
import os

import numpy as np
import pytest

from tamp_os.export import save_mesh
from tamp_os.export.files import WRITTEN_REMEMBERED, write_atomic, written_sha256
from tamp_os.lithograph.outputs import file_sha256, write_meshes
from tamp_os.mesh.solid import grid_solid


@pytest.fixture(scope="module")
def mesh():
    return grid_solid(np.random.default_rng(3).random((30, 40)) + 1.0, 40.0, 30.0)


def _on_disk(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.timeout(120)
@pytest.mark.parametrize("fmt", ["stl", "3mf", "glb", "obj", "ply", "step"])
def test_every_mesh_format_is_hashed_as_it_lands_on_disk(tmp_path, mesh, fmt):
    path = save_mesh(mesh, tmp_path / f"print.{fmt}", {"title": "hashed"})
    assert written_sha256(path) == _on_disk(path) == file_sha256(path)


@pytest.mark.timeout(120)
def test_formats_written_side_by_side_each_get_their_own_hash(tmp_path, monkeypatch, mesh):
    import tamp_os.lithograph.outputs as outputs

    monkeypatch.setattr(outputs, "PARALLEL_WRITE_TRIANGLES", 0)  # the threads even for this small mesh
    written = write_meshes(mesh, tmp_path, "print", formats=["stl", "3mf", "glb", "ply"], meta={"title": "side by side"})
    hashes = {fmt: written_sha256(path) for fmt, (path, _) in written.items()}
    assert hashes == {fmt: _on_disk(path) for fmt, (path, _) in written.items()} and len(set(hashes.values())) == 4


@pytest.mark.timeout(60)
@pytest.mark.parametrize("change", ["appended", "rewritten in place", "replaced", "removed", "touched"])
def test_a_file_changed_since_is_hashed_again(tmp_path, mesh, change):
    """Any change after the write (another size, another file at the name, new times) drops the
    remembered hash; file_sha256 then reads the file."""
    path = save_mesh(mesh, tmp_path / "print.stl")
    first = written_sha256(path)
    if change == "appended":
        with open(path, "ab") as fh:
            fh.write(b"x")
    elif change == "rewritten in place":  # same inode, same size, other bytes, other times
        data = bytearray(path.read_bytes())
        data[100] ^= 0xFF
        with open(path, "r+b") as fh:
            fh.write(data)
        os.utime(path, ns=(1, 1))
    elif change == "replaced":
        (tmp_path / "other").write_bytes(path.read_bytes()[:-1] + b"\x01")
        os.replace(tmp_path / "other", path)
    elif change == "touched":
        os.utime(path, ns=(1, 1))
    else:
        path.unlink()
    assert written_sha256(path) is None
    if path.exists():
        assert file_sha256(path) == _on_disk(path)
        assert change == "touched" or file_sha256(path) != first


@pytest.mark.timeout(60)
def test_a_failed_write_is_not_remembered_and_only_meshes_are_hashed(tmp_path, mesh):
    path = tmp_path / "print.stl"

    def fails(fh):
        fh.write(b"half")
        raise OSError(28, "No space left on device")

    with pytest.raises(Exception):
        write_atomic(path, fails, remember_sha256=True)
    assert not path.exists() and written_sha256(path) is None
    text = write_atomic(tmp_path / "notes.txt", lambda fh: fh.write(b"text"))
    assert written_sha256(text) is None and file_sha256(text) == _on_disk(text)


@pytest.mark.timeout(120)
def test_only_the_latest_files_are_remembered(tmp_path):
    paths = [write_atomic(tmp_path / f"{k}.bin", lambda fh, k=k: fh.write(bytes([k % 256]) * 10), remember_sha256=True)
             for k in range(WRITTEN_REMEMBERED + 5)]
    assert [written_sha256(p) is not None for p in paths] == [False] * 5 + [True] * WRITTEN_REMEMBERED
    assert all(file_sha256(p) == _on_disk(p) for p in paths)
