"""Every format read back by an independent reader."""

import json
import subprocess

import lib3mf
import numpy as np
import pygltflib
import pytest
import trimesh

from tamp_os import make_lithograph
from tamp_os.export import save_mesh

from conftest import ROOT, need, node_validator


@pytest.fixture(scope="module", params=["grid", "adaptive"])
def litho(request):
    img = np.zeros((30, 40), np.uint8)
    img[5:12, 5:30] = 255
    img[20:, 30:] = 120
    return make_lithograph(img, width_mm=40, resolution_px=40, blur_px=0.5, relief_mm=2.0, mesher=request.param)


@pytest.fixture(scope="module")
def expected_volume(litho):
    return litho.mesh.volume_mm3()


@pytest.mark.parametrize("fmt", ["stl", "obj", "ply", "glb", "3mf"])
def test_trimesh_reads_a_closed_solid_of_the_right_size(tmp_path, litho, expected_volume, fmt):
    path = save_mesh(litho.mesh, tmp_path / f"x.{fmt}", litho.metadata())
    loaded = trimesh.load(path, force="mesh", process=True)
    assert loaded.is_watertight and loaded.is_winding_consistent
    assert loaded.volume == pytest.approx(expected_volume, rel=1e-5)
    np.testing.assert_allclose(loaded.bounds, litho.mesh.bounds_mm, atol=1e-4)


def test_writing_3mf_leaves_the_locale_alone(tmp_path, litho):
    import locale

    before = locale.setlocale(locale.LC_ALL)
    save_mesh(litho.mesh, tmp_path / "x.3mf", {})
    assert locale.setlocale(locale.LC_ALL) == before


def test_3mf_read_by_lib3mf_with_unit_and_metadata(tmp_path, litho):
    meta = dict(litho.metadata(), title="Gecko setae µm — Ünïcode")
    path = save_mesh(litho.mesh, tmp_path / "x.3mf", meta)
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(path))
    assert model.GetUnit() == lib3mf.ModelUnit.MilliMeter
    objects = model.GetMeshObjects()
    assert objects.MoveNext()
    mesh = objects.GetCurrentMeshObject()
    assert mesh.GetTriangleCount() == litho.mesh.n_triangles
    assert mesh.GetVertexCount() == len(litho.mesh.vertices)
    assert mesh.IsManifoldAndOriented()
    group = model.GetMetaDataGroup()
    values = {group.GetMetaData(i).GetName(): group.GetMetaData(i).GetValue() for i in range(group.GetMetaDataCount())}
    assert values["Title"] == "Gecko setae µm — Ünïcode"
    assert "raised" in values["Description"]
    with open(path, "rb") as fh:
        import zipfile

        xml = zipfile.ZipFile(fh).read("3D/3dmodel.model")
    assert xml.startswith(b'<?xml version="1.0" encoding="UTF-8"?>') or xml.startswith(b'<?xml version="1.0" encoding="utf-8"?>')
    assert b'unit="millimeter"' in xml


def test_glb_is_valid_gltf_indexed_with_normals(tmp_path, litho):
    path = save_mesh(litho.mesh, tmp_path / "x.glb", {})
    gltf = pygltflib.GLTF2().load(str(path))
    prim = gltf.meshes[0].primitives[0]
    assert prim.indices is not None and prim.attributes.NORMAL is not None
    assert gltf.accessors[prim.indices].count == 3 * litho.mesh.n_triangles
    data = path.read_bytes()
    json_len = int.from_bytes(data[12:16], "little")
    assert not data[20 : 20 + json_len].endswith(b"\x00")  # the reference pads JSON with NUL
    validator = node_validator()
    need(validator is not None, "the Khronos glTF validator (node + npm gltf-validator, installed by make setup)")
    out = subprocess.run(
        ["node", str(ROOT / "tests" / "gltf_validate.mjs"), str(path), str(validator)],
        capture_output=True, text=True, check=True,
    )
    report = json.loads(out.stdout)
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"][:5]
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"][:5]


def test_stl_header_and_count(tmp_path, litho):
    path = save_mesh(litho.mesh, tmp_path / "x.stl", {"title": "t"})
    data = path.read_bytes()
    assert len(data) == 84 + 50 * litho.mesh.n_triangles
    assert int.from_bytes(data[80:84], "little") == litho.mesh.n_triangles
    assert not data.startswith(b"solid")  # binary STL must not look like ASCII STL to readers
