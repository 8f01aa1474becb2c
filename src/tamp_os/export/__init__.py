"""Exporters, chosen by file extension. Each writes a Mesh to an open binary file; the file
itself is opened by `files.write_atomic`.

Nothing is written unless everything can be: `check_export` runs the solid check on the mesh as
it will be written (float32 positions merged, as slicers read an STL) and every chosen format's
own check (STEP's size limit) first, and raises ExportError instead of writing a file. (A
lithograph's formats, lithograph/outputs.py, run the formats' checks first and the solid check
beside the writing, their files taking their names only once it has passed.)
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Callable, Iterable

from ..errors import ExportError, ParameterError
from .files import write_atomic
from ..mesh.solid import Mesh

Writer = Callable[[Mesh, BinaryIO, dict], None]


def _no_check(mesh: Mesh) -> None:
    """Formats that can hold any mesh."""


@dataclass(frozen=True)
class Exporter:
    """One format: `write(mesh, file, metadata)`, and `check(mesh)`, which raises ExportError
    when this format cannot hold the mesh (run before any file is written)."""

    write: Writer
    check: Callable[[Mesh], None] = _no_check


def _registry() -> dict[str, Exporter]:
    """Every mesh format of the format table (formats.py), with its writer and check."""
    from ..formats import MESH_FORMATS

    return {name: _exporter(name) for name in MESH_FORMATS}


@functools.lru_cache(maxsize=None)
def _exporter(name: str) -> Exporter:
    """One format's writer and check, imported only when that format is written (STEP's writer
    alone pulls in scipy.sparse)."""
    from ..formats import BY_NAME

    f = BY_NAME[name]
    return Exporter(f.write_function(), f.check_function() or _no_check)


def format_of(path: Path) -> str:
    """The mesh format a file name asks for ('stp' is 'step'); ParameterError if none writes it."""
    from ..formats import MESH_FORMATS, by_suffix

    found = by_suffix(Path(path).suffix or ".")
    if found is None or found.kind != "mesh":
        ext = Path(path).suffix.lower().lstrip(".")
        raise ParameterError(f"{path}: no exporter for '.{ext}'; choose one of {', '.join('.' + k for k in MESH_FORMATS)}.")
    return found.name


def exporter_for(path: Path) -> Writer:
    return _exporter(format_of(path)).write


def check_export(mesh: Mesh, paths: Iterable) -> None:
    """Raise ExportError unless `mesh` is a sound solid as written and every path's format can hold it.

    Run once before writing a set of files, so that a failure leaves no file at all.
    """
    paths = [Path(p) for p in paths]
    for path in paths:
        format_of(path)  # a name no format writes: that error first
    check_written_solid(mesh, paths)
    check_formats(mesh, paths)


def check_written_solid(mesh: Mesh, paths: Iterable) -> None:
    """check_export's first half: ExportError (naming the files) unless the mesh as a slicer
    reads it is a closed solid (mesh.validate.check_as_written)."""
    from ..mesh.validate import check_as_written

    check = check_as_written(mesh)
    if not check.ok:
        names = ", ".join(Path(p).name for p in paths)
        raise ExportError(
            f"{names}: the mesh is not a closed solid as a slicer reads it ({'; '.join(check.problems)}); "
            f"nothing was written. This is a fault in TAMP-OS, not in your input: please report it with the input and settings."
        )


def check_formats(mesh: Mesh, paths: Iterable) -> None:
    """check_export's second half: each path's format's own check (STEP's size limit); quick."""
    for exporter in {format_of(Path(p)): _exporter(format_of(Path(p))) for p in paths}.values():
        exporter.check(mesh)


def save_mesh(mesh: Mesh, path, metadata: dict | None = None, *, checked: bool = False,
              before_replace: Callable[[], None] | None = None) -> Path:
    """Write `mesh` to `path` in the format its extension names (metadata: title, description).

    The mesh is checked first (see check_export) unless `checked` says the caller already did
    (or does it meanwhile: `before_replace`, see files.write_atomic, waits for that check).
    """
    path = Path(path)
    writer = exporter_for(path)
    if not checked:
        check_export(mesh, [path])
    # The writers only write(): the file's SHA-256 comes along (the recipe lists it, lithograph/outputs.py).
    return write_atomic(path, lambda fh: writer(mesh, fh, metadata or {}), remember_sha256=True, before_replace=before_replace)
