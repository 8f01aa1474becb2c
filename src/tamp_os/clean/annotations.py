"""Burned-in annotations inside the picture: scale-bar boxes, bars, their labels and drawn
arrows. Detected from the pixels and inpainted, so they do not print as raised blocks. (The data
band beside the picture is cropped instead: clean/band.py.)"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..facts import Facts


@dataclass(frozen=True)
class Annotation(Facts):
    kind: str  # "box" (label or scale-bar box), "bar" (thin scale bar), "text"
    rows: tuple[int, int]  # first row, one past the last
    cols: tuple[int, int]
    text: str | None = None  # a text label's words as OCR read them, "" when unreadable, None when not read

    def describe(self) -> str:
        words = "" if self.text is None else f" '{self.text}'" if self.text else " (unreadable)"
        return f"{self.kind}{words} at rows {self.rows[0]}–{self.rows[1] - 1}, columns {self.cols[0]}–{self.cols[1] - 1}"


def is_arrow(solid: np.ndarray, image_size_px: int) -> bool:
    """Whether a saturated blob is a drawn arrow: a straight shaft of even width ending in a head
    at least twice as wide. Natural bright or dark features are rarely straight and of constant
    width, so this rejects sphere rims, cracks and highlights."""
    # No blob is longer than its box's diagonal: one too small for the shortest arrow needs no SVD
    # (by a margin far above the rounding of the length measured below).
    if np.hypot(solid.shape[0] - 1, solid.shape[1] - 1) < 0.03 * image_size_px - 1e-6:
        return False
    rows, cols = np.nonzero(solid)
    if rows.size < 40:
        return False
    points = np.column_stack([rows, cols]).astype(np.float64)
    points -= points.mean(axis=0)
    _, spread, axes = np.linalg.svd(points, full_matrices=False)
    along = points @ axes[0]
    across = points @ axes[1]
    length = float(along.max() - along.min())
    if not (0.03 * image_size_px <= length <= 0.5 * image_size_px) or spread[1] <= 0 or spread[0] / spread[1] < 3:
        return False
    # Width of the blob in ten slices along its axis.
    edges = np.linspace(along.min(), along.max() + 1e-9, 11)
    widths = []
    for a, b in zip(edges[:-1], edges[1:]):
        inside = (along >= a) & (along < b)
        widths.append(float(np.ptp(across[inside])) + 1 if inside.any() else 0.0)
    widths = np.array(widths)
    shaft = widths[2:8]
    if shaft.min() <= 0 or shaft.max() > 1.5 * shaft.min() + 1 or np.median(shaft) > 0.15 * length:
        return False  # not a straight shaft of even width
    # A head at one end only, and the other end as thin as the shaft.
    shaft_width = float(np.median(shaft))
    start, end = widths[:2].max(), widths[-2:].max()
    head, tail = max(start, end), min(start, end)
    return head >= 2.0 * shaft_width and tail <= 1.5 * shaft_width + 1


def _along_edge(solid: np.ndarray, sl: tuple, shape: tuple[int, int]) -> bool:
    """Whether a blob lies along the picture's edge, its long side on the border for at least half
    its length: a slide's flat glass margin or a scan's padding, not a mark drawn on the picture
    (a drawn arrow points into the picture; at most its tail or head touches the edge)."""
    h, w = shape
    bh, bw = solid.shape
    if bw >= bh:
        sides = ([solid[0]] if sl[0].start == 0 else []) + ([solid[-1]] if sl[0].stop == h else [])
    else:
        sides = ([solid[:, 0]] if sl[1].start == 0 else []) + ([solid[:, -1]] if sl[1].stop == w else [])
    return any(side.mean() >= 0.5 for side in sides)


def detect_annotations(values: np.ndarray, arrows: bool = True) -> tuple[np.ndarray, list[Annotation]]:
    """Mask of burned-in annotations inside the picture, and what they are (`arrows`: look for
    drawn arrows too; a diagram's arrows and strokes are its content, not marks on it).

    Scale-bar and label boxes: saturated (white or black) regions that, with holes (their text)
    filled, are nearly perfect rectangles and do hold text. Thin bars: saturated rectangles at
    least 8x longer than tall and at most 3 % of the image high. Arrows: see is_arrow. Text near
    boxes and bars (small saturated glyphs within a box height) goes with them.
    """
    finite = np.isfinite(values)
    # min and max of every pixel when all are finite: the same numbers, without copying the picture
    lo, hi = (float(values.min()), float(values.max())) if finite.all() else (float(values[finite].min()), float(values[finite].max()))
    mask = np.zeros(values.shape, bool)
    found: list[Annotation] = []
    if hi <= lo:
        return mask, found
    h, w = values.shape
    tolerance = 0.02 * (hi - lo)
    white, black = values >= hi - tolerance, values <= lo + tolerance
    for saturated, other in ((white, black), (black, white)):  # white marks, then black ones
        found_before = len(found)
        labels, parts = saturated_parts(saturated)
        for i, (sl, own) in enumerate(parts, start=1):
            bh, bw = sl[0].stop - sl[0].start, sl[1].stop - sl[1].start
            if bh * bw < 60 or bh * bw > 0.08 * h * w or bh >= 0.5 * h or bw >= 0.9 * w:
                continue
            solid = labels[own] == i
            if arrows and not _along_edge(solid, sl, (h, w)) and is_arrow(solid, max(h, w)):
                found.append(Annotation("arrow", (sl[0].start, sl[0].stop), (sl[1].start, sl[1].stop)))
                mask[sl] |= solid
                continue
            # A label box is two-tone: its colour and its text's, the opposite extreme. Text or a
            # scale bar touching the box's edge is no hole, so it counts with the box here (a
            # databar of white words on black, FEI XL style, has its bar on the top edge).
            # Only a component whose four edges are mostly its own colour is taken so: a
            # rectangle's border, not a bright disc on a dark ground (its corners are the ground).
            framed = min(solid[0].mean(), solid[-1].mean(), solid[:, 0].mean(), solid[:, -1].mean()) >= 0.6
            region = filled_holes(solid | other[sl] if framed else solid)
            fill = region.sum() / (bh * bw)
            if fill < 0.95 or min(bh, bw) < 3:
                continue
            # A label box holds text (holes); a scale bar is thin and long. A plain saturated
            # rectangle with neither is more likely part of the picture: leave it.
            has_text = (region.sum() - solid.sum()) >= 0.03 * region.sum()
            thin_bar = bw >= 8 * bh and bh <= 0.03 * h
            if not (has_text or thin_bar):
                continue
            kind = "bar" if thin_bar and not has_text else "box"
            found.append(Annotation(kind, (sl[0].start, sl[0].stop), (sl[1].start, sl[1].stop)))
            mask[sl] |= region
        # Glyphs of text beside a bar or box of this colour (not inside: holes are already filled).
        labelled = [a for a in found[found_before:] if a.kind in ("box", "bar")]
        if labelled:
            found += _mark_glyphs(saturated, mask, labelled)
    if found:  # every annotation found marked the mask within its box
        mask = _grown(mask, _around(found, rows_px=2, cols_px=2), iterations=2)  # JPEG halos around the edges
    return mask, _merge_text(found)


def saturated_parts(saturated: np.ndarray) -> tuple[np.ndarray, list[tuple[tuple[slice, slice], tuple[slice, slice]]]]:
    """ndimage.label(saturated) and find_objects of it, labelled within the box holding every
    True pixel (saturated pixels are few and often in one corner: 2-10x fewer pixels to scan).
    Nothing outside the box is labelled, so the parts, their numbers (by first pixel, row by
    row) and extents are those of the whole picture, offset by the box's corner.

    Returns (labels of the box, per part: (its slices in the picture, its slices in the box)).
    """
    rows, cols = np.flatnonzero(saturated.any(axis=1)), np.flatnonzero(saturated.any(axis=0))
    if rows.size == 0:
        return np.zeros((0, 0), np.int32), []
    r0, c0 = int(rows[0]), int(cols[0])
    labels, _ = ndimage.label(saturated[r0 : int(rows[-1]) + 1, c0 : int(cols[-1]) + 1])
    parts = [((slice(sl[0].start + r0, sl[0].stop + r0), slice(sl[1].start + c0, sl[1].stop + c0)), sl) for sl in ndimage.find_objects(labels)]
    return labels, parts


def _around(found: list[Annotation], *, rows_px: int, cols_px: int) -> tuple[slice, slice]:
    """The box holding every annotation of `found` and that many pixels around (cut at the picture's top and left)."""
    rows = slice(max(0, min(a.rows[0] for a in found) - rows_px), max(a.rows[1] for a in found) + rows_px)
    return rows, slice(max(0, min(a.cols[0] for a in found) - cols_px), max(a.cols[1] for a in found) + cols_px)


def _grown(mask: np.ndarray, box: tuple[slice, slice], *, iterations: int) -> np.ndarray:
    """binary_dilation(mask, iterations=`iterations`), computed within `box`, which holds every
    True pixel and `iterations` pixels around them: nothing grows further, and the picture's edge
    stops the growth in both (nothing lies beyond it), so the result is the same, 5-10x sooner."""
    out = np.zeros_like(mask)
    out[box] = ndimage.binary_dilation(mask[box], iterations=iterations)
    return out


def filled_holes(solid: np.ndarray) -> np.ndarray:
    """ndimage.binary_fill_holes(solid) (2-D, its default structure), by one labelling of the
    background instead of a dilation repeated until nothing changes (3x sooner on a label box):
    a hole is a background part (4-connected, as that dilation grows) that touches no edge."""
    background, outside = ground_parts(~solid)
    return ~outside[background]


def ground_parts(ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ndimage.label(ground) (2-D, 4-connected) and, per label, whether that part reaches the
    picture's edge (index 0, the pixels that are not ground: False). The parts that do not are
    the holes binary_fill_holes fills."""
    labels, n = ndimage.label(ground)
    reaches_edge = np.zeros(n + 1, bool)
    for edge in (labels[0], labels[-1], labels[:, 0], labels[:, -1]):
        reaches_edge[edge] = True
    reaches_edge[0] = False
    return labels, reaches_edge


def _mark_glyphs(saturated: np.ndarray, mask: np.ndarray, labelled: list[Annotation]) -> list[Annotation]:
    """Add to `mask` (in place) the letters of the same colour beside each box or bar."""
    h, w = mask.shape
    near = np.zeros_like(mask)
    for a in labelled:
        pad = max(4, a.rows[1] - a.rows[0])
        near[max(0, a.rows[0] - pad) : a.rows[1] + pad, max(0, a.cols[0] - 3 * pad) : a.cols[1] + 3 * pad] = True
    # Labelled within the box that holds every `near` pixel: nothing outside it is labelled, so
    # the components, their order (by first pixel, row by row) and their extents are those of the
    # whole picture, offset by the box's corner.
    pad = max(max(4, a.rows[1] - a.rows[0]) for a in labelled)
    box = _around(labelled, rows_px=pad, cols_px=3 * pad)
    r0, c0 = box[0].start, box[1].start
    labels, _ = ndimage.label(saturated[box] & near[box] & ~mask[box])
    glyphs = []
    for i, sl in enumerate(ndimage.find_objects(labels), start=1):
        bh, bw = sl[0].stop - sl[0].start, sl[1].stop - sl[1].start
        glyph = labels[sl] == i
        if bh <= 0.06 * h and bw <= 0.06 * w and glyph.sum() >= 6:  # letters, not noise specks
            rows, cols = slice(sl[0].start + r0, sl[0].stop + r0), slice(sl[1].start + c0, sl[1].stop + c0)
            mask[rows, cols] |= glyph
            glyphs.append(Annotation("text", (rows.start, rows.stop), (cols.start, cols.stop)))
    return glyphs


def _inside(a: Annotation, b: Annotation) -> bool:
    return a is not b and b.rows[0] <= a.rows[0] and a.rows[1] <= b.rows[1] and b.cols[0] <= a.cols[0] and a.cols[1] <= b.cols[1]


def _merge_text(found: list[Annotation]) -> list[Annotation]:
    """Report text glyphs as one entry per bar/box rather than one per letter, and nothing that
    lies inside a box (its letters and bar are removed with it)."""
    found = [a for a in found if not any(_inside(a, b) for b in found if b.kind == "box")]
    boxes = [a for a in found if a.kind != "text"]
    texts = [a for a in found if a.kind == "text"]
    if texts:
        r0 = min(a.rows[0] for a in texts)
        r1 = max(a.rows[1] for a in texts)
        c0 = min(a.cols[0] for a in texts)
        c1 = max(a.cols[1] for a in texts)
        boxes.append(Annotation("text", (r0, r1), (c0, c1)))
    return boxes


# The fast solve of a boxed mask stops when the residual is this share of the right-hand side:
# the fill then agrees with the direct solve to about 1e-9 of the picture's range, far below a
# float32 step (6e-8 of it), so at most a last float32 digit differs.
BOX_TOLERANCE = 1e-11
BOX_FILL = 0.95  # the mask covers at least this share of its bounding box
BOX_ITERATIONS = 50  # more: the box's holes are too many for the preconditioner; the direct solve takes it


def inpaint(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Fill masked pixels with the smooth (harmonic) surface that meets their surroundings.

    Solves Laplace's equation on the masked pixels only, with the unmasked neighbours as
    boundary values, about 10x faster than scikit-image's biharmonic inpainting on a scale-bar
    box and free of its overshoot. A mask that is nearly its bounding box (a databar box, a
    label's box) away from the picture's edge is solved by conjugate gradients preconditioned
    with the box's own Laplacian, inverted by a sine transform (_fill_box: 5-10x faster than
    the sparse direct solve, which every other mask gets).
    """
    if not mask.any():
        return values
    finite = np.isfinite(values)
    # A picture finite everywhere is known as it is: only the box needs converting for its fill.
    known = None if finite.all() else np.where(finite, values, np.nanmedian(values))
    out = values.astype(np.float32, copy=True)
    bounds = _bounds(mask)
    box = _inner_box(mask, bounds)
    if box is not None:
        frame = (slice(box[0] - 1, box[1] + 1), slice(box[2] - 1, box[3] + 1))
        filled = _fill_box(values[frame].astype(np.float64) if known is None else known[frame], mask[box[0] : box[1], box[2] : box[3]])
        if filled is not None:
            out[box[0] : box[1], box[2] : box[3]][mask[box[0] : box[1], box[2] : box[3]]] = filled
            return out
    r0, r1, c0, c1 = bounds
    rows, cols = np.nonzero(mask[r0:r1, c0:c1])  # within the bounds: the same pixels in the same (row-major) order
    rows += r0
    cols += c0
    out[rows, cols] = _fill_sparse(values if known is None else known, mask, rows, cols)
    return out


def _bounds(mask: np.ndarray) -> tuple[int, int, int, int]:
    """(r0, r1, c0, c1): the bounding box of a mask with some True pixel."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _inner_box(mask: np.ndarray, bounds: tuple[int, int, int, int]) -> tuple[int, int, int, int] | None:
    """The mask's bounds when the mask fills BOX_FILL of them and a ring of known pixels lies
    around them inside the picture; else None."""
    r0, r1, c0, c1 = bounds
    if r0 < 1 or c0 < 1 or r1 > mask.shape[0] - 1 or c1 > mask.shape[1] - 1:
        return None
    return (r0, r1, c0, c1) if np.count_nonzero(mask[r0:r1, c0:c1]) >= BOX_FILL * (r1 - r0) * (c1 - c0) else None


def _fill_box(framed: np.ndarray, piece: np.ndarray) -> np.ndarray | None:
    """The harmonic fill of the `piece` pixels of a box, `framed` being the known values of the
    box and a one-pixel ring around it; None when it does not converge. Unknown pixels are the
    piece; the box's other pixels (holes) and the ring are boundary values. Conjugate gradients
    on the exact five-point system, preconditioned by the whole box's Dirichlet Laplacian (a
    sine transform): the two differ only at the holes, so a few iterations suffice."""
    import scipy.fft

    h, w = piece.shape
    eig = (4.0 - 2.0 * np.cos(np.pi * np.arange(1, h + 1) / (h + 1)))[:, None] - 2.0 * np.cos(np.pi * np.arange(1, w + 1) / (w + 1))[None, :]

    def solve_box(r):  # the whole box's Laplacian inverted, restricted to the piece
        return np.where(piece, scipy.fft.idstn(scipy.fft.dstn(r, type=1, norm="ortho") / eig, type=1, norm="ortho"), 0.0)

    def apply(u):  # the five-point operator on the piece (u is zero off it)
        return np.where(piece, 4.0 * u - (_shifted(u, 1, 0) + _shifted(u, -1, 0) + _shifted(u, 0, 1) + _shifted(u, 0, -1)), 0.0)

    boundary = np.where(piece, 0.0, framed[1:-1, 1:-1])
    ring = np.zeros_like(framed)
    ring[1:-1, 1:-1] = boundary
    ring[0, :], ring[-1, :], ring[:, 0], ring[:, -1] = framed[0, :], framed[-1, :], framed[:, 0], framed[:, -1]
    rhs = np.where(piece, ring[:-2, 1:-1] + ring[2:, 1:-1] + ring[1:-1, :-2] + ring[1:-1, 2:], 0.0)
    return _conjugate_gradients(apply, solve_box, rhs, piece)


def _shifted(u: np.ndarray, dr: int, dc: int) -> np.ndarray:
    """u moved by (dr, dc), zeros shifted in: the neighbour in that direction of every pixel."""
    out = np.zeros_like(u)
    h, w = u.shape
    out[max(dr, 0) : h + min(dr, 0), max(dc, 0) : w + min(dc, 0)] = u[max(-dr, 0) : h + min(-dr, 0), max(-dc, 0) : w + min(-dc, 0)]
    return out


def _conjugate_gradients(apply, precondition, rhs: np.ndarray, piece: np.ndarray) -> np.ndarray | None:
    """Preconditioned conjugate gradients for apply(x) = rhs on the piece; x[piece], or None.
    Inner products by NumPy's own sums, not BLAS: OpenBLAS's threads spin beside the OCR thread
    (10 ms of CPU per dot product on a busy machine for 25,000 numbers)."""

    def dot(a, b) -> float:
        return float(np.multiply(a, b).sum())

    x = precondition(rhs)
    r = rhs - apply(x)
    z = precondition(r)
    p, rz = z, dot(r, z)
    goal = (BOX_TOLERANCE**2) * dot(rhs, rhs)  # squared norms
    for _ in range(BOX_ITERATIONS):
        if dot(r, r) <= goal:
            return x[piece]
        q = apply(p)
        alpha = rz / dot(p, q)
        x, r = x + alpha * p, r - alpha * q
        z = precondition(r)
        rz, rz_old = dot(r, z), rz
        p = z + (rz / rz_old) * p
    return x[piece] if dot(r, r) <= goal else None


def _fill_sparse(known: np.ndarray, mask: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The harmonic fill of the masked pixels (rows, cols) by one sparse direct solve; pixels at
    the picture's edge have no neighbour beyond it (zero flux). `known`: the picture's values,
    read as float64."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve

    h, w = mask.shape
    # Each pixel's unknown number, over the pixels and their neighbours only (not the whole picture)
    top, left = max(int(rows.min()) - 1, 0), max(int(cols.min()) - 1, 0)
    index = np.full((min(int(rows.max()) + 2, h) - top, min(int(cols.max()) + 2, w) - left), -1, np.int64)
    index[rows - top, cols - left] = np.arange(rows.size)
    diag = np.zeros(rows.size)
    rhs = np.zeros(rows.size)
    entries_r, entries_c = [], []
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        nr, nc = rows + dr, cols + dc
        inside = (nr >= 0) & (nr < h) & (nc >= 0) & (nc < w)
        diag += inside
        nr, nc, me = nr[inside], nc[inside], np.flatnonzero(inside)
        other = index[nr - top, nc - left]
        unknown = other >= 0
        entries_r.append(me[unknown])
        entries_c.append(other[unknown])
        np.add.at(rhs, me[~unknown], known[nr[~unknown], nc[~unknown]].astype(np.float64))
    r = np.concatenate([np.arange(rows.size)] + entries_r)
    c = np.concatenate([np.arange(rows.size)] + entries_c)
    data = np.concatenate([diag] + [-np.ones(len(e)) for e in entries_r])
    # The matrix is symmetric: minimum degree on A + A^T orders it with less fill than SuperLU's
    # default (COLAMD), about 1.3-1.5x faster on a databar box, and CSC is SuperLU's own layout.
    matrix = coo_matrix((data, (r, c)), shape=(rows.size, rows.size)).tocsc()
    return spsolve(matrix, rhs, permc_spec="MMD_AT_PLUS_A")


@dataclass(frozen=True)
class Removal:
    """Annotations found in a picture and the picture without them.

    values : (H, W) float32, the masked pixels inpainted.
    mask : (H, W) bool, True where an annotation was removed.
    annotations : what was found, in plain terms (Annotation.describe()).
    """

    values: np.ndarray
    mask: np.ndarray
    annotations: list[Annotation]


def remove_annotations(values: np.ndarray) -> Removal:
    """Find burned-in boxes, bars, labels and arrows in `values` (H, W) and inpaint them."""
    mask, found = detect_annotations(values)
    return Removal(inpaint(values, mask), mask, found)
