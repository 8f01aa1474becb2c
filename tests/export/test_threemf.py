"""The 3MF writer (export/threemf.py) writes its package once; its files read, in lib3mf and
trimesh, as those lib3mf itself wrote (the writer before): the same vertices by position, the
same triangles, metadata, attachments and colours, and no relationship that points nowhere."""

from __future__ import annotations

import io
import shutil
import subprocess
import zipfile
from xml.etree import ElementTree as ET

import lib3mf
import numpy as np
import pytest
import trimesh
from conftest import examples, need
from hypothesis import given, settings
from hypothesis import strategies as st

from tamp_os.export.threemf import SLIC3R_MODEL_CONFIG, write_3mf, write_3mf_parts, xml_text
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.tactile.parts import Part
from threemf_support import SLIC3R_REL, one_mesh_object, parts_by_material, read_3mf

# Both print six decimals of the float32 coordinates; lib3mf rounds some last digits the other
# way, so a reader's float32 may differ by 1e-6 mm and two float32 steps (2.4e-7 of the value).
POSITION_MM, POSITION_REL = 1e-6, 2.4e-7


@pytest.fixture(scope="module")
def litho():
    image = np.random.default_rng(5).random((40, 60))
    image[10:25, 15:40] += 2.0
    return make_lithograph(image, width_mm=50, formats=("3mf",), caption="Test", pixel_size=0.5e-6)


def _lib3mf_package(mesh, metadata: dict, tmp_path, *, materials=None) -> bytes:
    """The same mesh written by lib3mf itself, with the same metadata and attachments (the old writer)."""
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    model.SetUnit(lib3mf.ModelUnit.MilliMeter)
    obj = model.AddMeshObject()
    obj.SetName(metadata.get("title", "TAMP-OS lithograph"))
    obj.SetGeometry(
        [lib3mf.Position(tuple(float(x) for x in v)) for v in np.asarray(mesh.vertices, np.float32)],
        [lib3mf.Triangle(tuple(int(i) for i in f)) for f in mesh.faces],
    )
    if materials is not None:
        group = model.AddBaseMaterialGroup()
        ids = [group.AddMaterial(name, wrapper.RGBAToColor(*rgb, 255)) for name, rgb, _ in materials]
        obj.SetObjectLevelProperty(group.GetResourceID(), ids[0])
        per_face = np.repeat(ids, [count for *_, count in materials])
        obj.SetAllTriangleProperties([lib3mf.TriangleProperties(group.GetResourceID(), (int(m),) * 3) for m in per_face])
    model.AddBuildItem(obj, wrapper.GetIdentityTransform())
    group = model.GetMetaDataGroup()
    for key in ("Title", "Description", "Designer", "Application"):
        if metadata.get(key.lower()):
            group.AddMetaData("", key, metadata[key.lower()], "string", True)
    model.AddCustomContentType("config", "text/plain")
    for name, data in _attachments(metadata):
        model.AddAttachment("/" + name, SLIC3R_REL).ReadFromBuffer(list(data))
    path = tmp_path / "lib3mf.3mf"
    model.QueryWriter("3mf").WriteToFile(str(path))
    return path.read_bytes()


def _attachments(metadata: dict) -> list[tuple[str, bytes]]:
    settings = metadata.get("print_settings")
    if settings is None:
        return []
    return [("Metadata/Slic3r_PE.config", settings.prusa_config()), ("Metadata/project_settings.config", settings.bambu_project_settings())]


def _read(data: bytes, tmp_path, name: str):
    path = tmp_path / name
    path.write_bytes(data)
    wrapper, model = read_3mf(path)
    obj = one_mesh_object(model)
    vertices = np.array([v.Coordinates[:] for v in obj.GetVertices()], dtype=np.float64)
    faces = np.array([t.Indices[:] for t in obj.GetTriangleIndices()], dtype=np.int64)
    group = model.GetMetaDataGroup()
    meta = {group.GetMetaData(i).GetName(): group.GetMetaData(i).GetValue() for i in range(group.GetMetaDataCount())}
    return path, model, obj, vertices, faces, meta


