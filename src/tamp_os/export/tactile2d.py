"""Write a Graphic2D as PDF or SVG at true size with cairo (pycairo), for swell paper and embossers.

Black is where the paper should swell or the embosser raise: region outlines and their textures,
braille as real dots of standard size, the scale bar with end ticks, an optional frame line, and a
diagonal line across the top-right corner (orientation; cut along it if you like). This is a
separate registry from the mesh exporters: a 2-D graphic needs a region map, braille and a page,
not a mesh.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import BinaryIO, Callable

import numpy as np

from ..errors import MissingDependencyError, ParameterError
from .files import write_atomic
from ..tactile.braille import dot_centres
from ..tactile.furniture import TICK_LENGTH_MM
from . import textures as tx
from .graphic2d import Graphic2D, page_placement
from .markup import escape, xml_text

PT_PER_MM = 72 / 25.4
BAR_LINE_MM = 1.0  # scale bar and its ticks: a good standard tactile line
CORNER_LINE_MM = 1.0
FRAME_LINE_MM = 1.0


def _cairo():
    try:
        import cairo
    except ImportError:
        raise MissingDependencyError(
            "PDF and SVG tactile graphics need pycairo: run 'pip install pycairo' (on Debian it builds against "
            "'apt-get install libcairo2-dev pkg-config'; make setup does this)."
        ) from None
    return cairo


def _texture_of(graphic: Graphic2D, value: int) -> str:
    if graphic.textures:
        name = graphic.textures.get(value, "outline")
    elif value <= len(tx.TEXTURES):
        name = tx.TEXTURES[value - 1]
    else:
        raise ParameterError(
            f"region map: value {value} has no texture; a levels map has at most {len(tx.TEXTURES)} levels "
            f"(outline, dots, lines), or give textures for each object value."
        )
    if name not in tx.TEXTURES:
        raise ParameterError(f"textures: each must be one of {', '.join(tx.TEXTURES)}; got {name!r} for value {value}.")
    return name


def _draw_picture(ctx, graphic: Graphic2D) -> None:
    """Outlines of every region, and the texture inside each (dots in one fill, lines in one stroke)."""
    regions = tx.merge_small_regions(graphic.regions, graphic.mm_per_px)
    origin, p = graphic.picture_origin_mm, graphic.mm_per_px
    ctx.new_path()
    for value in (v for v in np.unique(regions) if v > 0):
        for line in tx.outlines_mm(regions, int(value), p, origin_mm=origin):
            ctx.move_to(*line[0])
            for point in line[1:]:
                ctx.line_to(*point)
            ctx.close_path()
    ctx.set_line_width(tx.OUTLINE_MM)
    ctx.stroke()
    for value in (v for v in np.unique(regions) if v > 0):
        texture, mask = _texture_of(graphic, int(value)), regions == value
        if texture == "dots":
            for x, y in tx.texture_dots_mm(mask, p, origin):
                ctx.new_sub_path()
                ctx.arc(x, y, tx.DOT_DIAMETER_MM / 2, 0, 2 * math.pi)
            ctx.fill()
        elif texture == "lines":
            for a, b in tx.texture_lines_mm(mask, p, origin):
                ctx.move_to(*a)
                ctx.line_to(*b)
            ctx.set_line_width(tx.LINE_WIDTH_MM)
            ctx.stroke()


def _draw_braille(ctx, graphic: Graphic2D) -> None:
    """Each braille dot its own filled circle of the spec's base diameter."""
    r = graphic.spec.dot_diameter_mm / 2
    for text in (graphic.caption, graphic.scale_bar.label if graphic.scale_bar else None) + tuple(k.label for k in graphic.key):
        if text is None:
            continue
        for x, y in dot_centres(list(text.lines), graphic.spec, text.left_mm, top_mm=text.top_mm):
            ctx.new_path()
            ctx.arc(x, y, r, 0, 2 * math.pi)
            ctx.fill()


