"""Exporters, chosen by file extension. Each writes a Mesh to an open binary file; the file
itself is opened by `files.write_atomic`."""

from __future__ import annotations

from pathlib import Path
from typing import BinaryIO, Callable

from ..errors import ParameterError
from ..files import write_atomic
from ..mesh.solid import Mesh

Writer = Callable[[Mesh, BinaryIO, dict], None]


def _registry() -> dict[str, Writer]:
    from . import glb, plain, step, stl, threemf

    return {
        "stl": stl.write_stl,
        "3mf": threemf.write_3mf,
        "glb": glb.write_glb,
        "obj": plain.write_obj,
        "ply": plain.write_ply,
        "step": step.write_step,
    }


def exporter_for(path: Path) -> Writer:
    ext = path.suffix.lower().lstrip(".")
    writers = _registry()
    if ext == "stp":
        ext = "step"
    if ext not in writers:
        raise ParameterError(f"{path}: no exporter for '.{ext}'; choose one of {', '.join('.' + k for k in writers)}.")
    return writers[ext]


def save_mesh(mesh: Mesh, path, metadata: dict | None = None) -> Path:
    """Write `mesh` to `path` in the format its extension names (metadata: title, description)."""
    path = Path(path)
    writer = exporter_for(path)
    return write_atomic(path, lambda fh: writer(mesh, fh, metadata or {}))