@pytest.mark.timeout(120)
def test_one_object_reads_as_lib3mf_wrote_it(litho, tmp_path):
    meta = dict(litho.metadata(), title='Gecko "setae" µm & <Ünïcode>')
    assert meta.get("print_settings") is not None  # the attachments are part of what is compared
    fh = io.BytesIO()
    write_3mf(litho.mesh, fh, meta)
    new = _read(fh.getvalue(), tmp_path, "new.3mf")
    old = _read(_lib3mf_package(litho.mesh, meta, tmp_path), tmp_path, "old.3mf")
    np.testing.assert_array_equal(new[4], old[4])
    np.testing.assert_allclose(new[3], old[3], rtol=POSITION_REL, atol=POSITION_MM)
    # and the new text is the better rounding of the mesh's own coordinates
    assert np.abs(new[3] - litho.mesh.vertices).max() <= np.abs(old[3] - litho.mesh.vertices).max()
    assert new[5] == old[5] and new[5]["Title"] == meta["title"]
    assert new[1].GetUnit() == lib3mf.ModelUnit.MilliMeter and new[2].GetName() == meta["title"]
    assert new[2].IsManifoldAndOriented()
    a, b = (trimesh.load(p[0], force="mesh", process=True) for p in (new, old))
    assert a.is_watertight and a.volume == pytest.approx(b.volume, rel=1e-6)
    np.testing.assert_allclose(a.bounds, b.bounds, rtol=POSITION_REL, atol=POSITION_MM)
    with zipfile.ZipFile(io.BytesIO(fh.getvalue())) as archive:
        for name, data in _attachments(meta):
            assert archive.read(name) == data


@pytest.mark.timeout(60)
def test_parts_read_with_their_materials_as_lib3mf_wrote_them(tmp_path):
    plate = trimesh.creation.box(extents=(30, 20, 2), transform=trimesh.transformations.translation_matrix((15, 10, 1)))
    bump = trimesh.creation.box(extents=(8, 8, 2), transform=trimesh.transformations.translation_matrix((15, 10, 3.1)))
    parts = [Part("base", "plate & <co>", plate, (245, 245, 240)), Part("raised", "bump", bump, (20, 30, 40))]
    fh = io.BytesIO()
    write_3mf_parts(parts, fh, {"title": "two boxes"})
    _, model, obj, vertices, faces, meta = _read(fh.getvalue(), tmp_path, "parts.3mf")
    assert meta["Application"].endswith("(volumes in PrusaSlicer 3MF layout)")
    by_material = parts_by_material(obj)
    assert len(by_material) == 2
    group = model.GetBaseMaterialGroupByID(obj.GetObjectLevelProperty()[0])
    for (mesh_read, idx), part, start in zip((by_material[k] for k in sorted(by_material)), parts, (0, len(plate.faces))):
        assert idx[0] == start and len(idx) == len(part.mesh.faces)
        assert mesh_read.volume == pytest.approx(part.mesh.volume, rel=1e-6)
    names = [group.GetName(p) for p in group.GetAllPropertyIDs()]
    colours = [group.GetDisplayColor(p) for p in group.GetAllPropertyIDs()]
    assert names == ["plate & <co>", "bump"]
    assert [(c.Red, c.Green, c.Blue, c.Alpha) for c in colours] == [(245, 245, 240, 255), (20, 30, 40, 255)]
    volumes = ET.fromstring(zipfile.ZipFile(io.BytesIO(fh.getvalue())).read("Metadata/Slic3r_PE_model.config")).iter("volume")
    assert [(v.get("firstid"), v.get("lastid")) for v in volumes] == [("0", "11"), ("12", "23")]


def _relationship_targets(archive: zipfile.ZipFile) -> list[str]:
    targets = []
    for name in archive.namelist():
        if name.endswith(".rels"):
            targets += [r.get("Target").lstrip("/") for r in ET.fromstring(archive.read(name))]
    return targets


@pytest.mark.timeout(60)
def test_package_is_valid_opc_with_no_dangling_relationship(litho):
    fh = io.BytesIO()
    write_3mf(litho.mesh, fh, litho.metadata())
    with zipfile.ZipFile(io.BytesIO(fh.getvalue())) as archive:
        assert archive.testzip() is None
        names = archive.namelist()
        assert "3D/_rels/3dmodel.model.rels" not in names  # the slicers' attachments are found by name
        targets = _relationship_targets(archive)
        assert targets == ["3D/3dmodel.model"] and all(t in names for t in targets)
        ns = "{http://schemas.openxmlformats.org/package/2006/content-types}"
        types = ET.fromstring(archive.read("[Content_Types].xml"))
        extensions = {d.get("Extension") for d in types.iter(f"{ns}Default")}
        assert all(n.rsplit(".", 1)[-1] in extensions for n in names if n != "[Content_Types].xml")
        assert all(info.date_time == (1980, 1, 1, 0, 0, 0) for info in archive.infolist())


