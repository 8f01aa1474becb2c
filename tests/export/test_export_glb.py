"""export/glb.py: the NumPy GLB writer gives the bytes trimesh's exporter gave (it replaced it so that
a GLB convert need not import trimesh), and a glTF reader reads back the mesh it was given."""

from __future__ import annotations

import json
import struct

import numpy as np
import pygltflib
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import need_module, examples
from tamp_os import make_lithograph
from tamp_os.export.glb import glb_bytes, unit_normals

pytestmark = pytest.mark.timeout(300)


def _trimesh_glb(vertices, faces, normals) -> bytes:
    """What export/glb.py wrote before: trimesh's exporter on one unprocessed mesh."""
    trimesh = need_module("trimesh")
    from trimesh.exchange.gltf import export_glb

    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, vertex_normals=normals, process=False)
    return _zero_bounds_unsigned(export_glb(trimesh.Scene(mesh), include_normals=True))


def _zero_bounds_unsigned(glb: bytes) -> bytes:
    """trimesh's file with each accessor bound of -0.0 written 0.0, as ours are (numpy's strided
    min(axis=0) may return either zero), its JSON chunk padded again the way trimesh pads it."""
    json_length = int.from_bytes(glb[12:16], "little")
    tree = json.loads(glb[20:20 + json_length])
    for accessor in tree["accessors"]:
        for key in ("min", "max"):
            accessor[key] = [bound + 0 for bound in accessor[key]]
    content = json.dumps(tree, separators=(",", ":"))
    content += (4 - ((len(content) + 20) % 4)) * " "
    binary = glb[20 + json_length:]
    return struct.pack("<5I", 0x46546C67, 2, len(content) + len(binary) + 20, len(content), 0x4E4F534A) + content.encode() + binary


@st.composite
def meshes(draw):
    n_vertices = draw(st.integers(3, 200))
    n_faces = draw(st.integers(1, 300))
    seed = draw(st.integers(0, 2**32 - 1))
    scale = draw(st.sampled_from([1e-3, 1.0, 116.0, 1e5]))
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(n_vertices, 3)) * scale
    faces = rng.integers(0, n_vertices, size=(n_faces, 3))
    normals = rng.normal(size=(n_vertices, 3))
    normals[rng.random(n_vertices) < 0.1] = 0.0  # zero normals are left alone, not divided by zero
    if draw(st.booleans()):
        vertices = vertices.astype(np.float32)
    if draw(st.booleans()):
        normals = normals.astype(np.float32)
    if draw(st.integers(0, 4)) == 0:  # positions that are their own unit normals: one shared buffer view
        vertices = normals = np.eye(3)[rng.integers(0, 3, n_vertices)] * rng.choice([-1.0, 1.0], (n_vertices, 1))
    return vertices, faces, normals


@settings(max_examples=examples(150), deadline=None)
@given(meshes())
def test_same_bytes_as_trimesh_on_any_mesh(mesh):
    assert glb_bytes(*mesh) == _trimesh_glb(*mesh)


def test_a_zero_bound_is_unsigned_whichever_zero_the_column_holds():
    """The review's failure: a column holding 0.0 and -0.0; its bound must be +0.0 either way."""
    for column in ([0.0, -0.0, 1.0], [-0.0, 0.0, 1.0], [-0.0, -0.0, 1.0]):
        vertices = np.array([column, [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]]).T.copy()
        data = glb_bytes(vertices, np.array([[0, 1, 2]]), vertices)
        tree = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
        assert str(tree["accessors"][1]["min"][0]) == "0.0"


@pytest.mark.parametrize("mesher", ["grid", "adaptive"])
def test_same_bytes_as_trimesh_on_a_lithograph(mesher):
    img = np.zeros((30, 40), np.uint8)
    img[5:12, 5:30] = 255
    img[20:, 30:] = 120
    mesh = make_lithograph(img, width_mm=40, resolution_px=40, blur_px=0.5, relief_mm=2.0, mesher=mesher).mesh
    data = glb_bytes(mesh.vertices, mesh.faces, mesh.vertex_normals())
    assert data == _trimesh_glb(mesh.vertices, mesh.faces, mesh.vertex_normals())
    assert len(data) % 4 == 0 and int.from_bytes(data[8:12], "little") == len(data)


def test_a_reader_gets_the_mesh_back(tmp_path):
    rng = np.random.default_rng(7)
    vertices = rng.uniform(0, 100, size=(50, 3))
    faces = rng.integers(0, 50, size=(80, 3))
    normals = rng.normal(size=(50, 3))
    path = tmp_path / "m.glb"
    path.write_bytes(glb_bytes(vertices, faces, normals))
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()
    prim = gltf.meshes[0].primitives[0]

    def read(index, dtype, width):
        acc = gltf.accessors[index]
        view = gltf.bufferViews[acc.bufferView]
        start = view.byteOffset + (acc.byteOffset or 0)
        return np.frombuffer(blob, dtype, acc.count * width, start).reshape(acc.count, width) if width > 1 else \
            np.frombuffer(blob, dtype, acc.count, start)

    assert np.array_equal(read(prim.indices, np.uint32, 1).reshape(-1, 3), faces)
    assert np.array_equal(read(prim.attributes.POSITION, np.float32, 3), vertices.astype(np.float32))
    got = read(prim.attributes.NORMAL, np.float32, 3)
    assert np.allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-6)
    assert np.array_equal(got, unit_normals(normals))
    assert gltf.accessors[prim.attributes.POSITION].max == vertices.astype(np.float32).max(axis=0).tolist()


def test_an_empty_mesh_is_refused():
    with pytest.raises(ValueError):
        glb_bytes(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3)))
