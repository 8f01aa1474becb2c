"""3MF through lib3mf (the 3MF Consortium's library), with unit millimetre and metadata.

lib3mf's Python SetGeometry builds ctypes objects one vertex at a time (about 10 s for 2 M
triangles); its C function takes packed float32×3 / uint32×3 arrays, so we hand it numpy
buffers directly (about 0.01 s). UUIDs are derived from the content so the same input gives
the same bytes.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import locale
import hashlib
import os
import shutil
import tempfile
import uuid
import zipfile

import numpy as np


@functools.lru_cache(maxsize=1)
def _wrapper():
    import lib3mf

    return lib3mf.get_wrapper()


@contextlib.contextmanager
def _keep_locale():
    """lib3mf sets the process locale to "C" (for its number formatting) and leaves it so, which
    silently turns Python's default text encoding into ASCII. Put it back afterwards."""
    saved = locale.setlocale(locale.LC_ALL)
    try:
        yield
    finally:
        locale.setlocale(locale.LC_ALL, saved)


def xml_text(value) -> str:
    """`value` as text XML 1.0 can hold: characters it forbids (control characters other than tab,
    newline and return; lone surrogates; U+FFFE/U+FFFF) become U+FFFD. lib3mf escapes & < > itself."""
    return "".join(
        ch if ch in "\t\n\r" or ("\x20" <= ch <= "\ud7ff") or ("\ue000" <= ch <= "\ufffd") or ch >= "\U00010000" else "\ufffd"
        for ch in str(value)
    )


def write_3mf(mesh, fh, metadata: dict) -> None:
    with _keep_locale():
        _write_3mf(mesh, fh, metadata)


def _write_3mf(mesh, fh, metadata: dict) -> None:
    import lib3mf

    wrapper = _wrapper()
    model = wrapper.CreateModel()
    model.SetUnit(lib3mf.ModelUnit.MilliMeter)
    obj = model.AddMeshObject()
    obj.SetName(xml_text(metadata.get("title", "TAMP-OS lithograph")))
    seed = _set_geometry(obj, mesh.vertices, mesh.faces)
    obj.SetUUID(str(uuid.uuid5(seed, "object")))
    item = model.AddBuildItem(obj, wrapper.GetIdentityTransform())
    item.SetUUID(str(uuid.uuid5(seed, "item")))
    model.SetBuildUUID(str(uuid.uuid5(seed, "build")))
    settings = _add_print_settings(model, metadata)
    _finish(model, fh, metadata, unlinked_attachments=settings)


def _set_geometry(obj, vertices, faces) -> uuid.UUID:
    """Give a lib3mf mesh object its geometry from numpy buffers; return a UUID seed from the content.

    `vertices` is (n, 3) in mm, `faces` (m, 3) vertex indices.
    """
    import lib3mf

    wrapper = _wrapper()
    vertices = np.ascontiguousarray(vertices, dtype=np.float32)
    faces = np.ascontiguousarray(faces, dtype=np.uint32)
    wrapper.checkError(
        obj,
        wrapper.lib.lib3mf_meshobject_setgeometry(
            obj._handle,
            ctypes.c_uint64(len(vertices)),
            vertices.ctypes.data_as(ctypes.POINTER(lib3mf.Position)),
            ctypes.c_uint64(len(faces)),
            faces.ctypes.data_as(ctypes.POINTER(lib3mf.Triangle)),
        ),
    )
    digest = hashlib.sha256(vertices.tobytes() + faces.tobytes()).hexdigest()
    return uuid.UUID(digest[:32])


def _set_triangle_materials(obj, group_id: int, material_per_face: np.ndarray) -> None:
    """Give every triangle one base material (3MF core `pid`/`p1`), from a numpy buffer.

    lib3mf's Python SetAllTriangleProperties builds one ctypes struct per triangle; its C
    function takes packed (resource id, 3 property ids) uint32 records, so we hand it those.
    """
    import lib3mf

    wrapper = _wrapper()
    records = np.empty((len(material_per_face), 4), dtype=np.uint32)
    records[:, 0] = group_id
    records[:, 1:] = np.asarray(material_per_face, dtype=np.uint32)[:, None]
    wrapper.checkError(
        obj,
        wrapper.lib.lib3mf_meshobject_setalltriangleproperties(
            obj._handle,
            ctypes.c_uint64(len(records)),
            records.ctypes.data_as(ctypes.POINTER(lib3mf.TriangleProperties)),
        ),
    )