@pytest.mark.timeout(120)
def test_size_close_to_the_old_writer_and_bytes_reproducible(litho, tmp_path):
    """Written once at zlib level 4 instead of lib3mf's package recompressed at level 6: at most 5 % larger."""
    meta = litho.metadata()
    fh, again = io.BytesIO(), io.BytesIO()
    write_3mf(litho.mesh, fh, meta)
    write_3mf(litho.mesh, again, meta)
    assert fh.getvalue() == again.getvalue()
    old = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(_lib3mf_package(litho.mesh, meta, tmp_path))) as src, zipfile.ZipFile(old, "w") as dst:
        for info in src.infolist():
            if info.filename != "3D/_rels/3dmodel.model.rels":  # what the old writer's second pass did
                dst.writestr(info, src.read(info), compress_type=zipfile.ZIP_DEFLATED)
    assert len(fh.getvalue()) <= 1.05 * len(old.getvalue())


# Any text: control characters, lone surrogates, XML's own characters, emoji, right-to-left.
HOSTILE_TEXT = st.text(st.characters(codec=None, exclude_categories=()), max_size=30) | st.sampled_from(
    ["& < > \" ' &amp; ]]> <!--", "\x00\x01\x07\x1b\ufffe\uffff", "😀🧬 שלום مرحبا", "x" * 5000, "\ud800 lone"]
)


def _random_mesh(seed: int, count: int, scale_mm: float):
    rng = np.random.default_rng(seed)
    vertices = rng.normal(size=(count, 3)) * scale_mm
    faces = np.array([rng.choice(count, 3, replace=False) for _ in range(count)])
    return trimesh.Trimesh(vertices, faces, process=False)


def _as_read(text: str, *, attribute: bool = False) -> str:
    """What an XML reader reads of `text` written as element text or an attribute: characters
    XML cannot hold as U+FFFD, a carriage return as a newline; in an attribute, tab and newline as spaces."""
    read = xml_text(text).replace("\r\n", "\n").replace("\r", "\n")
    return read.replace("\t", " ").replace("\n", " ") if attribute else read


@pytest.mark.timeout(120)
@settings(max_examples=examples(40), deadline=None)
@given(title=HOSTILE_TEXT, description=HOSTILE_TEXT, count=st.integers(3, 20), seed=st.integers(0, 2**31), scale_mm=st.sampled_from([1e-3, 1.0, 400.0]))
def test_any_metadata_and_mesh_read_back_intact(tmp_path_factory, title, description, count, seed, scale_mm):
    """lib3mf reads every mesh exactly and every metadata text as an XML reader (ElementTree, and
    PrusaSlicer's expat) reads it, without a warning: the readers agree."""
    mesh = _random_mesh(seed, count, scale_mm)
    fh = io.BytesIO()
    write_3mf(mesh, fh, {"title": title, "description": description})
    _, model, obj, vertices, faces, meta = _read(fh.getvalue(), tmp_path_factory.mktemp("h"), "h.3mf")
    np.testing.assert_array_equal(faces, mesh.faces)
    np.testing.assert_allclose(vertices, mesh.vertices.astype(np.float32), rtol=POSITION_REL, atol=POSITION_MM)
    assert meta.get("Title", "") == _as_read(title) and meta.get("Description", "") == _as_read(description)
    assert obj.GetName() == _as_read(title, attribute=True)
    with zipfile.ZipFile(io.BytesIO(fh.getvalue())) as archive:
        root = ET.fromstring(archive.read("3D/3dmodel.model"))
    ns = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
    assert {e.get("name"): e.text for e in root.findall(f"{ns}metadata")} == {k: v for k, v in meta.items() if k in ("Title", "Description")}
    assert root.find(f"{ns}resources/{ns}object").get("name") == obj.GetName()
    assert len(root.findall(f"{ns}resources/{ns}object/{ns}mesh/{ns}triangles/{ns}triangle")) == len(mesh.faces)


