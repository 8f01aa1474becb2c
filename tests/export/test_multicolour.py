"""Two-colour prints (issue 15.2): read back with lib3mf and trimesh, checked with manifold3d booleans."""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from xml.etree import ElementTree as ET

import lib3mf
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings, strategies as st

from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.params import LithoParams
from tamp_os.errors import ParameterError
from conftest import need, examples
from threemf_support import SLIC3R_REL, one_mesh_object, parts_by_material, read_3mf


@pytest.fixture(scope="module")
def two_colour(tmp_path_factory):
    image = np.random.default_rng(3).random((60, 90))
    litho = make_lithograph(image, width_mm=60, caption="⠠⠞⠑⠎⠞", frame_mm=1.5, multicolour=True, formats=("stl", "3mf", "glb"))
    folder = tmp_path_factory.mktemp("two")
    litho.save(folder, stem="p")
    return litho, folder


def _volumes_config(path) -> ET.Element:
    """PrusaSlicer's volume ranges, read from the package by name (as PrusaSlicer reads them)."""
    with zipfile.ZipFile(path) as archive:
        return ET.fromstring(archive.read("Metadata/Slic3r_PE_model.config"))


def _manifold(mesh: trimesh.Trimesh):
    import manifold3d as m3

    return m3.Manifold(m3.Mesh(vert_properties=np.asarray(mesh.vertices, dtype=np.float32), tri_verts=np.asarray(mesh.faces, dtype=np.uint32)))


@pytest.mark.timeout(120)
def test_3mf_is_one_object_of_two_coloured_closed_parts(two_colour):
    litho, folder = two_colour
    wrapper, model = read_3mf(folder / "p.3mf")
    assert model.GetUnit() == lib3mf.ModelUnit.MilliMeter
    obj = one_mesh_object(model)
    assert model.GetMeshObjects().Count() == 1
    # Two materials of different colours; every triangle is one of them.
    groups = model.GetBaseMaterialGroups()
    assert groups.MoveNext()
    group = groups.GetCurrentBaseMaterialGroup()
    ids = group.GetAllPropertyIDs()
    assert len(ids) == 2
    assert len({wrapper.ColorToRGBA(group.GetDisplayColor(i)) for i in ids}) == 2
    parts = parts_by_material(obj)
    assert set(parts) == set(ids)
    for mat, (mesh, _) in parts.items():
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0, group.GetName(mat)
    assert [group.GetName(i) for i in ids] == [p.label for p in litho.parts]


@pytest.mark.timeout(120)
def test_prusaslicer_volumes_match_the_materials(two_colour):
    litho, folder = two_colour
    _, model = read_3mf(folder / "p.3mf")
    obj = one_mesh_object(model)
    parts = parts_by_material(obj)
    config = _volumes_config(folder / "p.3mf")
    (entry,) = config.findall("object")
    assert int(entry.get("id")) == obj.GetModelResourceID()
    volumes = entry.findall("volume")
    assert len(volumes) == 2
    metas = [{m.get("key"): (m.get("type"), m.get("value")) for m in v.findall("metadata")} for v in volumes]
    covered = 0
    for volume, meta, (_, idx) in zip(volumes, metas, [parts[k] for k in sorted(parts)]):
        first, last = int(volume.get("firstid")), int(volume.get("lastid"))
        assert np.array_equal(idx, np.arange(first, last + 1))  # the range is exactly that material's triangles
        covered += last - first + 1
        assert all(kind == "volume" for kind, _ in meta.values())  # PrusaSlicer refuses any other type
        assert meta["volume_type"][1] == "ModelPart"
    assert covered == obj.GetTriangleCount()
    assert [int(m["extruder"][1]) for m in metas] == [1, 2]
    assert [m["name"][1] for m in metas] == [p.label for p in litho.parts]


