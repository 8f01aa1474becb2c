"""Reading our 3MF files back with lib3mf: the one mesh object and its parts by material."""

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


SLIC3R_REL = "http://schemas.slic3r.org/3mf/2017/06"


def read_3mf(path):
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    reader = model.QueryReader("3mf")
    reader.AddRelationToRead(SLIC3R_REL)  # lib3mf reads attachments only of relationships it is told about
    reader.ReadFromFile(str(path))
    assert reader.GetWarningCount() == 0, [reader.GetWarning(i) for i in range(reader.GetWarningCount())]
    return wrapper, model


def one_mesh_object(model):
    """The only build item, which must be a mesh object (not components)."""
    items = model.GetBuildItems()
    assert items.MoveNext()
    resource = items.GetCurrent().GetObjectResource()
    assert resource.IsMeshObject() and not items.MoveNext()
    return model.GetMeshObjectByID(resource.GetResourceID())


def parts_by_material(obj) -> dict[int, tuple[trimesh.Trimesh, np.ndarray]]:
    """material id -> (the triangles of that material as a trimesh, their triangle indices), read through lib3mf."""
    vertices = np.array([v.Coordinates[:] for v in obj.GetVertices()], dtype=float)
    faces = np.array([t.Indices[:] for t in obj.GetTriangleIndices()], dtype=np.int64)
    group, default, has = obj.GetObjectLevelProperty()
    assert has, "the object names a default material"
    props = obj.GetAllTriangleProperties()
    material = np.array([p.PropertyIDs[0] if p.ResourceID else default for p in props], dtype=np.int64)
    assert all(p.ResourceID in (0, group) for p in props) and len(material) == len(faces)
    out = {}
    for mat in np.unique(material):
        idx = np.flatnonzero(material == mat)
        out[int(mat)] = (trimesh.Trimesh(vertices, faces[idx], process=True), idx)
    return out