KEY_RASTER_MM = 0.1  # the swatch's texture is laid out on this grid, as the picture's is on its own


def _draw_key(ctx, graphic: Graphic2D) -> None:
    """Each key swatch: its outline, and inside it the texture of the region it names."""
    for row in graphic.key:
        x0, y0, x1, y1 = row.swatch_box
        ctx.new_path()
        ctx.rectangle(x0, y0, x1 - x0, y1 - y0)
        ctx.set_line_width(tx.OUTLINE_MM)
        ctx.stroke()
        mask = np.ones((round((y1 - y0) / KEY_RASTER_MM), round((x1 - x0) / KEY_RASTER_MM)), bool)
        if row.texture == "dots":
            for x, y in tx.texture_dots_mm(mask, KEY_RASTER_MM, (x0, y0)):
                ctx.new_sub_path()
                ctx.arc(x, y, tx.DOT_DIAMETER_MM / 2, 0, 2 * math.pi)
            ctx.fill()
        elif row.texture == "lines":
            for a, b in tx.texture_lines_mm(mask, KEY_RASTER_MM, (x0, y0)):
                ctx.move_to(*a)
                ctx.line_to(*b)
            ctx.set_line_width(tx.LINE_WIDTH_MM)
            ctx.stroke()


def _draw_furniture(ctx, graphic: Graphic2D) -> None:
    """Scale bar with end ticks, frame line and the top-right corner line."""
    ctx.set_line_cap(_cairo().LINE_CAP_BUTT)
    bar = graphic.scale_bar
    if bar is not None:
        x0, x1, y, w = bar.x0_mm, bar.x0_mm + bar.length_mm, bar.y_mm, BAR_LINE_MM
        ctx.move_to(x0, y)
        ctx.line_to(x1, y)
        for tick_x in (x0 + w / 2, x1 - w / 2):  # ticks inside the bar's length, so it measures true
            ctx.move_to(tick_x, y - TICK_LENGTH_MM / 2)
            ctx.line_to(tick_x, y + TICK_LENGTH_MM / 2)
        ctx.set_line_width(w)
        ctx.stroke()
    if graphic.frame_box is not None:
        fx0, fy0, fx1, fy1 = graphic.frame_box
        ctx.rectangle(fx0, fy0, fx1 - fx0, fy1 - fy0)
        ctx.set_line_width(FRAME_LINE_MM)
        ctx.stroke()
    if graphic.corner_cut_mm > 0:
        w, d, c = *graphic.plate_mm, graphic.corner_cut_mm
        inset = CORNER_LINE_MM / 2 / math.sqrt(2)  # keep the whole line on the plate
        ctx.move_to(w - c - inset, d - inset)
        ctx.line_to(w - inset, d - c - inset)
        ctx.set_line_width(CORNER_LINE_MM)
        ctx.stroke()


def _draw(surface, graphic: Graphic2D, offset_mm, page_h_mm: float, unit_scale: float) -> None:
    """Draw on a surface whose user unit is 1/unit_scale mm; the one place plate y flips to page y."""
    cairo = _cairo()
    ctx = cairo.Context(surface)
    ctx.scale(unit_scale, unit_scale)
    ctx.translate(offset_mm[0], page_h_mm - offset_mm[1])
    ctx.scale(1, -1)  # plate +y (far edge) points up the page
    ctx.set_tolerance(0.01)
    ctx.set_source_rgb(0, 0, 0)
    ctx.set_line_join(cairo.LINE_JOIN_ROUND)
    ctx.set_line_cap(cairo.LINE_CAP_ROUND)
    _draw_picture(ctx, graphic)
    _draw_braille(ctx, graphic)
    _draw_key(ctx, graphic)
    _draw_furniture(ctx, graphic)
    surface.show_page()


def _same_bytes_each_time(cairo, surface) -> None:
    """The creator, and no creation date: cairo writes the time of writing, so a rebuild from the
    recipe differed from the first PDF in those bytes alone; an empty date makes cairo leave it out."""
    surface.set_metadata(cairo.PDFMetadata.CREATOR, "tamp-os")
    surface.set_metadata(cairo.PDFMetadata.CREATE_DATE, "")


