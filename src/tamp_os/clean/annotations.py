"""Burned-in annotations: the data band under SEM images, and scale-bar boxes, bars and labels
inside the picture. Detected from the pixels (vendor metadata, when it records the band, is used
first by microscopy.py); the band is cropped, everything else is inpainted so it does not print
as a raised block."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass
class Annotation:
    kind: str  # "box" (label or scale-bar box), "bar" (thin scale bar), "text"
    rows: tuple[int, int]  # first row, one past the last
    cols: tuple[int, int]

    def describe(self) -> str:
        return f"{self.kind} at rows {self.rows[0]}–{self.rows[1] - 1}, columns {self.cols[0]}–{self.cols[1] - 1}"


def _row_mode_fraction(values: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the most common value (in 256 bins over lo..hi) and the fraction of pixels in it."""
    bins = np.clip(((values - lo) / (hi - lo) * 255).astype(np.int64), 0, 255)
    rows = values.shape[0]
    keys = (np.arange(rows)[:, None] * 256 + bins).ravel()
    counts = np.bincount(keys, minlength=rows * 256).reshape(rows, 256)
    mode = counts.argmax(axis=1)
    return mode, counts[np.arange(rows), mode] / values.shape[1]


def detect_info_band(values: np.ndarray) -> tuple[int, int]:
    """(rows to remove at the top, rows to remove at the bottom) for a data band, else (0, 0).

    A data band is a run of full-width rows at an edge whose most common value (the band's
    background, nearly always white or black) covers most of each row, between 2 % and 30 % of
    the image height, plus up to 3 rows of frame line next to it.
    """
    finite = values[np.isfinite(values)]
    lo, hi = float(finite.min()), float(finite.max())
    if hi <= lo:
        return 0, 0
    filled = np.where(np.isfinite(values), values, lo)
    mode, fraction = _row_mode_fraction(filled, lo, hi)
    extreme = (mode <= 12) | (mode >= 243)
    bandlike = (fraction >= 0.6) & extreme
    h = values.shape[0]

    def run_from(order) -> int:
        count, misses, last_good = 0, 0, 0
        for r in order:
            count += 1
            if bandlike[r]:
                misses, last_good = 0, count
            else:
                misses += 1
                if misses > 6:  # a line of text may break the background for a few rows
                    break
        if not 0.02 * h <= last_good <= 0.30 * h:
            return 0
        # Bands are uniform across the image; the picture above them is not: compare to be sure.
        band_rows = list(order)[:last_good]
        if fraction[band_rows].mean() < 0.75:
            return 0
        # Swallow a thin frame line (a few rows of low variation) between band and picture.
        row_std = filled.std(axis=1) / (hi - lo)
        extra = 0
        for r in list(order)[last_good : last_good + 3]:
            if row_std[r] < 0.1:
                extra += 1
            else:
                break
        return last_good + extra

    bottom = run_from(range(h - 1, -1, -1))
    top = run_from(range(h)) if not bottom else 0
    return top, bottom


def is_arrow(solid: np.ndarray, image_size_px: int) -> bool:
    """Whether a saturated blob is a drawn arrow: a straight shaft of even width ending in a head
    at least twice as wide. Natural bright or dark features are rarely straight and of constant
    width, so this rejects sphere rims, cracks and highlights."""
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


def detect_annotations(values: np.ndarray) -> tuple[np.ndarray, list[Annotation]]:
    """Mask of burned-in annotations inside the picture, and what they are.

    Scale-bar and label boxes: saturated (white or black) regions that, with holes (their text)
    filled, are nearly perfect rectangles and do hold text. Thin bars: saturated rectangles at
    least 8x longer than tall and at most 3 % of the image high. Arrows: see is_arrow. Text near
    boxes and bars (small saturated glyphs within a box height) goes with them.
    """
    finite = np.isfinite(values)
    lo, hi = float(values[finite].min()), float(values[finite].max())
    mask = np.zeros(values.shape, bool)
    found: list[Annotation] = []
    if hi <= lo:
        return mask, found
    h, w = values.shape
    tolerance = 0.02 * (hi - lo)
    for saturated in (values >= hi - tolerance, values <= lo + tolerance):  # white, then black marks
        found_before = len(found)
        labels, n = ndimage.label(saturated)
        if n == 0:
            continue
        slices = ndimage.find_objects(labels)
        for i, sl in enumerate(slices, start=1):
            bh, bw = sl[0].stop - sl[0].start, sl[1].stop - sl[1].start
            if bh * bw < 60 or bh * bw > 0.08 * h * w or bh >= 0.5 * h or bw >= 0.9 * w:
                continue
            solid = labels[sl] == i
            if is_arrow(solid, max(h, w)):
                found.append(Annotation("arrow", (sl[0].start, sl[0].stop), (sl[1].start, sl[1].stop)))
                mask[sl] |= solid
                continue
            region = ndimage.binary_fill_holes(solid)
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
            near = np.zeros_like(mask)
            for a in labelled:
                pad = max(4, a.rows[1] - a.rows[0])
                near[max(0, a.rows[0] - pad) : a.rows[1] + pad, max(0, a.cols[0] - 3 * pad) : a.cols[1] + 3 * pad] = True
            glyphs = saturated & near & ~mask
            labels, n = ndimage.label(glyphs)
            for i, sl in enumerate(ndimage.find_objects(labels), start=1):
                bh, bw = sl[0].stop - sl[0].start, sl[1].stop - sl[1].start
                glyph = labels[sl] == i
                if bh <= 0.06 * h and bw <= 0.06 * w and glyph.sum() >= 6:  # letters, not noise specks
                    mask[sl] |= glyph
                    found.append(Annotation("text", (sl[0].start, sl[0].stop), (sl[1].start, sl[1].stop)))
    if mask.any():
        mask = ndimage.binary_dilation(mask, iterations=2)  # JPEG halos around the edges
    return mask, _merge_text(found)