SLIC3R_MODEL_CONFIG = "/Metadata/Slic3r_PE_model.config"
SLIC3R_RELATIONSHIP = "http://schemas.slic3r.org/3mf/2017/06"
MODEL_RELATIONSHIPS = "3D/_rels/3dmodel.model.rels"
# The three .config parts are text (PrusaSlicer's model config XML, its print config lines, Bambu's JSON);
# OPC gives a content type per extension, so one that is true of all three.
CONFIG_CONTENT_TYPE = "text/plain"
# Contains "PrusaSlicer" (what Bambu Studio and OrcaSlicer look for) without starting with
# "PrusaSlicer-", which PrusaSlicer would read as the version of the PrusaSlicer that wrote it.
PRUSA_LAYOUT = "volumes in PrusaSlicer 3MF layout"


def write_3mf_parts(parts, fh, metadata: dict) -> None:
    """Several single-colour parts (tactile.parts.Part) as ONE object with one volume per part.

    The parts' triangles go into one mesh object, part after part (each part keeps its own
    vertices, so each stays a closed solid on its own). Two descriptions of the split ride along:
    every triangle names its part's base material (3MF core, read by any 3MF reader: name and
    display colour), and the attachment Metadata/Slic3r_PE_model.config (PrusaSlicer's own
    convention) cuts the object into volumes by triangle ranges and gives part k extruder k + 1.
    PrusaSlicer then loads one object with one part per colour; a components object instead
    falls apart into separate objects there.

    Bambu Studio and OrcaSlicer (not installable here, so read from their source, not run) load
    a 3MF with their own importer, which ignores this attachment and makes one part of a mesh
    object, unless the package looks like PrusaSlicer's: then they hand it to their copy of
    PrusaSlicer's importer, which reads the volumes. Their test (Model::read_from_archive,
    check_3mf_from_prusa) is: no 3D/_rels/3dmodel.model.rels in the package, and an Application
    metadata whose text contains "PrusaSlicer". So the attachment is stored without a
    relationship (as PrusaSlicer stores it) and the Application says whose layout this is.
    """
    with _keep_locale():
        _write_parts(parts, fh, metadata)


def _write_parts(parts, fh, metadata: dict) -> None:
    import lib3mf

    wrapper = _wrapper()
    model = wrapper.CreateModel()
    model.SetUnit(lib3mf.ModelUnit.MilliMeter)
    materials = model.AddBaseMaterialGroup()
    material_ids = [materials.AddMaterial(xml_text(p.label), wrapper.RGBAToColor(*p.colour_rgb, 255)) for p in parts]
    offsets = np.cumsum([0] + [len(p.mesh.vertices) for p in parts])
    vertices = np.concatenate([p.mesh.vertices for p in parts])
    faces = np.concatenate([np.asarray(p.mesh.faces, dtype=np.int64) + off for p, off in zip(parts, offsets)])
    face_counts = [len(p.mesh.faces) for p in parts]
    obj = model.AddMeshObject()
    title = xml_text(metadata.get("title", "TAMP-OS lithograph"))
    obj.SetName(title)
    seed = _set_geometry(obj, vertices, faces)
    obj.SetUUID(str(uuid.uuid5(seed, "object")))
    # The object-level material is the default the core spec asks for once triangles carry one.
    obj.SetObjectLevelProperty(materials.GetResourceID(), material_ids[0])
    _set_triangle_materials(obj, materials.GetResourceID(), np.repeat(material_ids, face_counts))
    item = model.AddBuildItem(obj, wrapper.GetIdentityTransform())
    item.SetUUID(str(uuid.uuid5(seed, "item")))
    model.SetBuildUUID(str(uuid.uuid5(seed, "build")))
    config = slic3r_model_config(obj.GetModelResourceID(), title, [p.label for p in parts], face_counts=face_counts)
    model.AddCustomContentType("config", CONFIG_CONTENT_TYPE)  # every package part needs a content type (OPC)
    model.AddAttachment(SLIC3R_MODEL_CONFIG, SLIC3R_RELATIONSHIP).ReadFromBuffer(list(config))
    _add_print_settings(model, metadata, content_type_added=True)
    application = f"{metadata.get('application', 'TAMP-OS')} ({PRUSA_LAYOUT})"
    _finish(model, fh, {**metadata, "application": application}, unlinked_attachments=True)


