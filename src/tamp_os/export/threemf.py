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
    seed = _set_geometry(obj, mesh)
    obj.SetUUID(str(uuid.uuid5(seed, "object")))
    item = model.AddBuildItem(obj, wrapper.GetIdentityTransform())
    item.SetUUID(str(uuid.uuid5(seed, "item")))
    model.SetBuildUUID(str(uuid.uuid5(seed, "build")))
    _finish(model, fh, metadata)


def _set_geometry(obj, mesh) -> uuid.UUID:
    """Give a lib3mf mesh object the mesh's geometry from numpy buffers; return a UUID seed from the content."""
    import lib3mf

    wrapper = _wrapper()
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.uint32)
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


def write_3mf_parts(parts, fh, metadata: dict) -> None:
    """Several single-colour parts (tactile.parts.Part) as one object made of components.

    Each part is a mesh object with its own base material (name and display colour); one
    components object holds them all with identity transforms and is the only build item, so
    slicers (PrusaSlicer, Bambu Studio, OrcaSlicer) load one object with one volume per part,
    each of which can be given its own filament.
    """
    with _keep_locale():
        _write_parts(parts, fh, metadata)


def _write_parts(parts, fh, metadata: dict) -> None:
    import lib3mf

    wrapper = _wrapper()
    model = wrapper.CreateModel()
    model.SetUnit(lib3mf.ModelUnit.MilliMeter)
    materials = model.AddBaseMaterialGroup()
    whole = model.AddComponentsObject()
    seeds = []
    for part in parts:
        material = materials.AddMaterial(xml_text(part.label), wrapper.RGBAToColor(*part.colour_rgb, 255))
        obj = model.AddMeshObject()
        obj.SetName(xml_text(part.label))
        seeds.append(_set_geometry(obj, part.mesh))
        obj.SetUUID(str(uuid.uuid5(seeds[-1], "object-" + part.name)))
        obj.SetObjectLevelProperty(materials.GetResourceID(), material)
        component = whole.AddComponent(obj, wrapper.GetIdentityTransform())
        component.SetUUID(str(uuid.uuid5(seeds[-1], "component-" + part.name)))
    seed = uuid.uuid5(seeds[0], "".join(str(s) for s in seeds))
    whole.SetName(xml_text(metadata.get("title", "TAMP-OS lithograph")))
    whole.SetUUID(str(uuid.uuid5(seed, "object")))
    item = model.AddBuildItem(whole, wrapper.GetIdentityTransform())
    item.SetUUID(str(uuid.uuid5(seed, "item")))
    model.SetBuildUUID(str(uuid.uuid5(seed, "build")))
    _finish(model, fh, metadata)


def _finish(model, fh, metadata: dict) -> None:
    """Add the metadata and write the model into `fh`."""
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
        with open(path, "rb") as src:
            shutil.copyfileobj(src, fh, 1 << 20)