@pytest.mark.timeout(60)
def test_bambu_studio_and_orcaslicer_take_it_as_a_prusaslicer_3mf(two_colour):
    """Bambu Studio and OrcaSlicer cannot be installed here. Their source (Model::read_from_archive,
    PrusaFileParser::check_3mf_from_prusa) sends a 3MF to their copy of PrusaSlicer's importer,
    the one that reads the volume ranges, only when the package has no 3D/_rels/3dmodel.model.rels
    and an Application metadata whose text contains "PrusaSlicer"; otherwise their own importer
    makes one part of a mesh object. This checks those conditions on the bytes written."""
    _, folder = two_colour
    with zipfile.ZipFile(folder / "p.3mf") as archive:
        names = archive.namelist()
        assert "3D/_rels/3dmodel.model.rels" not in names and "Metadata/Slic3r_PE_model.config" in names
        types = ET.fromstring(archive.read("[Content_Types].xml"))
        rels = ET.fromstring(archive.read("_rels/.rels"))
        model = ET.fromstring(archive.read("3D/3dmodel.model"))
    # Every package part still has a content type, and the package points at the model only.
    assert "config" in {d.get("Extension") for d in types if d.tag.endswith("Default")}
    assert [r.get("Target") for r in rels] == ["/3D/3dmodel.model"]
    core = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
    application = {m.get("name"): m.text for m in model.findall(f"{core}metadata")}["Application"]
    assert "PrusaSlicer" in application and application.startswith("TAMP-OS ")
    # Not "PrusaSlicer-x" (PrusaSlicer would take it for its own version) nor "BambuStudio-x".
    assert not application.startswith(("PrusaSlicer-", "BambuStudio-"))
    assert not any(ch in application for ch in "&<>")  # one run of text: the check reads it unsplit


@pytest.mark.timeout(120)
def test_parts_do_not_overlap_and_make_the_one_colour_print(two_colour):
    litho, folder = two_colour
    _, model = read_3mf(folder / "p.3mf")
    (_, (base, _)), (_, (raised, _)) = sorted(parts_by_material(one_mesh_object(model)).items())
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


def _prusa(*args: str) -> str:
    need(shutil.which("prusa-slicer") is not None, "prusa-slicer")
    out = subprocess.run(["prusa-slicer", *args], capture_output=True, text=True, timeout=150)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


def _info_blocks(stdout: str) -> list[dict[str, str]]:
    """`prusa-slicer --info` output: one dict of key = value per [file] block (one per object)."""
    blocks = []
    for line in stdout.splitlines():
        if line.startswith("[") and line.endswith("]"):
            blocks.append({})
        elif "=" in line and blocks:
            key, value = line.split("=", 1)
            blocks[-1][key.strip()] = value.strip()
    return blocks


@pytest.mark.timeout(160)
def test_prusaslicer_loads_one_object_of_two_closed_parts(two_colour):
    litho, folder = two_colour
    # --info prints one [file] block per object; its number_of_parts counts connected shells (every
    # braille dot is one), not volumes, so the volumes are read from PrusaSlicer's own re-export below.
    (info,) = _info_blocks(_prusa("--info", str(folder / "p.3mf")))
    assert info["manifold"] == "yes"
    _, model = read_3mf(folder / "p.3mf")
    parts = parts_by_material(one_mesh_object(model))
    assert float(info["volume"]) == pytest.approx(sum(m.volume for m, _ in parts.values()), rel=1e-4)


@pytest.mark.timeout(160)
def test_prusaslicer_keeps_two_named_volumes_on_extruders_1_and_2(two_colour, tmp_path):
    litho, folder = two_colour
    again = tmp_path / "again.3mf"
    _prusa("--export-3mf", "--dont-arrange", "-o", str(again), str(folder / "p.3mf"))
    with zipfile.ZipFile(again) as archive:
        config = ET.fromstring(archive.read("Metadata/Slic3r_PE_model.config"))
    (entry,) = config.findall("object")
    volumes = entry.findall("volume")
    metas = [{m.get("key"): m.get("value") for m in v.findall("metadata")} for v in volumes]
    assert [m["name"] for m in metas] == [p.label for p in litho.parts]
    assert [m["extruder"] for m in metas] == ["1", "2"]
    assert [m["volume_type"] for m in metas] == ["ModelPart", "ModelPart"]
    for volume in volumes:  # PrusaSlicer had nothing to repair in either part
        stats = volume.find("mesh").attrib
        assert all(int(stats[k]) == 0 for k in ("edges_fixed", "degenerate_facets", "facets_removed", "facets_reversed", "backwards_edges"))


