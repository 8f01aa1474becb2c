"""Writing prints made of several solids: two-colour parts and bed-sized tiles.

- Two-colour (tactile.parts): 3MF gets one object with one volume per part (per-triangle base
  materials, and PrusaSlicer's volume ranges with extruders 1 and 2: threemf.write_3mf_parts);
  STL gets one file per part (NAME.base.stl, NAME.raised.stl); the other formats get the fused
  one-colour solid, as without the option.
- Tiles (tiles.Tiling): every format gets one file per tile, NAME.tile-R-C.FMT.

Every solid is checked as written (check_export) before the first file is.
"""

from __future__ import annotations

from pathlib import Path

from . import check_export, format_of, save_mesh
from .files import write_atomic


def split_formats(formats: list[str]) -> tuple[list[str], list[str]]:
    """(formats written per part, formats written as the fused solid) for a two-colour print."""
    from ..formats import by_suffix

    for f in formats:  # a format named by a file's suffix ('stp' is step); what no one writes is refused
        if by_suffix(f) is None:
            format_of(Path(f"print.{f}"))
    per_part = [f for f in formats if by_suffix(f).holds_parts]
    return per_part, [f for f in formats if f not in per_part]


def write_parts(parts, whole, folder: Path, *, stem: str, formats: list[str], meta: dict) -> list[Path]:
    """Write a two-colour print: see the module notes. `whole` is the fused Mesh."""
    from .threemf import write_3mf_parts

    per_part, fused = split_formats(formats)
    stl_paths = [(part.mesh, folder / f"{stem}.{part.name}.stl") for part in parts] if "stl" in per_part else []
    for part in parts:  # every part is a closed solid on its own, whatever the format
        check_export(part.mesh, [folder / f"{stem}.{part.name}.{fmt}" for fmt in per_part])
    if fused:
        check_export(whole, [folder / f"{stem}.{fmt}" for fmt in fused])
    written = [save_mesh(mesh, path, meta, checked=True) for mesh, path in stl_paths]
    if "3mf" in per_part:
        written.append(write_atomic(folder / f"{stem}.3mf", lambda fh: write_3mf_parts(parts, fh, meta)))
    written += [save_mesh(whole, folder / f"{stem}.{fmt}", meta, checked=True) for fmt in fused]
    return written


def tile_stem(stem: str, tile) -> str:
    """NAME.tile-R-C: row R from the far edge, column C from the left, both from 1."""
    return f"{stem}.tile-{tile.row}-{tile.col}"


def write_tiles(tiling, folder: Path, stem: str, *, formats: list[str], meta: dict) -> list[Path]:
    """Write every tile in every format, after checking them all."""
    for tile in tiling.tiles:
        check_export(tile.mesh, [folder / f"{tile_stem(stem, tile)}.{fmt}" for fmt in formats])
    return [
        save_mesh(tile.mesh, folder / f"{tile_stem(stem, tile)}.{fmt}", meta, checked=True)
        for tile in tiling.tiles
        for fmt in formats
    ]
