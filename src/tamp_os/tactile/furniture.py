"""Tactile furniture around the relief: braille caption, scale bar, orientation corner, frame.

Layout (seen from above, far edge at the top):

    +---------------------------------------/   <- cut corner (orientation), top right
    |  [frame]  relief (the image)          |
    |                                       |
    |  |=========|  5 µm (braille)          |   <- scale bar row, below the relief
    |  caption in braille, wrapped          |
    +---------------------------------------+

The plate grows to hold them; every element keeps at least CLEARANCE_MM from every other. All
parts are fused with the relief into one closed 2-manifold solid by manifold3d.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .braille import DEFAULT_TABLE, BrailleSpec, block_size_mm, dot_centres, to_braille, wrap_cells
from ..errors import ParameterError
from ..mesh.solid import INDEX, Mesh
from ..units import format_length

CLEARANCE_MM = 4.0  # between distinct raised elements (standard: at least 3 mm)
BORDER_MM = 8.0  # plate edge to the nearest element on the left, top and right
BOTTOM_BORDER_MM = 6.0
CORNER_CUT_MM = 8.0  # legs of the cut corner at the top right
BAR_WIDTH_MM = 1.5
BAR_HEIGHT_MM = 1.0
TICK_WIDTH_MM = 1.0
TICK_LENGTH_MM = 5.0
FRAME_HEIGHT_MM = 1.0
DOME_SEGMENTS = 24  # vertices on the base circle; the base ring lies exactly on the diameter
DOME_STEPS = 6  # rings up the spherical cap


@dataclass
class Furniture:
    """What to add; None/empty means leave it out."""

    caption: str | None = None
    braille_table: str = DEFAULT_TABLE
    scale_bar_m: float | None = None  # the sample length the bar stands for
    sample_m_per_print_mm: float | None = None
    frame_mm: float = 0.0
    spec: BrailleSpec = field(default_factory=BrailleSpec)

    @property
    def wanted(self) -> bool:
        return bool(self.caption) or self.scale_bar_m is not None or self.frame_mm > 0


@dataclass
class Placed:
    """Where each element went (mm, plate coordinates) and what it says, for the description."""

    plate_mm: tuple[float, float]
    relief_origin_mm: tuple[float, float]
    caption_braille: list[str] = field(default_factory=list)
    caption_box: tuple[float, float, float, float] | None = None  # x0, y0, x1, y1
    scale_bar_box: tuple[float, float, float, float] | None = None
    scale_label: str | None = None
    scale_label_braille: str | None = None
    scale_label_box: tuple[float, float, float, float] | None = None
    frame_box: tuple[float, float, float, float] | None = None
    dots: int = 0


def choose_scale_bar_m(sample_m_per_print_mm: float, lo_mm: float = 10.0, hi_mm: float = 40.0) -> float:
    """A round length (1, 2 or 5 × 10^n) whose bar is 10–40 mm on the print, nearest 20 mm."""
    best = None
    start = math.floor(math.log10(sample_m_per_print_mm * lo_mm)) - 1
    for exponent in range(start, start + 4):
        for mantissa in (1, 2, 5):
            value = mantissa * 10.0**exponent
            bar = value / sample_m_per_print_mm
            if lo_mm <= bar <= hi_mm and (best is None or abs(bar - 20) < abs(best / sample_m_per_print_mm - 20)):
                best = value
    if best is None:  # the decade search always finds one for a 4x range; keep a clear failure anyway
        raise ParameterError("scale bar: no round length fits 10–40 mm at this scale; give one with --scale-bar.")
    return best


def _dome(spec: BrailleSpec, sink_mm: float):
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


def _box(x0, y0, x1, y1, z0, z1):
    import manifold3d as m3

    return m3.Manifold.cube((x1 - x0, y1 - y0, z1 - z0)).translate((x0, y0, z0))


def _corner_cut(plate_w: float, plate_d: float, height: float):
    """A prism that removes the top-right corner: legs of CORNER_CUT_MM along both edges."""
    import manifold3d as m3

    reach = CORNER_CUT_MM + 1.0  # the triangle overhangs the plate by 1 mm on each side
    corner = [(plate_w - reach, plate_d + 1), (plate_w + 1, plate_d - reach), (plate_w + 1, plate_d + 1)]
    return m3.Manifold.extrude(m3.CrossSection([corner]), height).translate((0, 0, -1))


def _fuse(parts, plate_w: float, plate_d: float, top_mm: float) -> Mesh:
    """Union of all parts, minus the orientation corner, as one Mesh."""
    import manifold3d as m3

    solid = m3.Manifold.batch_boolean(parts, m3.OpType.Add) - _corner_cut(plate_w, plate_d, top_mm + 10)
    if solid.status() != m3.Error.NoError or solid.is_empty():
        raise ParameterError(f"tactile furniture: fusing the parts failed ({solid.status()}); please report this input.")
    out = solid.to_mesh()
    return Mesh(vertices=np.asarray(out.vert_properties, dtype=np.float64)[:, :3], faces=np.asarray(out.tri_verts, dtype=INDEX))


Box = tuple[float, float, float, float]  # x0, y0, x1, y1 in mm, plate coordinates


@dataclass
class Plan:
    """Where every part goes, in mm on the plate, before any geometry is built."""

    placed: Placed
    frame_ring: tuple[Box, Box] | None = None  # outer and inner outline of the frame
    bar_boxes: list[Box] = field(default_factory=list)  # the bar, then its two end ticks
    dot_centres: list[tuple[float, float]] = field(default_factory=list)


def _scale_label(furniture: Furniture) -> tuple[float, str, list[str]]:
    """The bar length on the print (mm), its label and the label in braille lines."""
    bar_mm = furniture.scale_bar_m / furniture.sample_m_per_print_mm
    label = format_length(furniture.scale_bar_m).replace(".0 ", " ")
    return bar_mm, label, [to_braille(label, furniture.braille_table)]


def plan_furniture(width_mm: float, depth_mm: float, furniture: Furniture) -> Plan:
    """Plan the plate: its size, the relief's origin, and boxes and dot centres for each element.

    Pure layout (no geometry): the relief of `width_mm` × `depth_mm` sits above rows for the
    scale bar and the caption; every element keeps CLEARANCE_MM from every other.
    """
    spec, frame = furniture.spec, furniture.frame_mm
    side = BORDER_MM + (frame + CLEARANCE_MM if frame else 0.0)
    plate_w = width_mm + 2 * side
    inner_w = plate_w - 2 * BORDER_MM
    rows_h = []  # rows below the relief, from the relief downwards
    label_lines: list[str] = []
    if furniture.scale_bar_m is not None:
        bar_mm, label, label_lines = _scale_label(furniture)
        label_w, label_h = block_size_mm(label_lines, spec)
        if bar_mm + CLEARANCE_MM + label_w > inner_w:
            raise ParameterError(
                f"scale bar: {bar_mm:.1f} mm plus its braille label ({label_w:.1f} mm) does not fit the "
                f"{inner_w:.1f} mm of the plate; choose a shorter --scale-bar or a wider print."
            )
        rows_h.append(max(TICK_LENGTH_MM, label_h))
    caption_lines: list[str] = []
    if furniture.caption:
        cells = int((inner_w - spec.dot_spacing_mm - spec.dot_diameter_mm) // spec.cell_spacing_mm) + 1
        caption_lines = wrap_cells(to_braille(furniture.caption, furniture.braille_table), cells)
        rows_h.append(block_size_mm(caption_lines, spec)[1])
    below = (side - BORDER_MM if frame else 0.0) + sum(CLEARANCE_MM + h for h in rows_h) + BOTTOM_BORDER_MM
    if not rows_h:
        below = side
    ox, oy = side, below
    plan = Plan(placed=Placed(plate_mm=(plate_w, below + depth_mm + side), relief_origin_mm=(ox, oy)))
    if frame:
        x0, y0 = ox - CLEARANCE_MM - frame, oy - CLEARANCE_MM - frame
        x1, y1 = ox + width_mm + CLEARANCE_MM + frame, oy + depth_mm + CLEARANCE_MM + frame
        plan.frame_ring = ((x0, y0, x1, y1), (x0 + frame, y0 + frame, x1 - frame, y1 - frame))
        plan.placed.frame_box = (x0, y0, x1, y1)
    cursor = oy - (CLEARANCE_MM + frame if frame else 0.0)
    if label_lines:
        cursor = _plan_scale_bar(plan, spec, (bar_mm, label, label_lines), cursor - CLEARANCE_MM, rows_h[0])
    if caption_lines:
        cursor -= CLEARANCE_MM
        w, h = block_size_mm(caption_lines, spec)
        plan.dot_centres += dot_centres(caption_lines, spec, BORDER_MM, cursor)
        plan.placed.caption_braille = caption_lines
        plan.placed.caption_box = (BORDER_MM, cursor - h, BORDER_MM + w, cursor)
    plan.placed.dots = len(plan.dot_centres)
    return plan


def _plan_scale_bar(plan: Plan, spec: BrailleSpec, bar: tuple[float, str, list[str]], top_mm: float, row_h: float) -> float:
    """Put the bar, its ticks and its label in the row whose top is at `top_mm`; return its bottom.

    `bar` is (length on the print in mm, label, label in braille lines).
    """
    bar_mm, label, label_lines = bar
    label_w, label_h = block_size_mm(label_lines, spec)
    mid = top_mm - row_h / 2
    x0 = BORDER_MM
    plan.bar_boxes.append((x0, mid - BAR_WIDTH_MM / 2, x0 + bar_mm, mid + BAR_WIDTH_MM / 2))
    for tx in (x0, x0 + bar_mm - TICK_WIDTH_MM):
        plan.bar_boxes.append((tx, mid - TICK_LENGTH_MM / 2, tx + TICK_WIDTH_MM, mid + TICK_LENGTH_MM / 2))
    lx = x0 + bar_mm + CLEARANCE_MM
    plan.dot_centres += dot_centres(label_lines, spec, lx, mid + label_h / 2)
    placed = plan.placed
    placed.scale_bar_box = (x0, mid - TICK_LENGTH_MM / 2, x0 + bar_mm, mid + TICK_LENGTH_MM / 2)
    placed.scale_label = label
    placed.scale_label_braille = label_lines[0]
    placed.scale_label_box = (lx, mid - label_h / 2, lx + label_w, mid + label_h / 2)
    return top_mm - row_h


def build_parts(relief: Mesh, plan: Plan, base_mm: float, spec: BrailleSpec) -> list:
    """manifold3d solids for the plate, the relief moved to its origin, and each planned element."""
    import manifold3d as m3

    plate_w, plate_d = plan.placed.plate_mm
    top = base_mm
    parts = [_box(0, 0, plate_w, plate_d, 0, base_mm)]
    verts = relief.vertices + np.array([*plan.placed.relief_origin_mm, 0.0])
    parts.append(m3.Manifold(m3.Mesh(vert_properties=verts.astype(np.float32), tri_verts=relief.faces.astype(np.uint32))))
    if plan.frame_ring:
        outer, inner = plan.frame_ring
        parts.append(_box(*outer, top - 0.2, top + FRAME_HEIGHT_MM) - _box(*inner, top - 1.0, top + FRAME_HEIGHT_MM + 1.0))
    sink = min(0.4, base_mm / 2)
    dome = _dome(spec, sink)  # made before the bar: manifold3d numbers meshes in creation order
    parts += [_box(*box, top - sink, top + BAR_HEIGHT_MM) for box in plan.bar_boxes]
    parts += [dome.translate((x, y, top)) for x, y in plan.dot_centres]
    return parts


def add_furniture(relief: Mesh, width_mm: float, depth_mm: float, base_mm: float, furniture: Furniture) -> tuple[Mesh, Placed]:
    """The relief on a grown plate with the requested furniture, fused into one solid."""
    plan = plan_furniture(width_mm, depth_mm, furniture)
    parts = build_parts(relief, plan, base_mm, furniture.spec)
    plate_w, plate_d = plan.placed.plate_mm
    return _fuse(parts, plate_w, plate_d, base_mm), plan.placed


def braille_test_plate(text: str, table: str, heights_mm, diameters_mm, base_mm: float = 1.5):
    """A plate with `text` in braille once per (dot height, dot diameter), each row numbered in
    braille at its start, so a reader can pick what their printer makes legible."""
    rows = [(h, d) for h in heights_mm for d in diameters_mm]
    specs = [BrailleSpec(dot_diameter_mm=d, dot_height_mm=h) for h, d in rows]
    body = to_braille(text, table)
    lines = [to_braille(f"{i + 1}", table) + "\u2800" + body for i in range(len(rows))]
    width = max(block_size_mm([line], specs[0])[0] for line in lines) + 2 * BORDER_MM
    depth = len(rows) * specs[0].line_spacing_mm + 2 * BOTTOM_BORDER_MM
    parts = [_box(0, 0, width, depth, 0, base_mm)]
    for i, (line, spec) in enumerate(zip(lines, specs)):
        dome = _dome(spec, min(0.4, base_mm / 2))
        top_y = depth - BOTTOM_BORDER_MM - i * spec.line_spacing_mm
        parts += [dome.translate((x, y, base_mm)) for x, y in dot_centres([line], spec, BORDER_MM, top_y)]
    return _fuse(parts, width, depth, base_mm), rows, lines