@pytest.mark.timeout(160)
def test_prusaslicer_prints_each_part_with_its_own_extruder(tmp_path):
    """Two boxes of known volumes, sliced on a two-extruder printer: each extruder prints one part."""
    from tamp_os.export.threemf import write_3mf_parts
    from tamp_os.tactile.parts import Part

    plate = trimesh.creation.box(extents=(30, 20, 2), transform=trimesh.transformations.translation_matrix((15, 10, 1)))
    bump = trimesh.creation.box(extents=(8, 8, 2), transform=trimesh.transformations.translation_matrix((15, 10, 3)))
    parts = [Part("base", "plate", plate, (245, 245, 245)), Part("raised", "bump", bump, (20, 20, 20))]
    path = tmp_path / "two.3mf"
    with open(path, "wb") as fh:
        write_3mf_parts(parts, fh, {"title": "two boxes"})
    gcode = tmp_path / "two.gcode"
    _prusa("--export-gcode", "--nozzle-diameter", "0.4,0.4", "--center", "100,100", "-o", str(gcode), str(path))
    text = gcode.read_text()
    lines = text.splitlines()
    assert "T0" in lines and "T1" in lines
    used = [float(v) for v in text.split("; filament used [cm3] =")[1].splitlines()[0].split(",")]
    # The plate (1200 mm³) and the bump (128 mm³) each come from one extruder (infill below 100 % prints less).
    assert len(used) == 2 and used[0] > 3 * used[1] > 0


@pytest.mark.timeout(60)
@settings(max_examples=examples(60), deadline=None)
@given(
    counts=st.lists(st.integers(1, 10**7), min_size=1, max_size=6),
    names=st.lists(st.text(max_size=20), min_size=6, max_size=6),
    object_id=st.integers(1, 10**6),
)
def test_slic3r_config_ranges_cover_every_triangle_once(counts, names, object_id):
    from tamp_os.export.threemf import slic3r_model_config, xml_text

    config = ET.fromstring(slic3r_model_config(object_id, xml_text(names[0]), names[: len(counts)], face_counts=counts))
    (entry,) = config.findall("object")
    assert entry.get("id") == str(object_id)
    assert all(m.get("type") in ("object", "volume") for m in config.iter("metadata"))
    volumes = entry.findall("volume")
    assert len(volumes) == len(counts)
    expected_first = 0
    for k, (volume, count) in enumerate(zip(volumes, counts)):
        first, last = int(volume.get("firstid")), int(volume.get("lastid"))
        assert first == expected_first and last - first + 1 == count
        expected_first = last + 1
        meta = {m.get("key"): m.get("value") for m in volume.findall("metadata")}
        assert meta["extruder"] == str(k + 1) and meta["name"] == xml_text(names[k])


@pytest.mark.timeout(60)
def test_one_part_is_one_volume_on_extruder_1(tmp_path):
    from tamp_os.export.threemf import write_3mf_parts
    from tamp_os.tactile.parts import Part

    plate = trimesh.creation.box(extents=(30, 20, 2), transform=trimesh.transformations.translation_matrix((15, 10, 1)))
    path = tmp_path / "one.3mf"
    with open(path, "wb") as fh:
        write_3mf_parts([Part("base", "plate", plate, (245, 245, 245))], fh, {"title": "one"})
    _, model = read_3mf(path)
    parts = parts_by_material(one_mesh_object(model))
    ((mesh, idx),) = parts.values()
    assert mesh.is_watertight and mesh.volume == pytest.approx(1200, rel=1e-6)
    (volume,) = _volumes_config(path).find("object").findall("volume")
    assert (int(volume.get("firstid")), int(volume.get("lastid"))) == (0, len(idx) - 1)


@pytest.mark.timeout(30)
def test_multicolour_with_tiles_is_refused():
    with pytest.raises(ParameterError, match="multicolour and bed_mm"):
        LithoParams(multicolour=True, bed_mm="120")


@pytest.mark.timeout(120)
def test_a_file_name_picks_the_format_of_a_two_colour_print_or_is_refused_clearly(two_colour, tmp_path):
    """NAME.stp (step's other suffix) writes the fused solid; a name whose suffix no format has
    (a folder meant as out/run1.5) is refused with one sentence naming it, before any file is
    written (both were an unexpected KeyError in the two-colour writer)."""
    litho = two_colour[0]
    written = litho.save(tmp_path / "print.stp")
    assert [p.name for p in written if p.suffix == ".stp"] == ["print.stp"]
    with pytest.raises(ParameterError, match=r"run1\.5.*no format is written as '\.5'.*\.3mf.*folder"):
        litho.save(tmp_path / "out" / "run1.5")
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