@pytest.mark.timeout(60)
def test_line_breaks_and_tabs_read_the_same_in_lib3mf_and_an_xml_reader(tmp_path):
    """A carriage return, CR LF, tab and newline in the title: lib3mf (which does not normalise
    XML's line ends or attribute values) reads what ElementTree and PrusaSlicer read."""
    title = "a\r\nb\tc\nd\re"
    fh = io.BytesIO()
    write_3mf(trimesh.creation.box(), fh, {"title": title, "description": title})
    _, _, obj, _, _, meta = _read(fh.getvalue(), tmp_path, "breaks.3mf")
    assert meta["Title"] == meta["Description"] == "a\nb\tc\nd\ne"
    assert obj.GetName() == "a b c d e"
    root = ET.fromstring(zipfile.ZipFile(io.BytesIO(fh.getvalue())).read("3D/3dmodel.model"))
    ns = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
    assert [e.text for e in root.findall(f"{ns}metadata")] == [meta["Title"], meta["Description"]]
    assert root.find(f"{ns}resources/{ns}object").get("name") == obj.GetName()


def _two_parts():
    plate = trimesh.creation.box(extents=(30, 20, 2), transform=trimesh.transformations.translation_matrix((15, 10, 1)))
    bump = trimesh.creation.box(extents=(8, 8, 2), transform=trimesh.transformations.translation_matrix((15, 10, 3)))
    return [Part("base", 'plate & <co> "x"\n', plate, (245, 245, 240)), Part("raised", "\x01 bump 😀", bump, (20, 30, 40))]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("kind", ["one mesh", "parts"])
def test_every_package_part_has_a_content_type_and_every_relationship_a_target(litho, kind):
    meta = dict(litho.metadata(), title='A & <b> "c"')
    fh = io.BytesIO()
    (write_3mf(litho.mesh, fh, meta) if kind == "one mesh" else write_3mf_parts(_two_parts(), fh, meta))
    with zipfile.ZipFile(io.BytesIO(fh.getvalue())) as archive:
        names = archive.namelist()
        assert len(names) == len(set(names)) and {"3D/3dmodel.model", "[Content_Types].xml", "_rels/.rels"} <= set(names)
        ns = "{http://schemas.openxmlformats.org/package/2006/content-types}"
        types = ET.fromstring(archive.read("[Content_Types].xml"))
        extensions = {d.get("Extension").lower() for d in types.iter(f"{ns}Default")}
        assert all(n.rsplit(".", 1)[-1].lower() in extensions for n in names if n != "[Content_Types].xml")
        assert all(t in names for t in _relationship_targets(archive))
        for name in names:
            if name.endswith((".rels", ".model", ".xml")) or name == SLIC3R_MODEL_CONFIG:
                ET.fromstring(archive.read(name))  # well-formed
    expected = 2 + (kind == "parts")
    assert sum(n.startswith("Metadata/") for n in names) == expected  # the print settings (Prusa and Bambu) and the volumes


