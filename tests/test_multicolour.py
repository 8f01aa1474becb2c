"""Two-colour prints (issue 15.2): read back with lib3mf and trimesh, checked with manifold3d booleans."""

from __future__ import annotations

import shutil
import subprocess

import lib3mf
import numpy as np
import pytest
import trimesh

from tamp_os.pipeline import make_lithograph
from tamp_os.params import LithoParams
from tamp_os.errors import ParameterError
from conftest import need


@pytest.fixture(scope="module")
def two_colour(tmp_path_factory):
    image = np.random.default_rng(3).random((60, 90))
    litho = make_lithograph(image, width_mm=60, caption="⠠⠞⠑⠎⠞", frame_mm=1.5, multicolour=True, formats=("stl", "3mf", "glb"))
    folder = tmp_path_factory.mktemp("two")
    litho.save(folder, stem="p")
    return litho, folder


def _read_3mf(path):
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(path))
    return wrapper, model


def _meshes(model) -> list[tuple[str, trimesh.Trimesh, tuple]]:
    """(name, mesh, (material group id, material id)) of every mesh object, read through lib3mf."""
    out = []
    objects = model.GetMeshObjects()
    while objects.MoveNext():
        obj = objects.GetCurrentMeshObject()
        vertices = np.array([v.Coordinates[:] for v in obj.GetVertices()], dtype=float)
        faces = np.array([t.Indices[:] for t in obj.GetTriangleIndices()], dtype=np.int64)
        group, prop, has = obj.GetObjectLevelProperty()
        assert has, "each part names its material"
        out.append((obj.GetName(), trimesh.Trimesh(vertices, faces, process=True), (group, prop)))
    return out


def _manifold(mesh: trimesh.Trimesh):
    import manifold3d as m3

    return m3.Manifold(m3.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32), tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


@pytest.mark.timeout(120)
def test_3mf_has_one_object_of_two_coloured_closed_parts(two_colour):
    litho, folder = two_colour
    wrapper, model = _read_3mf(folder / "p.3mf")
    assert model.GetUnit() == lib3mf.ModelUnit.MilliMeter
    parts = _meshes(model)
    assert len(parts) == 2
    # One build item: a components object holding both parts.
    items = model.GetBuildItems()
    assert items.MoveNext()
    whole = items.GetCurrent().GetObjectResource()
    assert whole.IsComponentsObject() and not items.MoveNext()
    components = model.GetComponentsObjectByID(whole.GetResourceID())
    assert components.GetComponentCount() == 2
    # Two materials of different colours, one per part.
    groups = model.GetBaseMaterialGroups()
    assert groups.MoveNext()
    group = groups.GetCurrentBaseMaterialGroup()
    ids = group.GetAllPropertyIDs()
    assert len(ids) == 2
    colours = {wrapper.ColorToRGBA(group.GetDisplayColor(i)) for i in ids}
    assert len(colours) == 2
    assert {p[2][1] for p in parts} == set(ids)
    for name, mesh, _ in parts:
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, name


@pytest.mark.timeout(120)
def test_parts_do_not_overlap_and_make_the_one_colour_print(two_colour):
    litho, folder = two_colour
    _, model = _read_3mf(folder / "p.3mf")
    (_, base, _), (_, raised, _) = _meshes(model)
    a, b = _manifold(base), _manifold(raised)
    both = a + b
    assert (a ^ b).volume() < 1e-3
    assert both.volume() == pytest.approx(a.volume() + b.volume(), rel=1e-5)
    # Together they are the one-colour print (same volume, same bounds).
    single = trimesh.load(folder / "p.glb", force="mesh")
    assert both.volume() == pytest.approx(single.volume, rel=1e-4)
    assert raised.bounds[0][2] >= litho.params.base_mm - 0.01  # the raised part stands on the plate
    assert raised.bounds[1][2] > litho.params.base_mm + 0.5


@pytest.mark.timeout(120)
def test_stl_one_file_per_part_each_closed(two_colour):
    _, folder = two_colour
    assert not (folder / "p.stl").exists()
    volumes = []
    for name in ("base", "raised"):
        mesh = trimesh.load(folder / f"p.{name}.stl")
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, name
        volumes.append(mesh.volume)
    assert volumes[0] > 10 * volumes[1]


@pytest.mark.timeout(120)
def test_description_says_which_part_is_which(two_colour):
    litho, folder = two_colour
    text = (folder / "p.description.txt").read_text(encoding="utf-8")
    assert "Two-colour print" in text and "braille" in text


@pytest.mark.timeout(120)
def test_prusaslicer_reads_both_parts_as_closed(two_colour):
    need(shutil.which("prusa-slicer") is not None, "prusa-slicer")
    _, folder = two_colour
    out = subprocess.run(["prusa-slicer", "--info", str(folder / "p.3mf")], capture_output=True, text=True, timeout=120)
    assert out.stdout.count("manifold = yes") == 2 and "manifold = no" not in out.stdout


@pytest.mark.timeout(30)
def test_multicolour_with_tiles_is_refused():
    with pytest.raises(ParameterError, match="multicolour and bed_mm"):
        LithoParams(multicolour=True, bed_mm="120")
