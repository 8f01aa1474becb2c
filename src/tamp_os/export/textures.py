"""Region map -> the vector shapes of a tactile graphic: outlines, dot textures, line textures.

Every shape is in plate millimetres (origin bottom-left, +y to the far edge; the map's top row at
the far edge). Textures keep INSET_MM from their region's outline so a finger feels the outline
as its own line; regions too small to feel are merged into their neighbours first. Three
textures that differ by touch: outline only, outline + dots, outline + parallel lines. No solid
fills: on swell paper large black areas blister.

Dots fill a region's wide parts on a plate-aligned grid; its thin parts (a cytoplasm's strips
between nuclei, where the grid finds no room) take dots along their middle, nearer the outline
(THIN_INSET_MM) but still with clear paper between dot and line. Dots of one pattern keep
DOT_PITCH_MM apart, centre to centre, wherever they lie.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

OUTLINE_MM = 0.8  # outline line width (at least 0.5 mm to be felt)
DOT_DIAMETER_MM = 1.0  # texture dots: smaller than braille dots (1.5 mm) so the two are not confused
DOT_PITCH_MM = 3.0
LINE_WIDTH_MM = 0.6
LINE_PITCH_MM = 2.5  # centre to centre, perpendicular to the lines
LINE_ANGLE_DEG = 45.0  # diagonal, so texture lines are not mistaken for outline edges
MIN_SEGMENT_MM = 2.0
INSET_MM = 1.5  # clear gap between an outline and the texture inside it
MIN_DOT_GAP_MM = 0.4  # clear paper between a thin part's dot and the outline's stroke, so each is felt apart
THIN_INSET_MM = OUTLINE_MM / 2 + MIN_DOT_GAP_MM  # from a region's edge to a thin part's dot (the outline is centred on the edge)
MIN_AREA_MM2 = 6.0  # smaller regions are merged into the nearest larger one
TEXTURES = ("outline", "dots", "lines")


def merge_small_regions(regions: np.ndarray, mm_per_px: float, min_area_mm2: float = MIN_AREA_MM2) -> np.ndarray:
    """Give connected regions smaller than min_area_mm2 the value of the nearest larger region.

    Parameters
    ----------
    regions : (rows, cols) int array
    mm_per_px : pixel size on paper (mm)

    Returns
    -------
    (rows, cols) int array, a copy
    """
    from skimage.measure import label

    components = label(regions, background=-1, connectivity=1)  # background -1: zeros are regions too
    areas_mm2 = np.bincount(components.ravel()) * mm_per_px**2
    small = areas_mm2[components] < min_area_mm2
    out = np.array(regions, copy=True)
    if small.all() or not small.any():
        return out
    _, (ri, ci) = ndimage.distance_transform_edt(small, return_indices=True)
    out[small] = out[ri[small], ci[small]]
    return out


def _to_mm(rows_px: np.ndarray, cols_px: np.ndarray, n_rows: int, mm_per_px: float, origin_mm) -> np.ndarray:
    """(N, 2) x, y in mm for pixel coordinates (pixel centres at integers, row 0 at the far edge)."""
    x = origin_mm[0] + (cols_px + 0.5) * mm_per_px
    y = origin_mm[1] + (n_rows - rows_px - 0.5) * mm_per_px
    return np.column_stack([x, y])


def outlines_mm(regions: np.ndarray, value: int, mm_per_px: float, *, origin_mm, tolerance_mm: float = 0.15) -> list[np.ndarray]:
    """Closed outlines of the pixels equal to `value`, as (N, 2) polylines in mm (first = last point)."""
    from skimage.measure import approximate_polygon, find_contours

    mask = np.pad(regions == value, 1)  # a clear border closes every contour
    polylines = []
    for contour in find_contours(mask.astype(np.float32), 0.5):
        simple = approximate_polygon(contour, tolerance=tolerance_mm / mm_per_px)
        if len(simple) >= 3:
            polylines.append(_to_mm(simple[:, 0] - 1, simple[:, 1] - 1, regions.shape[0], mm_per_px, origin_mm))
    return polylines


def _inner_distance_mm(mask: np.ndarray, mm_per_px: float) -> np.ndarray:
    """Distance from each pixel centre to the region's boundary (mm); 0 outside."""
    inside = ndimage.distance_transform_edt(np.pad(mask, 1))[1:-1, 1:-1] * mm_per_px
    return np.where(mask, inside - mm_per_px / 2, 0.0)


def _lookup(field: np.ndarray, x: np.ndarray, y: np.ndarray, mm_per_px: float, origin_mm) -> np.ndarray:
    """Values of a (rows, cols) field at points in mm; 0 outside the picture."""
    rows, cols = field.shape
    c = np.floor((x - origin_mm[0]) / mm_per_px).astype(np.int64)
    r = rows - 1 - np.floor((y - origin_mm[1]) / mm_per_px).astype(np.int64)
    inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    out = np.zeros(np.shape(x), dtype=field.dtype)
    out[inside] = field[r[inside], c[inside]]
    return out


