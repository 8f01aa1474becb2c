"""Reading a mesh file a user names (estimate, slice, render, check): one clear error for anything
that is not a readable, finite, non-empty mesh, never a traceback or a figure computed from garbage."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..formats import READABLE_MESH_SUFFIXES as MESH_SUFFIXES


def read_mesh_file(path):
    """The mesh in `path` as a trimesh.Trimesh (vertices in the file's units, normally mm).

    Raises InputError naming the file and saying what is wrong: not a regular file, not a mesh
    format, unreadable, no faces, or coordinates that are not finite numbers.
    """
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file (or not a regular file); give a mesh such as NAME.stl.")
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise InputError(f"{path}: not a mesh file ({path.suffix or 'no extension'}); give one of {', '.join(MESH_SUFFIXES)}.")
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # trimesh raises many kinds for damaged files; all mean the same to the user
        raise InputError(f"{path}: cannot be read as a mesh ({exc.__class__.__name__}); is the file complete?") from None
    faces = getattr(mesh, "faces", None)
    if faces is None or len(faces) == 0:
        raise InputError(f"{path}: holds no triangles; nothing to measure or print.")
    if not np.isfinite(np.asarray(mesh.vertices)).all():
        raise InputError(f"{path}: some coordinates are not numbers (NaN or infinite); the file is damaged.")
    return mesh