def _merge_text(found: list[Annotation]) -> list[Annotation]:
    """Report text glyphs as one entry per bar/box rather than one per letter."""
    boxes = [a for a in found if a.kind != "text"]
    texts = [a for a in found if a.kind == "text"]
    if texts:
        r0 = min(a.rows[0] for a in texts)
        r1 = max(a.rows[1] for a in texts)
        c0 = min(a.cols[0] for a in texts)
        c1 = max(a.cols[1] for a in texts)
        boxes.append(Annotation("text", (r0, r1), (c0, c1)))
    return boxes


def inpaint(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Fill masked pixels with the smooth (harmonic) surface that meets their surroundings.

    Solves Laplace's equation on the masked pixels only, with the unmasked neighbours as
    boundary values: one sparse solve, about 10x faster than scikit-image's biharmonic
    inpainting on a scale-bar box and free of its overshoot.
    """
    if not mask.any():
        return values
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve

    h, w = values.shape
    finite = np.isfinite(values)
    known = values.astype(np.float64) if finite.all() else np.where(finite, values, np.nanmedian(values))
    rows, cols = np.nonzero(mask)
    index = np.full(values.shape, -1, np.int64)
    index[rows, cols] = np.arange(rows.size)
    diag = np.zeros(rows.size)
    rhs = np.zeros(rows.size)
    entries_r, entries_c = [], []
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        nr, nc = rows + dr, cols + dc
        inside = (nr >= 0) & (nr < h) & (nc >= 0) & (nc < w)
        diag += inside
        nr, nc, me = nr[inside], nc[inside], np.flatnonzero(inside)
        other = index[nr, nc]
        unknown = other >= 0
        entries_r.append(me[unknown])
        entries_c.append(other[unknown])
        np.add.at(rhs, me[~unknown], known[nr[~unknown], nc[~unknown]])
    r = np.concatenate([np.arange(rows.size)] + entries_r)
    c = np.concatenate([np.arange(rows.size)] + entries_c)
    data = np.concatenate([diag] + [-np.ones(len(e)) for e in entries_r])
    solution = spsolve(coo_matrix((data, (r, c)), shape=(rows.size, rows.size)).tocsr(), rhs)
    out = values.astype(np.float32, copy=True)
    out[rows, cols] = solution
    return out


def clean(values: np.ndarray, alpha: np.ndarray | None, *, crop_top: int, crop_bottom: int, crop_source: str, remove: bool):
    """Crop the data band and inpaint annotations. Returns (values, alpha, crop, annotations, mask).

    A band the vendor records (crop_source set) is always cropped: it is not part of the image.
    Detected bands and annotations are removed only when `remove` is true.
    """
    if not crop_source and remove:
        crop_top, crop_bottom = detect_info_band(values)
        crop_source = "detected data band" if crop_top or crop_bottom else ""
    if crop_top + crop_bottom >= values.shape[0] - 1:
        crop_top = crop_bottom = 0
        crop_source = ""
    stop = values.shape[0] - crop_bottom
    values = values[crop_top:stop]
    alpha = None if alpha is None else alpha[crop_top:stop]
    crop = {"top_rows": crop_top, "bottom_rows": crop_bottom, "left_columns": 0, "right_columns": 0, "source": crop_source or None}
    if not remove:
        return values, alpha, crop, [], None
    mask, found = detect_annotations(values)
    return inpaint(values, mask), alpha, crop, found, mask