def texture_dots_mm(mask: np.ndarray, mm_per_px: float, origin_mm) -> np.ndarray:
    """(N, 2) centres (mm) of texture dots: on a plate-aligned grid where a dot lies wholly INSET_MM
    inside the region, then along the parts the grid leaves bare, THIN_INSET_MM inside; every two
    dots at least DOT_PITCH_MM apart."""
    rows, cols = mask.shape
    x0, y0 = origin_mm
    room_px = _inner_distance_mm(mask, mm_per_px)
    xs = np.arange(np.ceil(x0 / DOT_PITCH_MM), np.floor((x0 + cols * mm_per_px) / DOT_PITCH_MM) + 1) * DOT_PITCH_MM
    ys = np.arange(np.ceil(y0 / DOT_PITCH_MM), np.floor((y0 + rows * mm_per_px) / DOT_PITCH_MM) + 1) * DOT_PITCH_MM
    gx, gy = np.meshgrid(xs, ys)
    room = _lookup(room_px, gx, gy, mm_per_px, origin_mm)
    keep = room >= INSET_MM + DOT_DIAMETER_MM / 2
    grid = np.column_stack([gx[keep], gy[keep]])
    return np.vstack([grid, _dots_along_thin_parts(room_px, grid, mm_per_px, origin_mm)])


def _dots_along_thin_parts(room_mm: np.ndarray, placed_mm: np.ndarray, mm_per_px: float, origin_mm) -> np.ndarray:
    """(N, 2) dot centres (mm) at pixel centres with room for a dot THIN_INSET_MM inside the region
    and DOT_PITCH_MM from every dot placed before: the deepest first, so dots run along a strip's
    middle; every such pixel ends within DOT_PITCH_MM of a dot."""
    rows, cols = room_mm.shape
    reach_px = DOT_PITCH_MM / mm_per_px
    span = int(np.ceil(reach_px)) + 1  # one more than the disk: a window centred a pixel off still holds it
    dr, dc = np.mgrid[-span : span + 1, -span : span + 1]
    blocked = np.zeros((rows + 2 * span, cols + 2 * span), bool)  # padded: a disk near the edge needs no clipping

    def block(r: float, c: float) -> None:
        r0, c0 = min(max(int(round(r)), 0), rows - 1), min(max(int(round(c)), 0), cols - 1)
        near = (dr + r0 - r) ** 2 + (dc + c0 - c) ** 2 < reach_px**2 - 1e-6
        blocked[r0 : r0 + 2 * span + 1, c0 : c0 + 2 * span + 1] |= near

    for x, y in placed_mm:  # pixel (r, c) has its centre at c + 0.5, rows - r - 0.5 pixels from the origin
        block(rows - 0.5 - (y - origin_mm[1]) / mm_per_px, (x - origin_mm[0]) / mm_per_px - 0.5)
    ok = room_mm >= THIN_INSET_MM + DOT_DIAMETER_MM / 2 - 1e-9
    ok &= ~blocked[span : span + rows, span : span + cols]
    rr, cc = np.nonzero(ok)
    order = np.lexsort((cc, rr, -room_mm[rr, cc]))
    chosen = []
    for r, c in zip(rr[order], cc[order]):
        if not blocked[r + span, c + span]:
            chosen.append((r, c))
            block(float(r), float(c))
    if not chosen:
        return np.zeros((0, 2))
    r, c = np.array(chosen).T
    return _to_mm(r, c, rows, mm_per_px, origin_mm)


def texture_lines_mm(mask: np.ndarray, mm_per_px: float, origin_mm) -> list[tuple[np.ndarray, np.ndarray]]:
    """Parallel line segments ((x0, y0), (x1, y1)) in mm filling the region, INSET_MM inside it."""
    rows, cols = mask.shape
    angle = np.radians(LINE_ANGLE_DEG)
    along, across = np.array([np.cos(angle), np.sin(angle)]), np.array([-np.sin(angle), np.cos(angle)])
    corners = np.array([[0, 0], [cols, 0], [0, rows], [cols, rows]]) * mm_per_px + np.asarray(origin_mm)
    # Offsets are multiples of the pitch from the plate origin, so neighbouring regions' lines align.
    k = np.arange(np.floor((corners @ across).min() / LINE_PITCH_MM), np.ceil((corners @ across).max() / LINE_PITCH_MM) + 1)
    step = mm_per_px / 2
    t = np.arange((corners @ along).min(), (corners @ along).max() + step, step)
    px = k[:, None] * LINE_PITCH_MM * across[0] + t[None, :] * along[0]
    py = k[:, None] * LINE_PITCH_MM * across[1] + t[None, :] * along[1]
    room = _lookup(_inner_distance_mm(mask, mm_per_px), px, py, mm_per_px, origin_mm)
    ok = np.pad(room >= INSET_MM + LINE_WIDTH_MM / 2, ((0, 0), (1, 1)))
    segments = []
    for i, row in enumerate(np.diff(ok.astype(np.int8), axis=1)):
        for start, stop in zip(np.flatnonzero(row == 1), np.flatnonzero(row == -1) - 1):
            if (stop - start) * step >= MIN_SEGMENT_MM:
                segments.append((np.array([px[i, start], py[i, start]]), np.array([px[i, stop], py[i, stop]])))
    return segments
