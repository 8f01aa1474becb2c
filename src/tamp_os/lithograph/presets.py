"""The Low/Medium/High table for a printer and an image, before anything is made: grid, mm per
pixel, blur, height levels, triangles and estimated file sizes. Shared by `tamp-os presets` and the web app."""

from __future__ import annotations

from ..params import LithoParams
from .pipeline import make_lithograph
from .sizing import layout_for, resolve_printer
from ..printing.printers import ADAPTIVE_RATIO, PRESETS, estimate_file_bytes, grid_triangles, height_levels


def preset_rows(params: LithoParams, width_px: int = 4, height_px: int = 3, *, picture=None) -> list[dict]:
    """One row per preset. With a picture, the mesh is made for real, so the counts are exact."""
    printer = resolve_printer(params)
    if picture is not None:
        width_px, height_px = picture.file.width, picture.file.height
    rows = []
    for preset in PRESETS:
        layout = layout_for(params, printer, width_px, image_h_px=height_px, preset=preset)
        exact = picture is not None
        if exact:
            mesh = make_lithograph(picture, params.replace(preset=preset)).mesh
            tris, verts = mesh.n_triangles, len(mesh.vertices)
        else:
            tris = grid_triangles(layout.cols, layout.rows)
            verts = layout.cols * layout.rows + 2 * (layout.cols + layout.rows)
            if params.mesher == "adaptive":
                tris, verts = int(tris * ADAPTIVE_RATIO), int(verts * ADAPTIVE_RATIO)
        rows.append({
            "preset": preset,
            "cols": layout.cols,
            "rows": layout.rows,
            "mm_per_px": layout.mm_per_px,
            "blur_px": layout.blur_px,
            "width_mm": layout.width_mm,
            "depth_mm": layout.depth_mm,
            "height_levels": height_levels(params.relief_mm, printer.layer_mm),
            "triangles": tris,
            "exact": exact,
            "bytes": {fmt: estimate_file_bytes(fmt, tris, verts) for fmt in params.formats},
        })
    return rows


def megabytes(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n >= 1e5 else f"{n / 1e3:.0f} kB"


def size_words(bytes_by_format: dict[str, int | None], about: str = "") -> str:
    """'STL about 1.2 MB, PDF not estimated (a page, not a mesh)': a row's file sizes in words."""
    return ", ".join(f"{fmt.upper()} {about}{megabytes(n)}" if n is not None else f"{fmt.upper()} not estimated (a page, not a mesh)"
                     for fmt, n in bytes_by_format.items())
