"""Tactile furniture around the relief: braille caption, scale bar, orientation corner, frame.

Layout (seen from above, far edge at the top):

    +---------------------------------------/   <- cut corner (orientation), top right
    |  [frame]  relief (the image)          |
    |                                       |
    |  |=========|  5 µm (braille)          |   <- scale bar row, below the relief
    |  caption in braille, wrapped          |
    +---------------------------------------+

Three steps: plan_furniture (pure layout: boxes and dot centres in mm) -> build_parts (manifold3d
solids) -> fuse (one union, minus the corner). The plate grows to hold the furniture; every
element keeps at least CLEARANCE_MM from every other. A plate without furniture is the relief
alone with its corner cut.

Parts overlap, they never touch: slicers merge an STL's vertices by position, and two parts that
share a face (a tick's top in the bar's top plane, a relief pixel at base height in the plate's
top) leave pinched edges used by four faces. So the plate top lies SEAM_MM below base_mm, the
relief's own bottom and every raised element reach down into the plate, and the bar with its
end ticks is one extruded outline.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from .braille import DEFAULT_TABLE, BrailleSpec, block_size_mm, dot_centres, to_braille, wrap_cells
from .scalebar import GAP_MM, ScaleBar, auto_scale_bar, chosen_scale_bar
from ..errors import ExportError, ParameterError, Text
from ..mesh.solid import INDEX, Mesh

CLEARANCE_MM = 4.0  # between distinct raised elements (standard: at least 3 mm)
BORDER_MM = 8.0  # plate edge to the nearest element on the left, top and right
BOTTOM_BORDER_MM = 6.0
CORNER_CUT_MM = 8.0  # legs of the cut corner at the top right
CORNER_SHARE = 0.4  # on a small plate the legs are at most this share of its shorter side
SEAM_MM = 0.002  # the plate top lies this far below base_mm: no face shared with the relief
BAR_WIDTH_MM = 1.5
BAR_HEIGHT_MM = 1.0
TICK_WIDTH_MM = 1.0
TICK_LENGTH_MM = 5.0
FRAME_HEIGHT_MM = 1.0
DOME_SEGMENTS = 24  # vertices on the base circle; the base ring lies exactly on the diameter
DOME_STEPS = 6  # rings up the spherical cap

Box = tuple[float, float, float, float]  # x0, y0, x1, y1 in mm, plate coordinates


@dataclass
class Furniture:
    """What to add; None/empty means leave it out.

    scale_bar_m is a length the user chose; auto_scale_bar asks for a round length that fits
    (both need sample_m_per_print_mm, the sample length one print millimetre stands for).
    """

    caption: str | None = None
    braille_table: str = DEFAULT_TABLE
    scale_bar_m: float | None = None
    auto_scale_bar: bool = False
    sample_m_per_print_mm: float | None = None
    frame_mm: float = 0.0
    corner_cut: bool = True
    spec: BrailleSpec = field(default_factory=BrailleSpec)

    @property
    def wanted(self) -> bool:
        """Whether any element besides the cut corner is asked for."""
        bar = (self.scale_bar_m is not None or self.auto_scale_bar) and bool(self.sample_m_per_print_mm)
        return bool(self.caption) or bar or self.frame_mm > 0


@dataclass
class Placed:
    """Where each element went (mm, plate coordinates) and what it says, for the description."""

    plate_mm: tuple[float, float]
    relief_origin_mm: tuple[float, float]
    caption_braille: list[str] = field(default_factory=list)
    caption_box: Box | None = None
    scale_bar_box: Box | None = None
    scale_label: str | None = None
    scale_bar_m: float | None = None  # the sample length the bar stands for
    scale_bar_mm: float | None = None  # the bar's length on the print
    scale_label_braille: str | None = None
    scale_label_lines: list[str] = field(default_factory=list)  # the label's braille lines, as laid out
    scale_label_box: Box | None = None
    scale_label_beside: bool = True  # the label is right of the bar (else below it)
    frame_box: Box | None = None
    corner_cut_mm: float = 0.0  # legs of the cut corner; 0 = no corner cut
    dots: int = 0
    notes: list[str] = field(default_factory=list)  # what was left out, and why


@dataclass
class Plan:
    """Where every part goes, in mm on the plate, before any geometry is built."""

    placed: Placed
    frame_ring: tuple[Box, Box] | None = None  # outer and inner outline of the frame
    bar_outline: list[tuple[float, float]] = field(default_factory=list)  # bar and end ticks, one polygon
    dot_centres: list[tuple[float, float]] = field(default_factory=list)


def corner_legs_mm(plate_w: float, plate_d: float) -> float:
    """Legs of the orientation corner: CORNER_CUT_MM, less on a plate too small for it."""
    return min(CORNER_CUT_MM, CORNER_SHARE * min(plate_w, plate_d))


def _scale_bar(furniture: Furniture, inner_w: float) -> tuple[ScaleBar | None, list[str]]:
    """The scale bar to place (or None) and notes on why one was left out."""
    per_mm = furniture.sample_m_per_print_mm
    if not per_mm:
        return None, []
    if furniture.scale_bar_m is not None:
        return chosen_scale_bar(furniture.scale_bar_m, per_mm, inner_w, spec=furniture.spec, table=furniture.braille_table), []
    if not furniture.auto_scale_bar:
        return None, []
    bar = auto_scale_bar(per_mm, inner_w, furniture.spec, table=furniture.braille_table)
    if bar is None:
        return None, [
            Text(
                f"`scale_bar`: the plate has no room for a scale bar of at least 8 mm ({inner_w:.1f} mm inside its borders); it was left out. The scale is in the description."
            )
        ]
    return bar, []


MAX_CAPTION_CHARS = 500  # a caption names the picture; longer text belongs in the description
CAPTION_MIN_ROOM_MM = 40.0  # four braille lines: a thin strip of a picture still takes a title


def _caption_lines(furniture: Furniture, cells: int, depth_mm: float) -> list[str]:
    """The caption's braille lines, refused when too long to translate or to fit the plate:
    its block may be at most as deep as the picture, or four lines for a thin one (so the plate
    never more than doubles, but by 40 mm)."""
    text = furniture.caption
    if len(text) > MAX_CAPTION_CHARS:
        raise ParameterError(
            f"`caption`: {len(text):,} characters is too long for a braille caption (at most {MAX_CAPTION_CHARS}); shorten it to a title of a few words."
        )
    lines = wrap_cells(to_braille(text, furniture.braille_table, what="caption"), max(cells, 1))
    height = block_size_mm(lines, furniture.spec)[1]
    limit = max(depth_mm, CAPTION_MIN_ROOM_MM)
    if height > limit:
        fit = max(1, int(len(text) * limit / height))
        raise ParameterError(
            f"`caption`: {len(lines)} braille lines ({height:.0f} mm) would be deeper than the picture itself allows "
            f"({limit:.0f} mm: the picture's depth, and at least {CAPTION_MIN_ROOM_MM:g} mm); shorten it to about {fit} "
            f"characters, or make the print wider."
        )
    return lines


def plan_furniture(width_mm: float, depth_mm: float, furniture: Furniture) -> Plan:
    """Plan the plate: its size, the relief's origin, and boxes and dot centres for each element.

    Pure layout (no geometry): the relief of `width_mm` × `depth_mm` sits above rows for the
    scale bar and the caption; every element keeps CLEARANCE_MM from every other. The plate
    widens (the relief stays centred) when a scale label's longest word needs it.
    """
    spec, frame = furniture.spec, furniture.frame_mm
    side = BORDER_MM + (frame + CLEARANCE_MM if frame else 0.0)
    inner_w = width_mm + 2 * side - 2 * BORDER_MM
    bar, notes = _scale_bar(furniture, inner_w)
    rows_h = [bar.row_mm[1]] if bar else []  # rows below the relief, from the relief downwards
    inner_w = max(inner_w, bar.row_mm[0] if bar else 0.0)
    caption_lines: list[str] = []
    if furniture.caption:
        cells = int((inner_w - spec.dot_spacing_mm - spec.dot_diameter_mm) // spec.cell_spacing_mm) + 1
        caption_lines = _caption_lines(furniture, cells, depth_mm)
        rows_h.append(block_size_mm(caption_lines, spec)[1])
    below = (side - BORDER_MM if frame else 0.0) + sum(CLEARANCE_MM + h for h in rows_h) + BOTTOM_BORDER_MM
    if not rows_h:
        below = side
    plate_w = inner_w + 2 * BORDER_MM
    ox, oy = (plate_w - width_mm) / 2, below
    plate_d = below + depth_mm + side
    placed = Placed(plate_mm=(plate_w, plate_d), relief_origin_mm=(ox, oy), notes=notes)
    placed.corner_cut_mm = corner_legs_mm(plate_w, plate_d) if furniture.corner_cut else 0.0
    plan = Plan(placed=placed)
    if frame:
        x0, y0 = ox - CLEARANCE_MM - frame, oy - CLEARANCE_MM - frame
        x1, y1 = ox + width_mm + CLEARANCE_MM + frame, oy + depth_mm + CLEARANCE_MM + frame
        plan.frame_ring = ((x0, y0, x1, y1), (x0 + frame, y0 + frame, x1 - frame, y1 - frame))
        placed.frame_box = (x0, y0, x1, y1)
    cursor = oy - (CLEARANCE_MM + frame if frame else 0.0)
    if bar:
        cursor = _plan_scale_bar(plan, bar, cursor - CLEARANCE_MM)
    if caption_lines:
        cursor -= CLEARANCE_MM
        w, h = block_size_mm(caption_lines, spec)
        plan.dot_centres += dot_centres(caption_lines, spec, BORDER_MM, top_mm=cursor)
        placed.caption_braille = caption_lines
        placed.caption_box = (BORDER_MM, cursor - h, BORDER_MM + w, cursor)
    placed.dots = len(plan.dot_centres)
    return plan


def _bar_outline(x0: float, x1: float, mid: float) -> list[tuple[float, float]]:
    """The bar and its two end ticks as one counter-clockwise outline (an I-beam on its side)."""
    t, hb, ht = TICK_WIDTH_MM, BAR_WIDTH_MM / 2, TICK_LENGTH_MM / 2
    return [
        (x0, mid - ht), (x0 + t, mid - ht), (x0 + t, mid - hb), (x1 - t, mid - hb), (x1 - t, mid - ht), (x1, mid - ht),
        (x1, mid + ht), (x1 - t, mid + ht), (x1 - t, mid + hb), (x0 + t, mid + hb), (x0 + t, mid + ht), (x0, mid + ht),
    ]  # fmt: skip


def _plan_scale_bar(plan: Plan, bar: ScaleBar, top_mm: float) -> float:
    """Put the bar, its ticks and its label in the row whose top is at `top_mm`; return its bottom."""
    label_w, label_h = bar.label_size_mm
    row_h = bar.row_mm[1]
    x0 = BORDER_MM
    mid = top_mm - row_h / 2 if bar.beside else top_mm - TICK_LENGTH_MM / 2
    plan.bar_outline = _bar_outline(x0, x0 + bar.length_mm, mid)
    if bar.beside:
        lx, ly = x0 + bar.length_mm + GAP_MM, mid + label_h / 2
    else:
        lx, ly = x0, top_mm - TICK_LENGTH_MM - GAP_MM
    plan.dot_centres += dot_centres(list(bar.label_lines), bar.spec, lx, top_mm=ly)
    placed = plan.placed
    placed.scale_bar_box = (x0, mid - TICK_LENGTH_MM / 2, x0 + bar.length_mm, mid + TICK_LENGTH_MM / 2)
    placed.scale_label = bar.label
    placed.scale_bar_m, placed.scale_bar_mm = bar.value_m, round(bar.length_mm, 3)
    placed.scale_label_braille = "\u2800".join(bar.label_lines)
    placed.scale_label_lines = list(bar.label_lines)
    placed.scale_label_box = (lx, ly - label_h, lx + label_w, ly)
    placed.scale_label_beside = bar.beside
    return top_mm - row_h


def relief_part(relief: Mesh, origin_mm: tuple[float, float], bottom_mm: float):
    """The relief as a manifold3d solid at its origin, its bottom raised to `bottom_mm` (inside the plate)."""
    import manifold3d as m3

    verts = relief.vertices + np.array([*origin_mm, 0.0])
    verts[relief.vertices[:, 2] <= 0.0, 2] = bottom_mm  # close_top puts the bottom at exactly z = 0
    return m3.Manifold(m3.Mesh(vert_properties=verts.astype(np.float32), tri_verts=relief.faces.astype(np.uint32)))


def _extrude(outlines, z0: float, z1: float):
    """Polygons (outer outline, then holes) extruded from z0 to z1."""
    import manifold3d as m3

    return m3.Manifold.extrude(m3.CrossSection(outlines), z1 - z0).translate((0, 0, z0))


def _rect(box: Box) -> list[tuple[float, float]]:
    x0, y0, x1, y1 = box
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def build_parts(relief: Mesh, plan: Plan, base_mm: float, *, spec: BrailleSpec) -> list:
    """manifold3d solids: the plate, the relief at its origin, and each planned element.

    Raised elements stand on z = base_mm and reach `sink` into the plate, whose top is SEAM_MM
    lower, so every pair of parts overlaps instead of touching.
    """
    return build_base(relief, plan, base_mm) + build_raised(plan, base_mm, spec)


def build_base(relief: Mesh, plan: Plan, base_mm: float) -> list:
    """manifold3d solids of the plate (its top SEAM_MM below base_mm) and the relief at its origin."""
    plate_w, plate_d = plan.placed.plate_mm
    plate_top = base_mm - min(SEAM_MM, base_mm / 10)
    return [_extrude([_rect((0, 0, plate_w, plate_d))], 0.0, plate_top), relief_part(relief, plan.placed.relief_origin_mm, plate_top / 2)]


def build_raised(plan: Plan, base_mm: float, spec: BrailleSpec) -> list:
    """manifold3d solids of the raised furniture (frame, scale bar, braille dots), each standing
    on z = base_mm and reaching `sink` down into the plate."""
    sink = min(0.4, base_mm / 2)
    parts = []
    if plan.frame_ring:
        outer, inner = plan.frame_ring
        parts.append(_extrude([_rect(outer), _rect(inner)[::-1]], base_mm - sink, base_mm + FRAME_HEIGHT_MM))
    if plan.bar_outline:
        parts.append(_extrude([plan.bar_outline], base_mm - sink, base_mm + BAR_HEIGHT_MM))
    dome = braille_dome(spec, sink)
    parts += [dome.translate((x, y, base_mm)) for x, y in plan.dot_centres]
    return parts


def add_furniture(relief: Mesh, width_mm: float, depth_mm: float, *, base_mm: float, furniture: Furniture) -> tuple[Mesh, Placed]:
    """The relief on a grown plate with the requested furniture, fused into one solid.

    Without furniture the relief is the plate, with its corner cut (when asked). Sizes in mm;
    the relief's outline is [0, width_mm] × [0, depth_mm].
    """
    if not furniture.wanted:
        placed = Placed(plate_mm=(width_mm, depth_mm), relief_origin_mm=(0.0, 0.0))
        if not furniture.corner_cut:
            return relief, placed
        placed.corner_cut_mm = corner_legs_mm(width_mm, depth_mm)
        solid = relief_part(relief, (0.0, 0.0), 0.0)
        top = float(relief.vertices[:, 2].max())
        return _fuse([solid], placed, top), placed
    plan = plan_furniture(width_mm, depth_mm, furniture)
    top = max(float(relief.vertices[:, 2].max()), base_mm + max(BAR_HEIGHT_MM, FRAME_HEIGHT_MM, furniture.spec.dot_height_mm))
    inlaid = _inlaid(relief, plan, base_mm, furniture.spec, top)
    if inlaid is not None:
        return inlaid, plan.placed
    parts = build_parts(relief, plan, base_mm, spec=furniture.spec)
    return _fuse(parts, plan.placed, top), plan.placed


def _inlaid(relief: Mesh, plan: Plan, base_mm: float, spec: BrailleSpec, top_mm: float) -> Mesh | None:
    """The same solid as fusing build_parts, with the relief joined to the plate without a boolean
    (tactile/inlay.py: 5-10x faster on a relief of 30,000 triangles), or None when the furniture
    or the corner comes too near the relief for that."""
    from .inlay import inlaid

    ox, oy = plan.placed.relief_origin_mm
    # by column: max(axis=0) over (N, 3) rows is ~20x slower
    footprint = (ox, oy, ox + float(relief.vertices[:, 0].max()), oy + float(relief.vertices[:, 1].max()))
    if not _clear_of(plan, footprint, spec):
        return None
    shape = _PlateShape(tuple(plan.placed.plate_mm), plan.placed.corner_cut_mm, footprint, base_mm, spec, top_mm,
                        tuple(map(tuple, plan.frame_ring)) if plan.frame_ring else None,
                        tuple(map(tuple, plan.bar_outline)), tuple(map(tuple, plan.dot_centres)))  # tuples: a key
    plate_top = base_mm - min(SEAM_MM, base_mm / 10)
    return inlaid(relief, _pocketed_plate(shape), (ox, oy), plate_top_mm=plate_top, pocket_floor_mm=plate_top / 2)


@dataclass(frozen=True)
class _PlateShape:
    """Everything that shapes the furnished plate with its pocket (see _pocketed_plate)."""

    plate_mm: tuple[float, float]
    corner_cut_mm: float
    footprint: Box
    base_mm: float
    spec: BrailleSpec
    top_mm: float
    frame_ring: tuple[Box, Box] | None
    bar_outline: tuple[tuple[float, float], ...]
    dot_centres: tuple[tuple[float, float], ...]


@functools.lru_cache(maxsize=8)
def _pocketed_plate(shape: _PlateShape) -> Mesh:
    """The furnished plate (raised furniture fused, corner cut) with a pocket under the relief's
    footprint: manifold3d's booleans, 5-10 ms. Kept for the next print of the same shape (a batch
    of pictures of one size and scale, a sweep of one picture): the same operations give the
    same mesh, so it is made once. Its arrays are read-only, as it is shared."""
    placed = Placed(plate_mm=shape.plate_mm, relief_origin_mm=(0.0, 0.0), corner_cut_mm=shape.corner_cut_mm)
    plan = Plan(placed, frame_ring=shape.frame_ring, bar_outline=list(shape.bar_outline), dot_centres=list(shape.dot_centres))
    plate_w, plate_d = shape.plate_mm
    plate_top = shape.base_mm - min(SEAM_MM, shape.base_mm / 10)
    plate = _extrude([_rect((0, 0, plate_w, plate_d))], 0.0, plate_top) - _extrude([_rect(shape.footprint)], plate_top / 2, plate_top + 1.0)
    pocketed = to_mesh(fuse_solid([plate] + build_raised(plan, shape.base_mm, shape.spec), placed, shape.top_mm))
    pocketed.vertices.flags.writeable = False
    pocketed.faces.flags.writeable = False
    return pocketed


def clear_plate_cache() -> None:
    """Forget the furnished plates kept for reuse (a benchmark's 'new picture')."""
    _pocketed_plate.cache_clear()


def _clear_of(plan: Plan, footprint: Box, spec: BrailleSpec) -> bool:
    """Whether every raised element and the cut corner keep CLEARANCE_MM / 2 from the footprint."""
    gap = CLEARANCE_MM / 2
    x0, y0, x1, y1 = footprint[0] - gap, footprint[1] - gap, footprint[2] + gap, footprint[3] + gap
    boxes = [
        (x - spec.dot_diameter_mm / 2, y - spec.dot_diameter_mm / 2, x + spec.dot_diameter_mm / 2, y + spec.dot_diameter_mm / 2) for x, y in plan.dot_centres
    ]
    if plan.bar_outline:
        xs, ys = zip(*plan.bar_outline)
        boxes.append((min(xs), min(ys), max(xs), max(ys)))
    if any(b[0] < x1 and b[2] > x0 and b[1] < y1 and b[3] > y0 for b in boxes):
        return False
    if plan.frame_ring:
        inner = plan.frame_ring[1]
        if not (inner[0] <= x0 and inner[1] <= y0 and inner[2] >= x1 and inner[3] >= y1):
            return False
    plate_w, plate_d = plan.placed.plate_mm
    # the corner's cut runs along x + y = plate_w + plate_d - legs
    return plan.placed.corner_cut_mm <= 0 or x1 + y1 < plate_w + plate_d - plan.placed.corner_cut_mm


def braille_dome(spec: BrailleSpec, sink_mm: float):
    """A spherical cap of the spec's base diameter and height, on a short cylinder sunk into the plate."""
    import manifold3d as m3

    a, h = spec.dot_diameter_mm / 2, spec.dot_height_mm
    radius = (a * a + h * h) / (2 * h)
    centre = h - radius
    profile = [(0.0, -sink_mm), (a, -sink_mm), (a, 0.0)]
    steps = DOME_STEPS
    start = math.asin(min(1.0, a / radius))
    for i in range(1, steps):
        angle = start * (1 - i / steps)
        profile.append((radius * math.sin(angle), centre + radius * math.cos(angle)))
    profile.append((0.0, h))
    return m3.Manifold.revolve(m3.CrossSection([profile]), DOME_SEGMENTS)


def _corner_cut(plate_w: float, plate_d: float, legs_mm: float, top_mm: float):
    """A prism that removes the top-right corner: legs of `legs_mm` along both edges."""
    reach = legs_mm + 1.0  # the triangle overhangs the plate by 1 mm on each side
    corner = [(plate_w - reach, plate_d + 1), (plate_w + 1, plate_d - reach), (plate_w + 1, plate_d + 1)]
    return _extrude([corner], -1.0, top_mm + 1.0)


def _fuse(parts, placed: Placed, top_mm: float) -> Mesh:
    """Union of all parts, minus the orientation corner (if any), as one Mesh; top_mm bounds the parts."""
    return to_mesh(fuse_solid(parts, placed, top_mm))


def fuse_solid(parts, placed: Placed, top_mm: float):
    """Union of all parts, minus the orientation corner (if any), as a manifold3d solid."""
    import manifold3d as m3

    solid = m3.Manifold.batch_boolean(parts, m3.OpType.Add) if len(parts) > 1 else parts[0]
    if placed.corner_cut_mm > 0:
        solid = solid - _corner_cut(*placed.plate_mm, placed.corner_cut_mm, top_mm)
    return solid


def to_mesh(solid) -> Mesh:
    """A manifold3d solid as a Mesh; ExportError if the boolean operations failed or left nothing."""
    import manifold3d as m3

    if solid.status() != m3.Error.NoError or solid.is_empty():
        raise ExportError(f"tactile furniture: fusing the parts failed ({solid.status()}); please report this input and its settings.")
    out = solid.to_mesh()
    return Mesh(vertices=np.asarray(out.vert_properties, dtype=np.float64)[:, :3], faces=np.asarray(out.tri_verts, dtype=INDEX))


def braille_test_plate(text: str, table: str, heights_mm, *, diameters_mm, base_mm: float = 1.5):
    """A plate with `text` in braille once per (dot height, dot diameter), each row numbered in
    braille at its start, so a reader can pick what their printer makes legible."""
    rows = [(h, d) for h in heights_mm for d in diameters_mm]
    specs = [BrailleSpec(dot_diameter_mm=d, dot_height_mm=h) for h, d in rows]
    body = to_braille(text, table)
    lines = [to_braille(f"{i + 1}", table) + "\u2800" + body for i in range(len(rows))]
    width = max(block_size_mm([line], specs[0])[0] for line in lines) + 2 * BORDER_MM
    depth = len(rows) * specs[0].line_spacing_mm + 2 * BOTTOM_BORDER_MM
    parts = [_extrude([_rect((0, 0, width, depth))], 0.0, base_mm - min(SEAM_MM, base_mm / 10))]
    for i, (line, spec) in enumerate(zip(lines, specs)):
        dome = braille_dome(spec, min(0.4, base_mm / 2))
        top_y = depth - BOTTOM_BORDER_MM - i * spec.line_spacing_mm
        parts += [dome.translate((x, y, base_mm)) for x, y in dot_centres([line], spec, BORDER_MM, top_mm=top_y)]
    placed = Placed(plate_mm=(width, depth), relief_origin_mm=(0.0, 0.0), corner_cut_mm=corner_legs_mm(width, depth))
    return _fuse(parts, placed, base_mm + max(h for h, _ in rows)), rows, lines
