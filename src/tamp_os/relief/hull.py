"""Convex hulls of labelled objects, as pixel masks, and their solidity.

The same pixels as scikit-image's `convex_hull_image` (the hull of every pixel's edge
midpoints, pixels whose centre lies inside or on it), drawn row by row in exact integer
arithmetic. scikit-image tests every pixel of the box against every hull edge
(`grid_points_in_poly`): 10-14 ms for a 240 × 240 region, most of an object search's budget;
here one interval per row costs well under a millisecond. The hull itself is still qhull's.
Where only the hulls' sizes are asked (solidity), hull_pixels finds every label's hull at once,
as two chains of row ends, with no qhull and no Python loop over labels: the same pixel counts.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull


def convex_hull_mask(mask: np.ndarray) -> np.ndarray:
    """Pixels of the convex hull of a (rows, cols) bool mask with at least one pixel set.

    A pixel (r, c) counts as the diamond of its edge midpoints (r ± 0.5, c), (r, c ± 0.5); in
    doubled coordinates (2r, 2c) these are integers, so every test here is exact.
    """
    rows, cols = mask.shape
    row = np.flatnonzero(mask.any(axis=1))
    # The hull of a row's run is the hull of its two ends: only their outer midpoints count.
    # (Midpoints shared by neighbouring rows are repeated; qhull takes repeats in 2-D.)
    first = np.argmax(mask[row], axis=1)
    last = cols - 1 - np.argmax(mask[row, ::-1], axis=1)
    r2, f2, l2 = 2 * row, 2 * first, 2 * last
    points = np.stack(
        [np.concatenate([r2 - 1, r2 + 1, r2, r2 - 1, r2 + 1, r2]), np.concatenate([f2, f2, f2 - 1, l2, l2, l2 + 1])], 1
    )
    corners = points[ConvexHull(points).vertices]
    return _fill_polygon(corners, rows, cols)


def _fill_polygon(corners: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Pixels whose centre is inside or on the convex polygon `corners` ((V, 2) int, doubled
    (row, col) coordinates, in order around it), as a (rows, cols) bool mask."""
    start = corners
    step = np.roll(corners, -1, axis=0) - corners
    area2 = np.sum(start[:, 0] * step[:, 1] - start[:, 1] * step[:, 0])
    if area2 < 0:  # clockwise: walk the other way, so the inside is on the left of every edge
        start, step = corners[::-1], np.roll(corners[::-1], -1, axis=0) - corners[::-1]
    d_row, d_col = step[:, 0], step[:, 1]
    # Inside on the left: d_row * (C - c0) - d_col * (R - r0) >= 0 at the doubled centre (R, C).
    R = 2 * np.arange(rows, dtype=np.int64)[:, None]
    num = d_row * start[:, 1] + d_col * (R - start[:, 0])  # the bound on d_row * C, (rows, V)
    lo = np.full(rows, 0, np.int64)
    hi = np.full(rows, cols - 1, np.int64)
    up, down, flat = d_row > 0, d_row < 0, d_row == 0
    if up.any():  # C >= num / d_row, so c >= ceil(num / (2 d_row))
        lo = np.maximum(lo, (-((-num[:, up]) // (2 * d_row[up]))).max(axis=1))
    if down.any():  # C <= num / d_row (d_row < 0), so c <= floor(num / (2 d_row))
        hi = np.minimum(hi, (num[:, down] // (2 * d_row[down])).min(axis=1))
    if flat.any():  # an edge along a row leaves out the rows beyond it
        outside = (num[:, flat] > 0).any(axis=1)
        hi = np.where(outside, -1, hi)
    c = np.arange(cols)
    return (c >= lo[:, None]) & (c <= hi[:, None])


def labelled_hulls(
    labels: np.ndarray, which: np.ndarray, boxes: list | None = None
) -> Iterator[tuple[int, tuple[slice, slice], np.ndarray, float]]:
    """For each label k with which[k] (bool, index 0 = background, ignored):
    (k, its bounding box, the hull mask within the box, solidity = area / hull area).
    `boxes`, if given, is ndimage.find_objects(labels, max_label=which.size - 1)."""
    if boxes is None:
        boxes = ndimage.find_objects(labels, max_label=which.size - 1)
    for k in np.flatnonzero(which[1:]) + 1:
        box = boxes[k - 1]
        if box is None:
            continue
        region = labels[box] == k
        hull = convex_hull_mask(region)
        yield int(k), box, hull, float(region.sum()) / float(hull.sum())


def solid_enough(labels: np.ndarray, candidates: np.ndarray, min_solidity: float) -> np.ndarray:
    """`candidates` (bool per label 0..n) less the labels whose solidity is under min_solidity.

    Solidity is at least area / bounding-box area, and at least area / bounding-octagon area
    (see octagon_px), so the hull, the costly part, is drawn only for the labels where both
    bounds leave doubt.
    """
    area = np.bincount(labels.ravel(), minlength=candidates.size)
    boxes = ndimage.find_objects(labels, max_label=candidates.size - 1)
    box_area = np.array([1] + [(b[0].stop - b[0].start) * (b[1].stop - b[1].start) if b else 1 for b in boxes])
    doubt = candidates & (area < min_solidity * box_area)
    if doubt.any():
        doubt &= area < min_solidity * octagon_px(labels, doubt, boxes)
    out = candidates.copy()
    doubt &= area > 0  # a label without pixels keeps its place, as it has no hull
    if doubt.any():
        hull = hull_pixels(labels, doubt)  # all the hulls at once: solidity needs their sizes only
        asked = np.flatnonzero(doubt)
        out[asked] = area[asked] / hull[asked] >= min_solidity
    return out


def octagon_px(labels: np.ndarray, which: np.ndarray, boxes: list) -> np.ndarray:
    """Per label (index 0 = background): the pixels of its bounding octagon (box and diagonal
    extents), which hold every pixel of its convex hull as convex_hull_mask draws it (a hull
    pixel's centre lies within half a pixel of the label's extents in r, c, r + c and r - c,
    and those are whole numbers); for labels not in `which`, or whose corner cuts overlap, the
    box's pixels. A bound the hull's count never exceeds, for all labels in one pass."""
    n = which.size - 1
    out = np.array([1] + [(b[0].stop - b[0].start) * (b[1].stop - b[1].start) if b else 1 for b in boxes], np.float64)
    rows, cols = np.nonzero(which[labels])
    if rows.size == 0:
        return out
    lab = labels[rows, cols].astype(np.intp)
    big = np.iinfo(np.int64).max
    s, d = rows + cols, rows - cols
    s_min = np.full(n + 1, big)
    s_max = np.full(n + 1, -big)
    d_min = np.full(n + 1, big)
    d_max = np.full(n + 1, -big)
    np.minimum.at(s_min, lab, s)
    np.maximum.at(s_max, lab, s)
    np.minimum.at(d_min, lab, d)
    np.maximum.at(d_max, lab, d)
    for k in np.flatnonzero(which[1:]) + 1:
        b = boxes[k - 1]
        if b is None:
            continue
        r0, r1, c0, c1 = b[0].start, b[0].stop - 1, b[1].start, b[1].stop - 1
        h, w = r1 - r0 + 1, c1 - c0 + 1
        # Corner cuts: lattice points of the box beyond each diagonal extent (right triangles).
        cut = np.array([s_min[k] - (r0 + c0), (r1 + c1) - s_max[k], d_min[k] - (r0 - c1), (r1 - c0) - d_max[k]])
        tl, br, tr, bl = cut  # r + c small: top left; large: bottom right; r - c small: top right; large: bottom left
        if cut.min() < 0 or cut.max() > min(h, w) or tl + tr > w or bl + br > w or tl + bl > h or tr + br > h \
                or tl + br > h + w - 1 or tr + bl > h + w - 1:
            continue  # the cuts would overlap: keep the box's count
        out[k] = h * w - float(np.sum(cut * (cut + 1) // 2))
    return out


def hull_pixels(labels: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Per label 0..which.size - 1: the pixels of its convex hull as convex_hull_mask draws it,
    for the labels with which[k] (0 for the others), all labels at once.

    A hull's rows run from its left chain to its right chain: the convex minorant of the rows'
    left ends and the concave majorant of their right ends (in doubled coordinates, the edge
    midpoints convex_hull_mask takes; a right end lies right of the left end of its own row, so
    it never shapes the left chain). Each chain is found by dropping, all labels and all points
    at once, every point on or beyond the chord of its two neighbours until none is (such a
    point is no corner of the chain, whatever else is dropped), then each pixel row's ends
    follow in exact integer arithmetic: the same pixels as qhull's hull filled row by row.
    """
    out = np.zeros(which.size, np.int64)
    rows = hull_rows(labels, which)
    if rows is not None:
        lab, _, lo, hi = rows
        np.add.at(out, lab, np.maximum(hi - lo + 1, 0))
    return out


def hull_rows(labels: np.ndarray, which: np.ndarray) -> tuple[np.ndarray, ...] | None:
    """(label, row, first column, last column) of every pixel row of the hulls of the labels with
    which[k], from each label's first row to its last (a row's last column under its first: none
    of the hull in that row), as hull_pixels finds them; None when no label is asked."""
    rows, cols = np.nonzero(which[labels])
    if rows.size == 0:
        return None
    lab = labels[rows, cols].astype(np.int64)
    # Each (label, row)'s first and last column: pixels come row by row, columns rising.
    order = np.argsort(lab * labels.shape[0] + rows, kind="stable")
    lab, rows, cols = lab[order], rows[order].astype(np.int64), cols[order].astype(np.int64)
    key = lab * labels.shape[0] + rows
    starts = np.flatnonzero(np.concatenate([[True], key[1:] != key[:-1]]))
    ends = np.concatenate([starts[1:], [key.size]]) - 1
    lab, row, first, last = lab[starts], rows[starts], cols[starts], cols[ends]
    left = _chain(lab, row, 2 * first, -1, np.minimum)
    right = _chain(lab, row, 2 * last, 1, np.maximum)
    # Every pixel row of each label, from its first row to its last.
    top = np.full(which.size, np.iinfo(np.int64).max)
    bottom = np.full(which.size, -1)
    np.minimum.at(top, lab, row)
    np.maximum.at(bottom, lab, row)
    asked = np.flatnonzero(bottom >= 0)
    height = bottom[asked] - top[asked] + 1
    q_lab = np.repeat(asked, height)
    q_row = top[q_lab] + np.arange(height.sum()) - np.repeat(np.cumsum(height) - height, height)
    return q_lab, q_row, _chain_at(left, q_lab, 2 * q_row, ceil=True), _chain_at(right, q_lab, 2 * q_row, ceil=False)


def _chain(lab: np.ndarray, row: np.ndarray, x2: np.ndarray, side: int, pick) -> tuple[np.ndarray, ...]:
    """(label, doubled row Y, doubled column X) of each label's left (side -1, `pick` np.minimum)
    or right (side 1, np.maximum) chain's corners, sorted by label then Y. The points: each row's
    end midpoints (2r - 1, x), (2r, x + side), (2r + 1, x); of two at one Y (the bottom of a row,
    the top of the next), the outer one."""
    y = np.stack([2 * row - 1, 2 * row, 2 * row + 1], axis=1).ravel()
    x = np.stack([x2, x2 + side, x2], axis=1).ravel()
    g = np.repeat(lab, 3)
    same = np.concatenate([[False], (g[1:] == g[:-1]) & (y[1:] == y[:-1])])
    keep = ~same
    starts = np.flatnonzero(keep)
    x = pick.reduceat(x, starts)
    y, g = y[starts], g[starts]
    while True:
        inner = np.flatnonzero((g[1:-1] == g[:-2]) & (g[1:-1] == g[2:])) + 1
        if inner.size == 0:
            break
        a, b, c = inner - 1, inner, inner + 1
        # side * (X_b - chord at Y_b) >= 0: on the chord of its neighbours or beyond it (outward is
        # smaller X on the left, larger on the right): no corner.
        beyond = side * ((x[b] - x[a]) * (y[c] - y[a]) - (x[c] - x[a]) * (y[b] - y[a])) <= 0
        if not beyond.any():
            break
        drop = np.zeros(y.size, bool)
        drop[b[beyond]] = True
        y, x, g = y[~drop], x[~drop], g[~drop]
    return g, y, x


def _chain_at(chain: tuple[np.ndarray, ...], lab: np.ndarray, y: np.ndarray, *, ceil: bool) -> np.ndarray:
    """The pixel column where each label's chain crosses doubled row y (strictly inside the
    chain's rows), rounded inwards: ceil on the left chain, floor on the right."""
    g, cy, cx = chain
    span = int(max(cy.max(), y.max()) - min(cy.min(), y.min())) + 1
    base = min(int(cy.min()), int(y.min()))
    key = g * span + (cy - base)
    j = np.searchsorted(key, lab * span + (y - base), side="right") - 1
    y0, y1, x0, x1 = cy[j], cy[j + 1], cx[j], cx[j + 1]
    num = x0 * (y1 - y) + x1 * (y - y0)
    den = 2 * (y1 - y0)
    return -((-num) // den) if ceil else num // den