def _add_print_settings(model, metadata: dict, content_type_added: bool = False) -> bool:
    """Attach the print settings (metadata["print_settings"], an export.print_settings.PrintSettings) as
    PrusaSlicer's Metadata/Slic3r_PE.config and Bambu Studio / OrcaSlicer's Metadata/project_settings.config.
    Both slicers find them by name, so like the model config they go in without a relationship: a
    relationship from the model would make Bambu Studio and OrcaSlicer look for model parts in them.
    Returns whether anything was attached."""
    from ..printing.print_settings import BAMBU_PROJECT_SETTINGS, PRUSA_CONFIG

    settings = metadata.get("print_settings")
    if settings is None:
        return False
    if not content_type_added:
        model.AddCustomContentType("config", CONFIG_CONTENT_TYPE)
    model.AddAttachment(PRUSA_CONFIG, SLIC3R_RELATIONSHIP).ReadFromBuffer(list(settings.prusa_config()))
    model.AddAttachment(BAMBU_PROJECT_SETTINGS, SLIC3R_RELATIONSHIP).ReadFromBuffer(list(settings.bambu_project_settings()))
    return True


def slic3r_model_config(object_id: int, name: str, part_names: list[str], *, face_counts: list[int]) -> bytes:
    """PrusaSlicer's Metadata/Slic3r_PE_model.config for one object split into volumes.

    Volume k covers triangles sum(face_counts[:k]) .. sum(face_counts[:k + 1]) - 1 (inclusive)
    of object `object_id` (its id in the 3MF model), is a model part named part_names[k], and
    prints with extruder k + 1. PrusaSlicer refuses the whole file when a metadata element's
    type is neither "object" nor "volume", so every one carries it.
    """
    from xml.etree import ElementTree as ET

    root = ET.Element("config")
    obj = ET.SubElement(root, "object", id=str(object_id), instances_count="1")
    ET.SubElement(obj, "metadata", type="object", key="name", value=name)
    first = 0
    for k, (part_name, count) in enumerate(zip(part_names, face_counts)):
        volume = ET.SubElement(obj, "volume", firstid=str(first), lastid=str(first + count - 1))
        for key, value in (("name", xml_text(part_name)), ("volume_type", "ModelPart"), ("extruder", str(k + 1))):
            ET.SubElement(volume, "metadata", type="volume", key=key, value=value)
        first += count
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8", xml_declaration=False) + b"\n"


def _finish(model, fh, metadata: dict, unlinked_attachments: bool = False) -> None:
    """Add the metadata and write the model into `fh`; with `unlinked_attachments`, the
    attachments stay in the package without the relationships lib3mf gives them."""
    group = model.GetMetaDataGroup()
    for key in ("Title", "Description", "Designer", "Application"):
        value = metadata.get(key.lower())
        if value:
            group.AddMetaData("", key, xml_text(value), "string", True)
    # WriteToFile is about 3x faster than WriteToBuffer (which returns a Python list of ints),
    # so lib3mf writes a private temporary file that we then copy into the atomic output.
    with tempfile.TemporaryDirectory(prefix="tamp-3mf-") as tmp:
        path = os.path.join(tmp, "model.3mf")
        model.QueryWriter("3mf").WriteToFile(path)
        if unlinked_attachments:
            path = _without_model_relationships(path)
        with open(path, "rb") as src:
            shutil.copyfileobj(src, fh, 1 << 20)


def _without_model_relationships(path: str) -> str:
    """A copy of the package at `path` without 3D/_rels/3dmodel.model.rels (lib3mf writes it
    for every attachment; no 3MF reader needs it to find PrusaSlicer's config, which is read by
    name). Entries keep their order and timestamps, so the bytes stay reproducible."""
    out = path + ".unlinked"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            if info.filename != MODEL_RELATIONSHIPS:
                dst.writestr(info, src.read(info), compress_type=zipfile.ZIP_DEFLATED)
    return out
