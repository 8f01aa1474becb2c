"""Reading a swell-paper PDF back: the texture dots as drawn, and how they cover each region.

The dots are read from the PDF's page content (pypdf), not from the code that placed them: every
filled sub-path of four Bézier curves whose extent is a texture dot's diameter is one dot, its
centre in plate millimetres (origin bottom-left, as the Graphic2D's), through the page's `cm`
transforms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MM_PER_PT = 25.4 / 72


def _mul(a, b):
    """The product of two PDF matrices [a b c d e f] (a applied first)."""
    return [a[0] * b[0] + a[1] * b[2], a[0] * b[1] + a[1] * b[3], a[2] * b[0] + a[3] * b[2], a[2] * b[1] + a[3] * b[3],
            a[4] * b[0] + a[5] * b[2] + b[4], a[4] * b[1] + a[5] * b[3] + b[5]]


def filled_round_dots_mm(pdf_path, *, page: int = 0, offset_mm=(0.0, 0.0)) -> list[tuple[float, float, float]]:
    """(x, y, diameter) in mm of every filled round dot (four curves, as wide as high) on a page."""
    import pypdf

    content = pypdf.PdfReader(str(pdf_path)).pages[page].get_contents()
    ops = pypdf.generic.ContentStream(content, None).operations
    ctm, stack, sub, subs, dots = [1, 0, 0, 1, 0, 0], [], None, [], []
    for operands, op in ops:
        op = op.decode("latin-1")
        nums = [float(v) for v in operands] if op in ("cm", "m", "l", "c", "re") else []
        if op == "q":
            stack.append(ctm)
        elif op == "Q":
            ctm = stack.pop()
        elif op == "cm":
            ctm = _mul(nums, ctm)
        elif op == "m":
            sub = {"points": [nums], "curves": 0, "lines": 0}
            subs.append(sub)
        elif op in ("l", "c") and sub is not None:
            sub["points"].append(nums[-2:])
            sub["curves" if op == "c" else "lines"] += 1
        elif op in ("f", "f*", "F", "b", "B", "S", "s", "n"):
            for s in subs if op in ("f", "f*", "F") else []:
                if s["curves"] == 4 and s["lines"] == 0:
                    pts = np.array(s["points"])
                    pts = np.column_stack([pts[:, 0] * ctm[0] + pts[:, 1] * ctm[2] + ctm[4],
                                           pts[:, 0] * ctm[1] + pts[:, 1] * ctm[3] + ctm[5]]) * MM_PER_PT
                    w, h = np.ptp(pts, axis=0)
                    if abs(w - h) < 0.02 * max(w, h):
                        centre = (pts.min(axis=0) + pts.max(axis=0)) / 2
                        dots.append((centre[0] - offset_mm[0], centre[1] - offset_mm[1], float(w)))
            subs, sub = [], None
    return dots


@dataclass(frozen=True)
class DotCover:
    """How one region's dots cover it: count, dots per 100 mm², the closest two dots' distance and
    the share of the region within `reach_mm` of a dot."""

    area_mm2: float
    dots: int
    per_100_mm2: float
    min_spacing_mm: float | None
    share_within_reach: float


def dot_cover(region: np.ndarray, mm_per_px: float, origin_mm, dots_mm: np.ndarray, *, reach_mm: float = 3.0) -> DotCover:
    """The cover of `region` (a bool map whose top row is at the far edge) by the dots that lie in it."""
    from scipy import ndimage
    from scipy.spatial import cKDTree

    rows, cols = region.shape
    dots_mm = np.asarray(dots_mm, float).reshape(-1, 2)
    c = np.floor((dots_mm[:, 0] - origin_mm[0]) / mm_per_px).astype(int)
    r = rows - 1 - np.floor((dots_mm[:, 1] - origin_mm[1]) / mm_per_px).astype(int)
    inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    inside[inside] = region[r[inside], c[inside]]
    mine = dots_mm[inside]
    area = float(region.sum()) * mm_per_px**2
    spacing = None
    if len(mine) >= 2:
        spacing = float(cKDTree(mine).query(mine, 2)[0][:, 1].min())
    hit = np.zeros(region.shape, bool)
    hit[r[inside], c[inside]] = True
    near = ndimage.distance_transform_edt(~hit) * mm_per_px <= reach_mm if hit.any() else hit
    share = float((near & region).sum() / max(region.sum(), 1))
    return DotCover(area, len(mine), 100 * len(mine) / area if area else 0.0, spacing, share)
