"""Text that reaches a file or a braille line is safe, big meshes take the threaded writers, GLB
normals point out, and the scale bar is right on a padded image. Issue 12 sections 4 and 7."""

import json
import struct
import zipfile
import xml.etree.ElementTree as ET

import lib3mf
import numpy as np
import pytest

from conftest import need

from tamp_os import make_lithograph
from tamp_os.errors import ParameterError
from tamp_os.export import save_mesh
from tamp_os.export.stl import CHUNK, STL_RECORD
from tamp_os.mesh.solid import grid_solid
from tamp_os.tactile.braille import liblouis_available, to_braille
from tamp_os.units import parse_length_m

HOSTILE = "Title\x07 with <tags> & \"quotes\" 'and' \x00 nul, emoji 😀, CJK 中文, RTL שלום \u202e"


@pytest.fixture(scope="module")
def small_mesh():
    return grid_solid(np.random.default_rng(0).random((12, 16)) + 1.0, 30.0, 20.0)


def lib3mf_metadata(path) -> dict:
    model = lib3mf.get_wrapper().CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(path))
    group = model.GetMetaDataGroup()
    return {group.GetMetaData(i).GetName(): group.GetMetaData(i).GetValue() for i in range(group.GetMetaDataCount())}


@pytest.mark.timeout(60)
def test_3mf_metadata_with_control_characters_is_well_formed_xml(tmp_path, small_mesh):
    meta = {"title": HOSTILE, "description": HOSTILE + "\nsecond line", "designer": "TAMP-OS"}
    path = save_mesh(small_mesh, tmp_path / "x.3mf", meta)
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("3D/3dmodel.model"))  # raises on malformed XML
    values = {el.get("name"): el.text for el in root.iter() if el.tag.endswith("metadata")}
    assert "\x07" not in values["Title"] and "\x00" not in values["Title"]
    for kept in ("<tags> & \"quotes\"", "😀", "中文", "שלום"):
        assert kept in values["Title"], kept
    assert lib3mf_metadata(path)["Title"] == values["Title"]


@pytest.mark.timeout(60)
def test_step_title_with_quotes_and_backslashes_stays_a_valid_string(tmp_path, small_mesh):
    path = save_mesh(small_mesh, tmp_path / "x.step", {"title": "it's a \\ back\\slash \x07 ünï"})
    text = path.read_text(encoding="ascii")
    header = next(line for line in text.splitlines() if line.startswith("FILE_DESCRIPTION"))
    inner = header[len("FILE_DESCRIPTION(('") : header.index("'),")]
    assert "'" not in inner and "\\" not in inner and all(" " <= c <= "~" for c in inner)


@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    "caption, named",
    [("smile 😀", "U+1F600"), ("中文 caption", "U+4E2D"), ("שלום", "U+05E9"), ("bell\x07", "U+0007"), ("zero\u200bwidth", "U+200B")],
)
def test_captions_the_braille_table_cannot_write_are_refused_by_name(caption, named):
    if not caption.isascii() or "\x07" not in caption:
        need(liblouis_available(), "liblouis")
    with pytest.raises(ParameterError, match="caption") as info:
        make_lithograph(np.eye(20), width_mm=40, caption=caption)
    assert named in str(info.value)


@pytest.mark.timeout(60)
def test_captions_the_table_can_write_still_work():
    need(liblouis_available(), "liblouis")
    assert to_braille("café 5 µm", "en-ueb-g1.ctb")  # accented Latin and µ are in UEB
    assert make_lithograph(np.eye(20), width_mm=40, caption="Café, 5 µm").report["tactile"]["caption_braille"]


@pytest.mark.timeout(180)
def test_stl_and_3mf_above_one_chunk_take_the_threaded_path_and_read_back(tmp_path):
    rows = cols = 520  # 2 × 519² top triangles: more than one 524,288-triangle chunk
    mesh = grid_solid(np.random.default_rng(1).random((rows, cols)) + 1.0, 100.0, 100.0)
    assert mesh.n_triangles > CHUNK
    stl = save_mesh(mesh, tmp_path / "big.stl", {"title": "big"})
    data = stl.read_bytes()
    count = struct.unpack("<I", data[80:84])[0]
    records = np.frombuffer(data, dtype=STL_RECORD, offset=84)
    assert count == len(records) == mesh.n_triangles
    np.testing.assert_array_equal(records["v"], mesh.vertices.astype(np.float32)[mesh.faces])  # every chunk in order
    model = lib3mf.get_wrapper().CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(save_mesh(mesh, tmp_path / "big.3mf", {"title": "big"})))
    objects = model.GetMeshObjects()
    assert objects.MoveNext()
    obj = objects.GetCurrentMeshObject()
    assert obj.GetTriangleCount() == mesh.n_triangles and obj.GetVertexCount() == len(mesh.vertices)


@pytest.mark.timeout(60)
def test_glb_normals_point_outward(tmp_path):
    import pygltflib

    litho = make_lithograph(np.random.default_rng(2).random((20, 24)), width_mm=40, resolution_px=24)
    path = save_mesh(litho.mesh, tmp_path / "x.glb", {})
    gltf = pygltflib.GLTF2().load(str(path))
    blob = gltf.binary_blob()

    def accessor(index, dtype, width):
        acc = gltf.accessors[index]
        view = gltf.bufferViews[acc.bufferView]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        return np.frombuffer(blob, dtype=dtype, count=acc.count * width, offset=start).reshape(acc.count, width)

    prim = gltf.meshes[0].primitives[0]
    positions = accessor(prim.attributes.POSITION, np.float32, 3).astype(np.float64)
    normals = accessor(prim.attributes.NORMAL, np.float32, 3).astype(np.float64)
    index_dtype = {5125: np.uint32, 5123: np.uint16}[gltf.accessors[prim.indices].componentType]
    faces = accessor(prim.indices, index_dtype, 1).reshape(-1, 3).astype(np.int64)  # a SCALAR accessor
    # outward: each vertex normal agrees with the area-weighted normals of its faces, which point
    # away from the solid (positive volume), and the bottom's normals point down, the top's up
    tri = positions[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    assert np.einsum("ij,ij->i", tri[:, 0], face_n).sum() > 0
    summed = np.zeros_like(positions)
    for k in range(3):
        np.add.at(summed, faces[:, k], face_n)
    assert (np.einsum("ij,ij->i", summed, normals) > 0).all()
    assert (normals[positions[:, 2] == 0, 2] < 0).all()
    top = positions[:, 2] == positions[:, 2].max()
    assert (normals[top, 2] > 0).all()


@pytest.mark.timeout(60)
@pytest.mark.parametrize("shape", [(40, 20), (20, 40)])
def test_scale_bar_on_an_image_padded_to_the_print(shape):
    need(liblouis_available(), "liblouis")
    # 1 µm pixels, padded to 40 × 40 source pixels over 80 mm: 0.5 µm per print millimetre
    image = np.random.default_rng(3).random(shape)
    litho = make_lithograph(image, width_mm=80, depth_mm=80, fit="pad", pixel_size="1um", resolution_px=40)
    tactile = litho.report["tactile"]
    x0, _, x1, _ = tactile["scale_bar_box_mm"]
    assert x1 - x0 == pytest.approx(parse_length_m(tactile["scale_bar_label"]) / (1e-6 * 40 / 80), rel=1e-9)
    assert json.dumps(litho.report["scale"])  # said in the report too
    assert "500 nm" in litho.report["scale"]
