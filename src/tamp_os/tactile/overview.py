"""The overview plate of a multi-panel figure: the layout at plate size, each panel a raised frame
with its letter in braille inside its top-left corner and a light relief of its content, so a
reader learns how the panels sit before reading each panel's own print.

Heights (mm above the base): frame FRAME_MM, content hint at most HINT_MM and kept HINT_GAP_MM
inside the frame (a finger tells the frame from the hint by both height and a gap), the letter's
corner left flat for the braille, which stands on the plate as on any caption."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .braille import BrailleSpec, block_size_mm, dot_centres, to_braille
from .furniture import CLEARANCE_MM, Furniture, Placed, build_parts, fuse_solid, plan_furniture, to_mesh

FRAME_MM = 1.0  # frame height: a standard raised line
FRAME_WIDTH_MM = 1.2
HINT_MM = 0.5  # the content's hint is at most this high: felt, but lower than the frame
HINT_GAP_MM = 2.0  # between the frame and the hint
HINT_BLUR_MM = 1.0  # the hint is the content's coarse shape only
MIN_FRAME_MM = 12.0  # a panel smaller than this on the overview cannot hold a frame and a letter


@dataclass
class OverviewPanel:
    """One panel on the overview: its box in source pixels, label and content (values, any range)."""

    box_px: tuple[int, int, int, int]
    label: str
    values: np.ndarray


@dataclass
class Overview:
    heights_mm: np.ndarray  # (rows, cols), row 0 = the figure's top = far edge
    mesh: object  # tactile furniture and braille fused: a mesh.solid.Mesh
    placed: Placed
    letters_braille: dict[str, str]  # label -> the braille written in its frame
    notes: list[str]


def overview_heights(
    figure_px: tuple[int, int],
    panels: list[OverviewPanel],
    cols: int,
    *,
    rows: int,
    width_mm: float,
    depth_mm: float,
    base_mm: float,
    spec: BrailleSpec,
    table: str,
) -> tuple[np.ndarray, dict, list[tuple[float, float]], list[str]]:
    """The overview's heightmap, the braille per label, the letters' dot centres in relief mm
    (x right, y up from the relief's bottom edge) and notes."""
    W, H = figure_px
    sx, sy = (cols - 1) / W, (rows - 1) / H  # grid px per source px
    mm = width_mm / (cols - 1)
    heights = np.full((rows, cols), base_mm, np.float64)
    letters, dots, notes = {}, [], []
    for panel in panels:
        x, y, w, h = panel.box_px
        c0, c1 = int(round(x * sx)), int(round((x + w) * sx))
        r0, r1 = int(round(y * sy)), int(round((y + h) * sy))
        if min(c1 - c0, r1 - r0) * mm < MIN_FRAME_MM:
            notes.append(
                f"panel {panel.label} is {min(c1 - c0, r1 - r0) * mm:.0f} mm on the overview, too small for a frame and its letter "
                f"(at least {MIN_FRAME_MM:g} mm); it is left flat there"
            )
            continue
        fw = max(1, int(round(FRAME_WIDTH_MM / mm)))
        top = base_mm + FRAME_MM
        heights[r0:r1, c0 : c0 + fw] = heights[r0:r1, c1 - fw : c1] = top
        heights[r0 : r0 + fw, c0:c1] = heights[r1 - fw : r1, c0:c1] = top
        gap = fw + max(1, int(round(HINT_GAP_MM / mm)))
        inner = (r0 + gap, r1 - gap, c0 + gap, c1 - gap)
        braille = to_braille(panel.label, table, what="panel letter")
        letters[panel.label] = braille
        bw, bh = block_size_mm([braille], spec)
        # The letter's corner: flat, the braille CLEARANCE_MM from the frame and from the hint.
        lx_mm, ly_mm = (c0 + fw) * mm + CLEARANCE_MM, (r0 + fw) * mm + CLEARANCE_MM  # from the left, from the top
        pad_c1 = int(np.ceil((lx_mm + bw + CLEARANCE_MM) / mm))
        pad_r1 = int(np.ceil((ly_mm + bh + CLEARANCE_MM) / mm))
        if pad_c1 > c1 - fw or pad_r1 > r1 - fw:  # the braille would touch the frame: leave it out, and say so
            del letters[panel.label]
            notes.append(
                f"panel {panel.label}'s label ({len(braille)} braille cells) does not fit inside its frame on the overview; the frame is there without it"
            )
            braille = None
        if inner[1] > inner[0] and inner[3] > inner[2]:
            hint = _hint(panel.values, inner[1] - inner[0], inner[3] - inner[2], mm)
            heights[inner[0] : inner[1], inner[2] : inner[3]] = base_mm + HINT_MM * hint
            if braille:
                heights[r0 + fw : min(pad_r1, r1 - fw), c0 + fw : min(pad_c1, c1 - fw)] = base_mm
        if braille:
            dots += dot_centres([braille], spec, lx_mm, top_mm=depth_mm - ly_mm)  # y up from the relief's bottom edge
    return heights, letters, dots, notes


def _hint(values: np.ndarray, rows: int, cols: int, mm_per_px: float) -> np.ndarray:
    """The panel's content at the hint's grid size, contrast stretched and blurred to its coarse
    shape, 0..1."""
    from PIL import Image

    finite = np.isfinite(values)
    if not finite.any():
        return np.zeros((rows, cols))
    lo, hi = np.percentile(values[finite], [2, 98])
    scaled = np.clip((np.where(finite, values, lo) - lo) / max(hi - lo, 1e-12), 0, 1).astype(np.float32)
    small = np.asarray(Image.fromarray(scaled).resize((cols, rows), Image.Resampling.BOX), dtype=np.float64)
    return np.clip(ndimage.gaussian_filter(small, HINT_BLUR_MM / mm_per_px), 0, 1)


def build_overview(
    figure_px,
    panels: list[OverviewPanel],
    cols: int,
    *,
    rows: int,
    width_mm: float,
    depth_mm: float,
    base_mm: float,
    furniture: Furniture,
    mesher: str,
    max_error_mm: float,
) -> Overview:
    """The overview as one closed solid: the heightmap on its plate, the furniture (caption,
    cut corner) and each panel's letter in braille inside its frame."""
    from ..mesh.adaptive import adaptive_solid
    from ..mesh.solid import grid_solid

    heights, letters, dots, notes = overview_heights(
        figure_px, panels, cols, rows=rows, width_mm=width_mm, depth_mm=depth_mm, base_mm=base_mm, spec=furniture.spec, table=furniture.braille_table
    )
    relief = adaptive_solid(heights, width_mm, depth_mm, max_error_mm=max_error_mm) if mesher == "adaptive" else grid_solid(heights, width_mm, depth_mm)
    plan = plan_furniture(width_mm, depth_mm, furniture)
    ox, oy = plan.placed.relief_origin_mm
    plan.dot_centres += [(ox + x, oy + y) for x, y in dots]
    plan.placed.dots = len(plan.dot_centres)
    parts = build_parts(relief, plan, base_mm, spec=furniture.spec)
    top = max(float(heights.max()), base_mm + max(FRAME_MM, furniture.spec.dot_height_mm, 1.0))
    return Overview(heights, to_mesh(fuse_solid(parts, plan.placed, top)), plan.placed, letters, notes)