@pytest.mark.timeout(300)
def test_prusaslicer_reads_parts_with_hostile_names_and_slices_them(litho, tmp_path):
    """PrusaSlicer's own reader (--info) and its slicer take a two-part file with XML-hostile names."""
    need(shutil.which("prusa-slicer") is not None, "PrusaSlicer (apt-get install prusa-slicer)")
    parts = _two_parts()
    path = tmp_path / "hostile.3mf"
    with path.open("wb") as fh:
        write_3mf_parts(parts, fh, dict(litho.metadata(), title='A & <b> "c" \x02 😀 שלום', description="x" * 5000))
    done = subprocess.run(["prusa-slicer", "--info", str(path)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    info = dict(tuple(s.strip() for s in line.split("=", 1)) for line in done.stdout.splitlines() if "=" in line)
    assert info["manifold"] == "yes" and int(info["number_of_facets"]) == sum(len(p.mesh.faces) for p in parts)
    assert float(info["size_x"]) == pytest.approx(30.0) and float(info["max_z"]) == pytest.approx(4.0)
    gcode = tmp_path / "hostile.gcode"
    done = subprocess.run(["prusa-slicer", "--export-gcode", "--output", str(gcode), str(path)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and gcode.stat().st_size > 0, done.stderr[-2000:]


@pytest.mark.timeout(60)
def test_model_written_in_pieces_is_the_model_compressed_whole(monkeypatch):
    """The model is formatted and compressed a few rows at a time: the package is the same
    bytes, and its model the same text, as with one piece."""
    from tamp_os.export import threemf

    rng = np.random.default_rng(7)
    vertices = rng.normal(size=(500, 3)) * 50
    parts = [Part(name, name, trimesh.Trimesh(vertices, rng.integers(0, 500, (n, 3)), process=False), rgb)
             for n, name, rgb in ((300, "base", (10, 20, 30)), (41, "dots", (200, 0, 0)), (5, "key", (0, 0, 255)))]
    with monkeypatch.context() as whole_model:  # as for a model near Zip64's limit: joined, then compressed whole
        whole_model.setattr(threemf, "_body_bytes_max", lambda *args: zipfile.ZIP64_LIMIT)
        whole = io.BytesIO()
        write_3mf_parts(parts, whole, {"title": "pieces"})
    monkeypatch.setattr(threemf, "CHUNK_ROWS", 7)
    pieces = io.BytesIO()
    write_3mf_parts(parts, pieces, {"title": "pieces"})
    assert pieces.getvalue() == whole.getvalue()
    with zipfile.ZipFile(pieces) as archive:
        model = archive.read("3D/3dmodel.model").decode()
    written = np.array([[float(x) for x in line.split('"')[1:6:2]] for line in model.splitlines() if line.startswith("<vertex ")])
    np.testing.assert_array_equal(written, np.round(np.concatenate([vertices] * 3).astype(np.float32).astype(np.float64), 6))
    assert model.count("<triangle ") == 346 and model.count(' p1="2"') == 5


@pytest.mark.timeout(60)
@pytest.mark.parametrize("where", ["formatting", "compressing"])
def test_a_write_stopped_between_pieces_leaves_no_file_and_no_thread(monkeypatch, tmp_path, where):
    """Ctrl-C while the model is being formatted or an error while a piece is being compressed:
    no 3MF, no temporary file beside it, no writer thread left (should one compress again), and
    the error reaches the caller."""
    import threading

    from tamp_os.export import threemf
    from tamp_os.export.files import write_atomic

    rng = np.random.default_rng(11)
    mesh = trimesh.Trimesh(rng.normal(size=(200, 3)) * 30, rng.integers(0, 200, (300, 3)), process=False)
    monkeypatch.setattr(threemf, "CHUNK_ROWS", 16)
    calls = []
    if where == "formatting":
        fmt = threemf._vertices_xml
        monkeypatch.setattr(threemf, "_vertices_xml", lambda v: calls.append(1) or (fmt(v) if len(calls) != 4 else (_ for _ in ()).throw(_Stopped)))
        expected = _Stopped
    else:
        pieces = threemf._model_pieces
        monkeypatch.setattr(threemf, "_model_pieces", lambda *a: _with_a_bad_piece(pieces(*a), calls))
        expected = TypeError
    target = tmp_path / "print.3mf"
    with pytest.raises(expected):
        write_atomic(target, lambda fh: write_3mf(mesh, fh, {"title": "stopped"}))
    assert list(tmp_path.iterdir()) == []
    assert not [t for t in threading.enumerate() if t.name.startswith("tamp-3mf")]
    write_atomic(target, lambda fh: write_3mf(mesh, fh, {"title": "stopped"}))  # the next write is whole
    assert zipfile.ZipFile(target).testzip() is None


class _Stopped(BaseException):
    """What Ctrl-C raises (a BaseException, not an Exception), without stopping the test run."""


def _with_a_bad_piece(pieces, calls):
    """The model's pieces with None as the fourth, once: zipfile's entry raises TypeError writing it."""
    for k, piece in enumerate(pieces):
        if k == 3 and not calls:
            calls.append(1)
            yield None
        yield piece


def _package(mesh_or_parts, *, threaded: bool, chunk_rows: int, whole: bool = False) -> bytes:
    """The 3MF of a mesh (or of parts) with the model formatted CHUNK_ROWS at a time and compressed
    beside the formatting (`threaded`) or in this thread, or joined and compressed whole."""
    from tamp_os.export import threemf

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(threemf, "CHUNK_ROWS", chunk_rows)
        if whole:  # as for a model near Zip64's limit: joined, then compressed in one call
            patch.setattr(threemf, "_body_bytes_max", lambda *args: zipfile.ZIP64_LIMIT)
        patch.setenv("TAMP_THREADS", "0" if threaded else "1")
        out = io.BytesIO()
        if isinstance(mesh_or_parts, list):
            write_3mf_parts(mesh_or_parts, out, {"title": "pipeline"})
        else:
            write_3mf(mesh_or_parts, out, {"title": "pipeline"})
    return out.getvalue()


@pytest.mark.timeout(300)
@settings(max_examples=examples(40))
@given(n_vertices=st.integers(0, 300), n_faces=st.integers(0, 400), chunk_rows=st.integers(1, 64),
       scale=st.sampled_from([1e-3, 1.0, 250.0, 1e6]), seed=st.integers(0, 2**16), parts=st.booleans())
def test_compressed_beside_the_formatting_is_the_same_package(n_vertices, n_faces, chunk_rows, scale, seed, parts):
    """Any mesh (none, one triangle, indices past the vertices), any piece size, one object or
    parts: compressing on a helper thread gives the bytes of compressing in this thread and of
    compressing the model whole; and the model's lines are what Python's '%.6f' and '%d' write."""
    rng = np.random.default_rng(seed)
    vertices = (rng.normal(size=(n_vertices, 3)) * scale).astype(np.float32)
    faces = rng.integers(0, max(n_vertices, 1) + (seed % 3 == 0), (n_faces, 3))  # now and then an index past the last vertex
    mesh = trimesh.Trimesh(vertices, faces, process=False, validate=False)
    subject = [Part("base", "base", mesh, (1, 2, 3)), Part("dots", "dots", trimesh.Trimesh(vertices[:1], faces[:1] * 0, process=False), (4, 5, 6))] if parts else mesh
    threaded = _package(subject, threaded=True, chunk_rows=chunk_rows)
    assert threaded == _package(subject, threaded=False, chunk_rows=chunk_rows)
    assert threaded == _package(subject, threaded=False, chunk_rows=1 << 13, whole=True)
    model = zipfile.ZipFile(io.BytesIO(threaded)).read("3D/3dmodel.model").decode()
    if not parts:
        assert "".join(line + "\n" for line in model.splitlines() if line.startswith("<vertex ")) == "".join(
            '<vertex x="%.6f" y="%.6f" z="%.6f"/>\n' % tuple(v) for v in vertices.astype(np.float64).tolist())
        assert "".join(line + "\n" for line in model.splitlines() if line.startswith("<triangle ")) == "".join(
            '<triangle v1="%d" v2="%d" v3="%d"/>\n' % tuple(f) for f in faces.tolist())


@pytest.mark.timeout(60)
def test_coordinates_numpy_does_not_write_are_written_by_python():
    """inf, nan and coordinates beyond decimal_text's exact range: the same text as '%.6f'."""
    vertices = np.array([[np.inf, -np.inf, np.nan], [3e10, -1e12, 0.5], [1.0, 2.0, 3.0]], dtype=np.float32)
    mesh = trimesh.Trimesh(vertices, [[0, 1, 2]], process=False, validate=False)
    data = _package(mesh, threaded=True, chunk_rows=2)
    model = zipfile.ZipFile(io.BytesIO(data)).read("3D/3dmodel.model").decode()
    assert [line for line in model.splitlines() if line.startswith("<vertex ")] == [
        '<vertex x="%.6f" y="%.6f" z="%.6f"/>' % tuple(v) for v in vertices.astype(np.float64).tolist()]


@pytest.mark.timeout(60)
@pytest.mark.parametrize("fails_at", [0, 1, 5])
def test_a_helper_that_fails_stops_the_formatting_soon_and_leaves_no_thread(fails_at):
    """The helper's write raising (a full disk, a bug): the error reaches the caller at once, the
    pieces not yet made are never made (no hang on a full pipeline), and the helper is gone."""
    import threading

    from tamp_os.export.threemf import PIPELINE_DEPTH, write_in_order

    made, written = [], []

    def pieces():
        for k in range(1000):
            made.append(k)
            yield bytes([k % 256]) * 10

    def write(piece):
        if len(written) == fails_at:
            raise OSError("no space left")
        written.append(piece)

    with pytest.raises(OSError, match="no space"):
        write_in_order(write, pieces(), threaded=True)
    assert len(made) <= fails_at + PIPELINE_DEPTH + 2 and written == [bytes([k]) * 10 for k in range(fails_at)]
    assert not [t for t in threading.enumerate() if t.name.startswith("tamp-3mf")]


@pytest.mark.timeout(60)
def test_pieces_are_written_in_their_order():
    from tamp_os.export.threemf import write_in_order

    written: list[int] = []
    write_in_order(written.append, iter(range(500)), threaded=True)
    assert written == list(range(500))