def write_pdf(graphic: Graphic2D, fh: BinaryIO, page_size: str | None = None, *, metadata: dict | None = None) -> None:
    """The graphic as a one-page vector PDF at true size (page in points = mm × 72 / 25.4)."""
    cairo = _cairo()
    (pw, ph), offset = page_placement(graphic.plate_mm, page_size)
    surface = cairo.PDFSurface(fh, pw * PT_PER_MM, ph * PT_PER_MM)
    meta = metadata or {}
    surface.set_metadata(cairo.PDFMetadata.TITLE, xml_text(meta.get("title", "Tactile graphic")))  # a file name's stray bytes too
    if meta.get("description"):
        surface.set_metadata(cairo.PDFMetadata.SUBJECT, xml_text(meta["description"]))
    _same_bytes_each_time(cairo, surface)
    _draw(surface, graphic, offset, ph, PT_PER_MM)
    surface.finish()


def write_svg(graphic: Graphic2D, fh: BinaryIO, page_size: str | None = None, *, metadata: dict | None = None) -> None:
    """The graphic as SVG whose width and height are in mm and whose user unit is 1 mm."""
    cairo = _cairo()
    (pw, ph), offset = page_placement(graphic.plate_mm, page_size)
    buffer = io.BytesIO()
    surface = cairo.SVGSurface(buffer, pw, ph)
    surface.set_document_unit(cairo.SVGUnit.MM)
    _draw(surface, graphic, offset, ph, 1.0)
    surface.finish()
    text = buffer.getvalue().decode("utf-8")
    # cairo writes no title; screen readers and file browsers announce one.
    title = f"<title>{escape(str((metadata or {}).get('title', 'Tactile graphic')))}</title>\n"
    head_end = text.index(">", text.index("<svg")) + 1
    fh.write((text[:head_end] + "\n" + title + text[head_end + 1:]).encode("utf-8"))


def write_pdf_pages(graphics: list[Graphic2D], fh: BinaryIO, page_size: str | None = None, *, title: str = "Tactile graphics") -> None:
    """Several graphics as one PDF, one page each at true size (a figure's overview and panels)."""
    cairo = _cairo()
    sizes = [page_placement(g.plate_mm, page_size) for g in graphics]
    (pw, ph), _ = sizes[0]
    surface = cairo.PDFSurface(fh, pw * PT_PER_MM, ph * PT_PER_MM)
    surface.set_metadata(cairo.PDFMetadata.TITLE, xml_text(title))
    _same_bytes_each_time(cairo, surface)
    for graphic, ((pw, ph), offset) in zip(graphics, sizes):
        surface.set_size(pw * PT_PER_MM, ph * PT_PER_MM)
        _draw(surface, graphic, offset, ph, PT_PER_MM)
    surface.finish()


Writer = Callable[..., None]
GRAPHIC_WRITERS: dict[str, Writer] = {"pdf": write_pdf, "svg": write_svg}


def save_graphic(graphic: Graphic2D, path, page_size: str | None = None, *, metadata: dict | None = None) -> Path:
    """Write `graphic` to `path` as PDF or SVG (by extension), atomically.

    page_size: None or 'plate' for the graphic's own size, 'a4' or 'letter' to centre it on that page.
    metadata: 'title' and 'description'.
    """
    path = Path(path)
    ext = path.suffix.lower().lstrip(".")
    if ext not in GRAPHIC_WRITERS:
        raise ParameterError(f"{path}: no tactile-graphic writer for '.{ext}'; choose .pdf or .svg.")
    page_placement(graphic.plate_mm, page_size)  # a page that is too small fails before any file is opened
    return write_atomic(path, lambda fh: GRAPHIC_WRITERS[ext](graphic, fh, page_size, metadata=metadata))
