"""Panels of a multi-panel figure (journal figures, posters, slides): where each panel is, and the
letter it carries. Pure functions of the pixels; printing the panels is figure.py's job.

How a layout is found, and why a single micrograph is never split:
- Gutters are straight bands of ONE constant colour (white or black) that run the whole length of
  the region they divide: at least LINE_SHARE of every line within GUTTER_TOL of pure white or
  black. Natural structure (grain boundaries, cell walls, specimen edges, noise) never holds a
  constant value along a whole row, so it never makes a gutter. The figure is cut recursively
  along such bands (an XY cut), margins trimmed.
- A piece is a panel when it is a rectangular picture: its four edges are mostly not gutter colour
  (a picture cut straight), and it is mostly not gutter colour inside. Thin pieces of mostly gutter
  colour are text (a title strip, a label, a data band's lines): a wide one directly under a panel
  is that panel's data band and goes with it; the others are left out.
- A split needs at least two such panels. Then regularity finds the rest: where the panels found
  share a width and a pitch, a grid cell with content that lines up with them (a dark
  fluorescence panel on a black gutter, whose edges are as black as the gutter) is a panel too.
- Letters (a, b, c / A, B, C / (a)) are read by Tesseract in each panel's corners, from isolated
  glyphs on a plain ground (a white label box, the gutter); letters that do not read fall back
  to numbers, and the layout says so.
When fewer than two panels are found, the figure is whole and `reason` says why.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..texts import GRID, MAX_PANELS, MIN_BOX_SHARE, Box, min_box_px, parse_boxes, parse_grid  # noqa: F401  (re-exported)
from . import ocr

GUTTER_TOL = 0.03  # a gutter pixel is within this share of the range from pure white or black
LINE_SHARE = 0.98  # share of a line's pixels that must be gutter colour for the line to be gutter
EDGE_SHARE = 0.5  # a panel's edge lines hold at most this share of gutter colour (a straight cut)
INSIDE_SHARE = 0.6  # a panel holds at most this share of gutter colour inside
TEXT_SIDE_SHARE = 0.12  # text strips are thinner than this share of the figure's shorter side
BAND_WIDTH_SHARE = 0.5  # a data band is at least this share of its panel's width
MAX_DEPTH = 6  # cuts nested at most this deep (a grid of grids)
# A panel's shorter side is at least this share of the figure's shorter side: 5 %, twice what a
# given box needs (texts.MIN_BOX_SHARE says why).
MIN_PANEL_SHARE = 2 * MIN_BOX_SHARE
MAX_DETECT_PIXELS = 3.2e6  # larger figures are cut on every few pixels, then the edges found at full resolution
SIZE_TOL = 0.02  # widths and pitches agree within this share
LETTER_WHITELIST = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ()"
OCR_LINE_PX = 30  # glyph height on the page Tesseract reads
MAX_SINGLE_CALLS = 8  # glyphs read one by one at most (each 30 ms in process, 0.4 s by the command)


@dataclass(frozen=True)
class Panel:
    """One panel: its box in source pixels, its label and how both were found.

    box_px : (x, y, w, h), x from the left, y from the top of the figure.
    label : the letter read ("a", "B"), inferred, or a number ("1") when no letter is known.
    letter_read : the label is a letter read by OCR in the panel's corner.
    found_by : "gutters", "regular grid" (found from its neighbours), "content" (edges mostly
        background), "forced grid" (panels = RxC), or "given" (recorded boxes).
    """

    box_px: Box
    label: str
    letter_read: bool = False
    found_by: str = "gutters"

    @property
    def x(self) -> int:
        return self.box_px[0]

    @property
    def y(self) -> int:
        return self.box_px[1]

    @property
    def w(self) -> int:
        return self.box_px[2]

    @property
    def h(self) -> int:
        return self.box_px[3]


@dataclass(frozen=True)
class PanelLayout:
    """The layout of a figure.

    split : the figure is several panels (False: print it whole).
    panels : in reading order (rows top to bottom, left to right); empty when not split.
    rows : panels grouped by rows of the layout (indices into `panels`).
    gutter : "white" or "black" (None when not split).
    reason : when not split, why, in one sentence; when split, how the layout was found.
    ambiguous : not split although something suggests a figure (gutters cut it into a rectangular
        picture and another piece of picture size, or into overlapping pieces): worth a warning.
        A single picture (no such piece: its only rectangular piece, if any, with text strips such
        as its own data band) is not, and the front ends say nothing about figures for it.
    notes : what a reader should know (left-out strips, letters that did not read).
    figure_px : (width, height) of the figure.
    seconds : time taken.
    """

    split: bool
    panels: tuple[Panel, ...] = ()
    rows: tuple[tuple[int, ...], ...] = ()
    gutter: str | None = None
    reason: str = ""
    notes: tuple[str, ...] = ()
    figure_px: tuple[int, int] = (0, 0)
    seconds: float = 0.0
    ambiguous: bool = False

    def boxes(self) -> list[Box]:
        return [p.box_px for p in self.panels]

    def labels(self) -> list[str]:
        return [p.label for p in self.panels]

    def record(self) -> str:
        """The boxes as the `panel_boxes` parameter records them: 'a=x,y,w,h;b=...'."""
        def key(p: Panel) -> str:  # a letter inferred, not read, is marked with *
            return p.label + ("*" if p.label.isalpha() and not p.letter_read else "")

        return ";".join(f"{key(p)}={','.join(str(v) for v in p.box_px)}" for p in self.panels)


# ---------------------------------------------------------------------------------------------
# The public functions


def detect_panels(values: np.ndarray, rgb: np.ndarray | None = None, *, read_letters: bool = True) -> PanelLayout:
    """The panels of a figure, or why it is one picture.

    Figures above MAX_DETECT_PIXELS are cut on every few pixels (a 4000 × 3000 figure on every
    second: 4 times less to look at, the bulk of the time), each panel's edges then found again
    at full resolution in the few rows and columns around them; letters are read at full
    resolution.

    values : (H, W) float image (any range; NaN = unknown, never gutter).
    rgb : optional (H, W, 3) colour image of the same figure: a gutter pixel must then be white
        or black in every channel (a saturated red stripe is not a gutter).
    read_letters : read panel letters by OCR (Tesseract); off, panels are numbered.
    """
    start = time.perf_counter()
    h, w = values.shape
    step = int(np.ceil(np.sqrt(h * w / MAX_DETECT_PIXELS)))
    small = values[::step, ::step] if step > 1 else values
    small_rgb = rgb[::step, ::step] if step > 1 and rgb is not None and rgb.ndim == 3 else rgb
    limits = _gutter_limits(small, small_rgb)
    if limits is None:
        return PanelLayout(False, reason="the figure is uniform, so it has no panels", figure_px=(w, h), seconds=time.perf_counter() - start)
    masks = _masks_within(limits, small, small_rgb)
    best: tuple[list[Box], list[str], str, list[str]] | None = None
    reasons = []
    for colour, mask in masks.items():
        boxes, how, notes, failure = _layout_in(mask, small, step)
        if boxes is None:
            reasons.append(failure)
            continue
        if best is None or len(boxes) > len(best[0]):
            best = (boxes, how, colour, notes)
    if best is None:
        reason, ambiguous = _why_whole(reasons)
        return PanelLayout(False, reason=reason, figure_px=(w, h), seconds=time.perf_counter() - start, ambiguous=ambiguous)
    boxes, how, colour, notes = best
    if step > 1:
        boxes = _refined(values, rgb, limits, colour, boxes, how, step)
    order, rows = reading_order(boxes)
    boxes, how = [boxes[i] for i in order], [how[i] for i in order]
    labels, read, letter_notes = _labels(values, None, boxes, read_letters, limits)
    panels = tuple(Panel(b, lab, r, hw) for b, lab, r, hw in zip(boxes, labels, read, how))
    sentence = f"{len(panels)} panels found from {colour} gutters" + (
        "" if all(x == "gutters" for x in how) else " and the regularity of the layout")
    return PanelLayout(True, panels, rows, colour, sentence, tuple(notes + letter_notes), (w, h), time.perf_counter() - start)


def _refined(values: np.ndarray, rgb: np.ndarray | None, limits: "_Limits", colour: str, boxes: list[Box], how: list[str],
             step: int) -> list[Box]:
    """Boxes found on every step-th pixel (in source pixels, exact to `step`), their edges found
    again at full resolution: each edge is the first line that is not gutter, looking inward
    from `step` pixels outside it. A panel found from its neighbours (its edges are gutter
    colour) takes the edges of the panels it lines up with, else keeps the coarse ones."""
    H, W = values.shape
    coarse = [(x, y, x + bw, y + bh) for x, y, bw, bh in ((v * step for v in b) for b in boxes)]
    coarse = [(x0, y0, min(W, x1), min(H, y1)) for x0, y0, x1, y1 in coarse]
    fine = {}
    for i, (x0, y0, x1, y1) in enumerate(coarse):
        if how[i] != "gutters":
            continue
        for _ in range(2):  # the rows' shares depend on the columns, and back
            y0, y1 = _edges(values, rgb, limits, colour, (y0, y1), (x0, x1), step, axis=0)
            x0, x1 = _edges(values, rgb, limits, colour, (x0, x1), (y0, y1), step, axis=1)
        fine[i] = (x0, y0, x1, y1)
    same = {}  # coarse edge -> the fine one, per side, from the panels refined
    for i, box in fine.items():
        for side in range(4):
            same.setdefault((side, coarse[i][side]), box[side])
    out = []
    for i, box in enumerate(coarse):
        x0, y0, x1, y1 = fine.get(i) or tuple(same.get((side, v), v) for side, v in enumerate(box))
        out.append((x0, y0, x1 - x0, y1 - y0))
    return out


def _edges(values, rgb, limits: "_Limits", colour: str, span: tuple[int, int], across: tuple[int, int], step: int,
           axis: int) -> tuple[int, int]:
    """The start and stop of a box along one axis (0: rows, 1: columns) at full resolution,
    searched within `step` lines of the coarse ones; lines taken over `across` only."""
    a, b = span
    n = values.shape[axis]

    def lines(lo: int, hi: int) -> np.ndarray:
        index = (slice(lo, hi), slice(*across)) if axis == 0 else (slice(*across), slice(lo, hi))
        band = _masks_within(limits, values[index], None if rgb is None or rgb.ndim != 3 else rgb[index], colour)[colour]
        return _lines(band, axis)

    lo, hi = max(0, a - step), min(n, a + step)
    flags = np.flatnonzero(~lines(lo, hi)) if hi > lo else np.array([], int)
    start = lo + int(flags[0]) if flags.size else a
    lo, hi = max(0, b - step), min(n, b + step)
    flags = np.flatnonzero(~lines(lo, hi)) if hi > lo else np.array([], int)
    stop = lo + int(flags[-1]) + 1 if flags.size else b
    return (start, stop) if stop > start else (a, b)


def forced_grid(values: np.ndarray, grid: str, *, read_letters: bool = True) -> PanelLayout:
    """The figure cut into an equal R×C grid (panels = 'RxC'), each cell trimmed of its gutters."""
    start = time.perf_counter()
    rows_n, cols_n = parse_grid(grid)
    h, w = values.shape
    masks = _gutter_masks(values, None) or {"white": np.zeros(values.shape, bool)}
    colour = _border_colour(masks)
    mask = masks[colour]
    x0, y0, x1, y1 = _trim(mask, 0, 0, w, h)
    if x1 <= x0 or y1 <= y0:
        x0, y0, x1, y1 = 0, 0, w, h
    boxes = []
    for r in range(rows_n):
        for c in range(cols_n):
            cx0, cx1 = x0 + (x1 - x0) * c // cols_n, x0 + (x1 - x0) * (c + 1) // cols_n
            cy0, cy1 = y0 + (y1 - y0) * r // rows_n, y0 + (y1 - y0) * (r + 1) // rows_n
            tx0, ty0, tx1, ty1 = _trim(mask, cx0, cy0, cx1, cy1)
            if min(tx1 - tx0, ty1 - ty0) < min_box_px(w, h):
                tx0, ty0, tx1, ty1 = cx0, cy0, cx1, cy1
            boxes.append((tx0, ty0, tx1 - tx0, ty1 - ty0))
    _, rows = reading_order(boxes)
    labels, read, notes = _labels(values, mask, boxes, read_letters)
    panels = tuple(Panel(b, lab, rd, "forced grid") for b, lab, rd in zip(boxes, labels, read))
    return PanelLayout(True, panels, rows, colour, f"cut into the {rows_n}×{cols_n} grid asked for (`panels` = {grid})",
                       tuple(notes), (w, h), time.perf_counter() - start)


def given_layout(values: np.ndarray, record: str) -> PanelLayout:
    """The layout recorded in a recipe ('a=x,y,w,h;b=...'), checked against the figure."""
    h, w = values.shape
    boxes, keys = parse_boxes(record, w, h)
    order, rows = reading_order(boxes)
    boxes, keys = [boxes[i] for i in order], [keys[i] for i in order]
    panels = tuple(Panel(b, k.rstrip("*"), k.isalpha(), "given") for b, k in zip(boxes, keys))
    return PanelLayout(True, panels, rows, None, "the panel boxes recorded in the recipe", (), (w, h), 0.0)


def reading_order(boxes: list[Box]) -> tuple[list[int], tuple[tuple[int, ...], ...]]:
    """Indices of `boxes` in reading order (rows top to bottom, each left to right), and the rows
    as tuples of positions in that order. A box joins a row when its centre lies within the
    vertical span of the row's first box."""
    remaining = sorted(range(len(boxes)), key=lambda i: (boxes[i][1], boxes[i][0]))
    rows_idx: list[list[int]] = []
    for i in remaining:
        cy = boxes[i][1] + boxes[i][3] / 2
        for row in rows_idx:
            first = boxes[row[0]]
            if first[1] <= cy < first[1] + first[3]:
                row.append(i)
                break
        else:
            rows_idx.append([i])
    order, rows, k = [], [], 0
    for row in rows_idx:
        row.sort(key=lambda i: boxes[i][0])
        order += row
        rows.append(tuple(range(k, k + len(row))))
        k += len(row)
    return order, tuple(rows)


# ---------------------------------------------------------------------------------------------
# Gutters and the XY cut


@dataclass(frozen=True)
class _Limits:
    """What counts as gutter colour: grey values within `tol` of the figure's lowest and highest
    (and, for a colour figure, every channel within `ctol` of its lowest and highest)."""

    lo: float
    hi: float
    tol: float
    clo: float | None = None
    chi: float | None = None
    ctol: float | None = None


def _gutter_masks(values: np.ndarray, rgb: np.ndarray | None) -> dict[str, np.ndarray] | None:
    limits = _gutter_limits(values, rgb)
    return None if limits is None else _masks_within(limits, values, rgb)


def _gutter_limits(values: np.ndarray, rgb: np.ndarray | None) -> _Limits | None:
    lo, hi = float(values.min()), float(values.max())
    if not (np.isfinite(lo) and np.isfinite(hi)):  # only then the slower pass that skips NaN and inf
        finite = np.isfinite(values)
        if not finite.any():
            return None
        lo, hi = float(values[finite].min()), float(values[finite].max())
    if not hi > lo:
        return None
    if rgb is not None and rgb.ndim == 3 and rgb.shape[:2] == values.shape:
        c = rgb[..., :3].astype(np.float32)
        clo, chi = float(np.nanmin(c)), float(np.nanmax(c))
        return _Limits(lo, hi, GUTTER_TOL * (hi - lo), clo, chi, GUTTER_TOL * max(chi - clo, 1e-12))
    return _Limits(lo, hi, GUTTER_TOL * (hi - lo))


def _masks_within(limits: _Limits, values: np.ndarray, rgb: np.ndarray | None, only: str | None = None) -> dict[str, np.ndarray]:
    """The white and black gutter masks (or only one of them)."""
    out = {}
    c = rgb[..., :3].astype(np.float32) if limits.ctol is not None and rgb is not None and rgb.ndim == 3 else None
    with np.errstate(invalid="ignore"):
        if only in (None, "white"):
            out["white"] = values >= limits.hi - limits.tol
            if c is not None:
                out["white"] &= (c >= limits.chi - limits.ctol).all(axis=2)
        if only in (None, "black"):
            out["black"] = values <= limits.lo + limits.tol
            if c is not None:
                out["black"] &= (c <= limits.clo + limits.ctol).all(axis=2)
    return out


def _border_colour(masks: dict[str, np.ndarray]) -> str:
    """The colour of the figure's outermost pixels (its background), white when neither is."""
    def ring(m):
        return np.concatenate([m[0], m[-1], m[:, 0], m[:, -1]]).mean()

    return max(masks, key=lambda k: (ring(masks[k]), k == "white"))


def _lines(mask: np.ndarray, axis: int) -> np.ndarray:
    """Gutter lines of a region: along axis 0 the rows, along 1 the columns."""
    n = mask.shape[1 - axis]
    # Summing bytes into uint16 is 3-5x faster than count_nonzero along an axis (SIMD, no int64).
    counts = mask.view(np.uint8).sum(axis=1 - axis, dtype=np.uint16 if n < 65536 else np.int64)
    return counts >= LINE_SHARE * n


def _trim(mask: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> tuple[int, int, int, int]:
    """The box without the gutter-colour lines along its edges (its margins)."""
    return _trimmed(mask, (x0, y0, x1, y1))[0]


def _trimmed(mask: np.ndarray, box) -> tuple[tuple[int, int, int, int], tuple[np.ndarray, np.ndarray] | None]:
    """The trimmed box and its gutter rows and columns (None when nothing is left), so that the
    cut does not count them again."""
    x0, y0, x1, y1 = box
    for _ in range(4):  # trimming rows changes the columns' shares, and back
        sub = mask[y0:y1, x0:x1]
        if sub.size == 0:
            return (x0, y0, x0, y0), None
        row_lines, col_lines = _lines(sub, 0), _lines(sub, 1)
        rows, cols = np.flatnonzero(~row_lines), np.flatnonzero(~col_lines)
        if rows.size == 0 or cols.size == 0:
            return (x0, y0, x0, y0), None
        new = (x0 + int(cols[0]), y0 + int(rows[0]), x0 + int(cols[-1]) + 1, y0 + int(rows[-1]) + 1)
        if new == (x0, y0, x1, y1):
            return new, (row_lines, col_lines)
        x0, y0, x1, y1 = new
    sub = mask[y0:y1, x0:x1]
    return (x0, y0, x1, y1), (_lines(sub, 0), _lines(sub, 1))


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of the runs of True in a 1-D bool array."""
    padded = np.concatenate([[False], flags, [False]])
    edges = np.flatnonzero(padded[1:] != padded[:-1])
    return list(zip(edges[::2].tolist(), edges[1::2].tolist()))


def _xy_cut(mask: np.ndarray, box: tuple[int, int, int, int], min_gap: int, min_side: int, depth: int = 0) -> list[tuple[int, int, int, int]]:
    """Leaves (x0, y0, x1, y1) of the recursive cut of `box` along full-length gutter bands."""
    (x0, y0, x1, y1), lines = _trimmed(mask, box)
    if lines is None or x1 - x0 < min_side or y1 - y0 < min_side:
        return [(x0, y0, x1, y1)] if x1 > x0 and y1 > y0 else []
    best = None
    for axis in (0, 1):
        runs = [r for r in _runs(lines[axis]) if r[1] - r[0] >= min_gap]
        if runs and (best is None or max(b - a for a, b in runs) > max(b - a for a, b in best[1])):
            best = (axis, runs)
    if best is None or depth >= MAX_DEPTH:
        return [(x0, y0, x1, y1)]
    axis, runs = best
    leaves = []
    cuts = [0] + [v for run in runs for v in run] + [(y1 - y0) if axis == 0 else (x1 - x0)]
    for a, b in zip(cuts[::2], cuts[1::2]):
        piece = (x0, y0 + a, x1, y0 + b) if axis == 0 else (x0 + a, y0, x0 + b, y1)
        leaves += _xy_cut(mask, piece, min_gap, min_side, depth + 1)
    return leaves


@dataclass
class _Leaf:
    box: tuple[int, int, int, int]  # x0, y0, x1, y1
    kind: str  # "panel", "text", "other"
    share: float  # gutter colour inside

    @property
    def area(self) -> int:
        return (self.box[2] - self.box[0]) * (self.box[3] - self.box[1])


def _share(mask: np.ndarray) -> float:
    """The share of True in a bool array (bytes summed: several times faster than mean())."""
    return float(mask.view(np.uint8).sum(dtype=np.int64)) / max(1, mask.size)


def _classify(mask: np.ndarray, box, fig_short: int, fig_area: int) -> _Leaf:
    x0, y0, x1, y1 = box
    sub = mask[y0:y1, x0:x1]
    share = _share(sub)
    edges = [sub[0].mean(), sub[-1].mean(), sub[:, 0].mean(), sub[:, -1].mean()]
    thin = min(x1 - x0, y1 - y0) < TEXT_SIDE_SHARE * fig_short or (x1 - x0) * (y1 - y0) < 0.01 * fig_area
    tiny = min(x1 - x0, y1 - y0) < MIN_PANEL_SHARE * fig_short or (x1 - x0) * (y1 - y0) < 0.004 * fig_area
    if tiny:
        return _Leaf(box, "text", share)  # a glyph, a line of text: too small to be a panel
    if max(edges) <= EDGE_SHARE and share < INSIDE_SHARE and not (thin and share > 0.3):
        return _Leaf(box, "panel", share)
    return _Leaf(box, "text" if thin else "other", share)


def _layout_in(mask: np.ndarray, values: np.ndarray, step: int = 1):
    """(boxes, how each was found, notes, None) for one gutter colour, or (None, None, None, why not).
    `step`: the mask is of every step-th pixel (the notes say source pixels)."""
    h, w = mask.shape
    min_gap = max(2, round(0.0015 * max(h, w)))
    min_side = max(8, round(0.02 * min(h, w)))
    leaves = [_classify(mask, b, min(h, w), h * w) for b in _xy_cut(mask, (0, 0, w, h), min_gap, min_side)]
    panels = [lf for lf in leaves if lf.kind == "panel"]
    if len(panels) < 2:
        if len(leaves) <= 1:
            return None, None, None, "no straight gutter of one colour crosses it"
        if panels and _content_beside(panels[0], [lf for lf in leaves if lf.kind == "other"]):
            return None, None, None, AMBIGUOUS
        return None, None, None, "the pieces between its straight bands are not rectangular pictures"
    notes: list[str] = []
    texts = [lf for lf in leaves if lf.kind == "text"]
    _merge_bands(panels, texts)
    how = {id(p): "gutters" for p in panels}
    others = [lf for lf in leaves if lf.kind == "other"]
    for cell in _regular_cells(mask, panels, others, w, h, min_gap):
        panels.append(cell)
        how[id(cell)] = "regular grid"
    typical = float(np.median([p.area for p in panels]))
    for lf in others:
        if any(_overlap(lf.box, p.box) > 0.5 * lf.area for p in panels):
            continue
        if lf.area >= 0.25 * typical:
            panels.append(lf)
            how[id(lf)] = "content"
            notes.append(f"the panel at {_where(lf.box, step)} has mostly background along its edges; its box is where its content ends")
        else:
            notes.append(f"a small piece at {_where(lf.box, step)} (a legend or a colour bar?) is not a panel and is not printed")
    if texts:
        notes.append(f"{len(texts)} strip{'s' if len(texts) != 1 else ''} of text (title, labels) between the panels "
                     f"{'are' if len(texts) != 1 else 'is'} not printed")
    if _overlapping(panels):
        return None, None, None, "the pieces found overlap, so the layout is not a clean grid"
    boxes = [(p.box[0], p.box[1], p.box[2] - p.box[0], p.box[3] - p.box[1]) for p in panels]
    return boxes, [how[id(p)] for p in panels], notes, None


def _content_beside(panel: _Leaf, others: list[_Leaf]) -> bool:
    """Pieces of picture that are not rectangular pictures (a dark panel on a black gutter cut into
    its spots) spanning, together, a box at least a quarter of the rectangular picture's area:
    perhaps a second panel, so the layout is ambiguous rather than a single picture."""
    if not others:
        return False
    x0, y0 = min(o.box[0] for o in others), min(o.box[1] for o in others)
    x1, y1 = max(o.box[2] for o in others), max(o.box[3] for o in others)
    return (x1 - x0) * (y1 - y0) >= 0.25 * panel.area


def _where(box, step: int = 1) -> str:
    x0, y0, x1, y1 = (v * step for v in box)
    return f"x {x0}–{x1 - 1}, y {y0}–{y1 - 1}"


def _overlap(a, b) -> int:
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return max(0, w) * max(0, h)


def _overlapping(leaves: list[_Leaf]) -> bool:
    return any(_overlap(a.box, b.box) > 0 for i, a in enumerate(leaves) for b in leaves[i + 1:])


def _merge_bands(panels: list[_Leaf], texts: list[_Leaf]) -> None:
    """Give each panel the text right under it that makes up a data band (in place: merged strips
    leave `texts`). The band's pieces (lines of text, its frame, a logo) are gathered while each
    starts within a few rows of the panel or of the pieces already gathered, inside the panel's
    columns; together they must span at least BAND_WIDTH_SHARE of the panel's width."""
    for p in sorted(panels, key=lambda lf: lf.box[1]):
        x0, y0, x1, y1 = p.box
        gap_limit = max(3, round(0.03 * (y1 - y0)))
        tol = SIZE_TOL * (x1 - x0) + 2
        inside = [t for t in texts if t.box[0] >= x0 - tol and t.box[2] <= x1 + tol and t.box[1] >= y1]
        bottom, cluster = y1, []
        for t in sorted(inside, key=lambda lf: lf.box[1]):
            if t.box[1] - bottom > gap_limit:
                break
            cluster.append(t)
            bottom = max(bottom, t.box[3])
        if not cluster:
            continue
        span = max(t.box[2] for t in cluster) - min(t.box[0] for t in cluster)
        if span >= BAND_WIDTH_SHARE * (x1 - x0):
            p.box = (x0, y0, x1, bottom)
            for t in cluster:
                texts.remove(t)


def _intervals(values: list[tuple[int, int]], tol: float) -> list[tuple[int, int]]:
    """Distinct (start, stop) intervals, those within `tol` of each other taken as one."""
    out: list[tuple[int, int]] = []
    for a, b in sorted(values):
        if not any(abs(a - c) <= tol and abs(b - d) <= tol for c, d in out):
            out.append((a, b))
    return out


def _grid_axis(spans: list[tuple[int, int]], limit: int, tol: float) -> list[tuple[int, int]]:
    """The regular intervals along one axis: the spans found, and where they share one size and
    one pitch, the cells between and beyond them up to `limit` (the figure's side)."""
    spans = _intervals(spans, tol)
    sizes = [b - a for a, b in spans]
    if len(spans) < 2 or max(sizes) - min(sizes) > 2 * tol:
        return spans
    size = int(round(np.median(sizes)))
    starts = [a for a, _ in spans]
    step = min(b - a for a, b in zip(starts, starts[1:]))
    for k in (4, 3, 2, 1):  # the smallest pitch that every gap between spans is a multiple of
        pitch = step / k
        if pitch < size:
            continue
        if all(abs((s - starts[0]) / pitch - round((s - starts[0]) / pitch)) * pitch <= tol for s in starts):
            break
    else:
        return spans
    out, first = [], starts[0]
    n_lo = int(np.floor(first / pitch + 1e-9))
    for n in range(-n_lo, int((limit - first) / pitch) + 1):
        a = int(round(first + n * pitch))
        if a >= 0 and a + size <= limit + tol:
            out.append((a, min(limit, a + size)))
    return out


def _regular_cells(mask, panels: list[_Leaf], others: list[_Leaf], w: int, h: int, min_gap: int) -> list[_Leaf]:
    """Panels found from their neighbours: cells of the regular grid the panels found define, not
    yet covered by a panel, holding some content, with gutter colour where the gutters should be."""
    tol = max(2.0, SIZE_TOL * max(w, h) / 4)
    cols = _grid_axis([(p.box[0], p.box[2]) for p in panels], w, tol)
    rows = _grid_axis([(p.box[1], p.box[3]) for p in panels], h, tol)
    found = []
    for y0, y1 in rows:
        for x0, x1 in cols:
            box = (x0, y0, x1, y1)
            area = (x1 - x0) * (y1 - y0)
            if area <= 0 or any(_overlap(box, p.box) > 0.02 * area for p in panels + found):
                continue
            share = _share(mask[y0:y1, x0:x1])
            if share > 0.998 or share < INSIDE_SHARE:
                continue  # empty cell (no panel there), or a picture the gutters should have found
            if not any(_overlap(box, o.box) > 0 for o in others):
                continue  # nothing the cut left over lies there
            if not _gutters_around(mask, box, w, h, min_gap):
                continue
            found.append(_Leaf(box, "panel", share))
    return found


def _gutters_around(mask, box, w: int, h: int, min_gap: int) -> bool:
    """The bands just outside a cell (where its gutters would be) are gutter colour, or the figure's edge."""
    x0, y0, x1, y1 = box
    bands = []
    if x0 >= min_gap:
        bands.append(mask[y0:y1, x0 - min_gap : x0])
    if x1 + min_gap <= w:
        bands.append(mask[y0:y1, x1 : x1 + min_gap])
    if y0 >= min_gap:
        bands.append(mask[y0 - min_gap : y0, x0:x1])
    if y1 + min_gap <= h:
        bands.append(mask[y1 : y1 + min_gap, x0:x1])
    return all(b.size == 0 or b.mean() >= 0.95 for b in bands)


AMBIGUOUS = "one piece between its straight bands is a rectangular picture, another as large is not"


def _why_whole(reasons: list[str]) -> tuple[str, bool]:
    """Why a picture is printed whole, and whether that is worth a warning (something suggests a
    figure: a layout too ambiguous to split), or not (a single picture)."""
    if any("overlap" in r for r in reasons):
        return "the figure is printed whole: " + next(r for r in reasons if "overlap" in r) + ".", True
    if AMBIGUOUS in reasons:
        return ("the figure is printed whole: straight bands of one colour cut it into pieces, and one is a rectangular picture "
                "but another as large is not (a layout too ambiguous to split; `panels` RxC cuts it into a grid)."), True
    if any("rectangular" in r for r in reasons):
        return ("it is a single picture: it has straight bands of one colour, but they do not cut it into rectangular "
                "pictures (at most one, with strips of text such as its data band)."), False
    return "it is a single picture: no straight gutter of one colour crosses it.", False


# ---------------------------------------------------------------------------------------------
# Letters


@dataclass
class _Glyphs:
    ink: np.ndarray  # (h, w) bool, the label's strokes
    distance: float  # from the panel's corner, in px


def _labels(values: np.ndarray, mask: np.ndarray | None, boxes: list[Box], read_letters: bool,
            limits: _Limits | None = None) -> tuple[list[str], list[bool], list[str]]:
    """Labels for the panels in reading order, whether each was read, and notes. `limits`: the
    figure's range when known (finding it again costs 30 ms on 12 Mpx)."""
    n = len(boxes)
    numbers = [str(i + 1) for i in range(n)]
    if not read_letters:
        return numbers, [False] * n, []
    if ocr.backend() is None:
        return numbers, [False] * n, ["panel letters are not read without Tesseract (apt-get install tesseract-ocr); the panels are numbered 1 to "
                                       f"{n} in reading order"]
    if limits is not None:
        lo, hi = limits.lo, limits.hi
    else:
        lo, hi = float(values.min()), float(values.max())
        if not (np.isfinite(lo) and np.isfinite(hi)):
            lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    labels = _read_letters(_Scaled(values, lo, hi), boxes)
    return _consistent(labels, n)


def _consistent(read: list[str | None], n: int) -> tuple[list[str], list[bool], list[str]]:
    """Letters when those read make sense as a lettering of n panels; missing ones inferred from
    the order; otherwise numbers. With a note on what was not read."""
    numbers = [str(i + 1) for i in range(n)]
    sure = [r for r in read if r and not r.startswith("?")]
    upper_first = bool(sure) and sum(r.isupper() for r in sure) > len(sure) / 2
    read = [(r[1].upper() if upper_first else r[1]) if r and r.startswith("?") else r for r in read]
    got = [r for r in read if r]
    if not got:
        return numbers, [False] * n, [f"no panel letters could be read; the panels are numbered 1 to {n} in reading order"]
    upper = all(r.isupper() for r in got)
    lower = all(r.islower() for r in got)
    first = "A" if upper else "a"
    allowed = {chr(ord(first) + i) for i in range(n)}
    if not (upper or lower) or len(set(got)) != len(got) or not set(got) <= allowed:
        return numbers, [False] * n, [f"the letters read ({', '.join(got)}) are not a lettering of {n} panels; "
                                       f"the panels are numbered 1 to {n} in reading order"]
    missing = sorted(allowed - set(got))
    out, notes = [], []
    for r in read:
        out.append(r if r else missing.pop(0))
    inferred = [o for o, r in zip(out, read) if not r]
    if inferred:
        notes.append(f"the letter{'s' if len(inferred) > 1 else ''} of panel{'s' if len(inferred) > 1 else ''} "
                     f"{', '.join(inferred)} did not read; {'they are' if len(inferred) > 1 else 'it is'} inferred from the order of the others")
    return out, [bool(r) for r in read], notes


class _Scaled:
    """The figure scaled to 0..1 (NaN as 0.5) one window at a time: scaling a whole 12 Mpx figure
    to read letters in a few corners would cost more than finding the panels."""

    def __init__(self, values: np.ndarray, lo: float, hi: float):
        self.values, self.lo, self.span = values, lo, max(hi - lo, 1e-12)
        self.shape = values.shape

    def __getitem__(self, index) -> np.ndarray:
        window = (self.values[index].astype(np.float32) - np.float32(self.lo)) / np.float32(self.span)
        return np.nan_to_num(window, nan=0.5)


def _read_letters(scaled: "_Scaled | np.ndarray", boxes: list[Box]) -> list[str | None]:
    """The letter in each panel's corner, or None. All glyphs go to Tesseract in one call (one
    line each), since each call costs 0.1–0.3 s; a glyph the batch misreads is not retried."""
    candidates = [_corner_glyphs(scaled, box, boxes[:i] + boxes[i + 1:]) for i, box in enumerate(boxes)]
    crops = _alike(candidates)
    found = [c for c in crops if c is not None]
    if not found:
        return [None] * len(boxes)
    texts = _ocr_lines([c.ink for c in found])
    out, k = [], 0
    for c in crops:
        if c is None:
            out.append(None)
            continue
        text = texts[k] if k < len(texts) else ""
        k += 1
        out.append(parse_letter(text))
    return out


def _alike(candidates: list[list[_Glyphs]]) -> list[_Glyphs | None]:
    """One glyph group per panel: the nearest to its corner among those about as tall as the
    letters of the other panels (a figure's letters share one size; a bright speck in a dark
    panel that happens to lie nearer does not)."""
    nearest = [min(c, key=lambda g: g.distance) if c else None for c in candidates]
    heights = [g.ink.shape[0] for g in nearest if g is not None]
    if len(heights) < 2:
        return nearest
    typical = float(np.median(heights))
    out = []
    for c, near in zip(candidates, nearest):
        alike = [g for g in c if 0.6 * typical <= g.ink.shape[0] <= 1.6 * typical]
        out.append(min(alike, key=lambda g: g.distance) if alike else near)
    return out


def _corner_glyphs(scaled: "_Scaled | np.ndarray", box: Box, others: list[Box] = ()) -> list[_Glyphs]:
    """Label glyph groups near the panel's corners: isolated strokes on a plain ground (a label
    box or the gutter), inside the panel's corner or just outside it. The top left is searched
    first (almost always the letter's place); the other corners only when it holds none."""
    H, W = scaled.shape
    x, y, w, h = box
    side = min(w, h)
    reach_in, reach_out = max(12, int(0.25 * side)), max(8, int(0.2 * side))
    # Large panels are searched on every d-th pixel (the smallest glyph still 8 samples high: the
    # search, not the OCR, was the bulk of reading letters on a 4000 × 3000 figure); the glyphs
    # found are cut from the full resolution for the OCR.
    d = max(1, max(8, int(0.015 * side)) // 8)
    found: list[_Glyphs] = []
    for cx, cy, sx, sy in ((x, y, 1, 1), (x + w, y, -1, 1), (x, y + h, 1, -1)):
        xa, xb = sorted((cx - sx * reach_out, cx + sx * reach_in))
        ya, yb = sorted((cy - sy * reach_out, cy + sy * reach_in))
        xa, ya, xb, yb = max(0, xa), max(0, ya), min(W, xb), min(H, yb)
        window = scaled[ya:yb:d, xa:xb:d]
        if window.size == 0:
            continue
        window = _grey_others(window, xa, ya, others, d)
        for ink, (gy, gx), bbox, dark in _isolated_glyphs(window, side / d):
            if d > 1:
                ink = _full_crop(scaled, others, xa, ya, d, bbox, dark)
            found.append(_Glyphs(ink, float(np.hypot(xa + d * gx - cx, ya + d * gy - cy))))
        if found:
            break
    return found


def _full_crop(scaled, others: list[Box], xa: int, ya: int, d: int, bbox, dark: bool) -> np.ndarray:
    """The ink of a glyph group found on every d-th pixel, at full resolution: the group's box
    widened by the d-1 pixels it may reach between samples, cut to where the ink is."""
    H, W = scaled.shape
    r0, r1, c0, c1 = bbox
    fr0, fc0 = max(0, ya + d * r0 - (d - 1)), max(0, xa + d * c0 - (d - 1))
    fr1, fc1 = min(H, ya + d * (r1 - 1) + d), min(W, xa + d * (c1 - 1) + d)
    window = _grey_others(scaled[fr0:fr1, fc0:fc1], fc0, fr0, others)
    ink = window <= 0.3 if dark else window >= 0.7
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    if rows.size == 0:
        return ink
    return ink[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]


def _grey_others(window: np.ndarray, xa: int, ya: int, others: list[Box], d: int = 1) -> np.ndarray:
    """The window (of every d-th pixel from xa, ya) with the parts of other panels greyed out
    (neither ink nor ground), so that a corner's search reaching into the gutter never reads a
    neighbour's letter."""
    out = None
    for x, y, w, h in others:
        c0, c1 = max(0, -(-(x - xa) // d)), min(window.shape[1], -(-(x + w - xa) // d))
        r0, r1 = max(0, -(-(y - ya) // d)), min(window.shape[0], -(-(y + h - ya) // d))
        if c1 > c0 and r1 > r0:
            out = window.copy() if out is None else out
            out[r0:r1, c0:c1] = 0.5
    return window if out is None else out


def _isolated_glyphs(window: np.ndarray, side: float):
    """Groups of glyph-sized strokes of one polarity whose surroundings are plainly the other:
    yields (ink crop, (row, col) of the group's centre in the window, its box (r0, r1, c0, c1),
    dark ink)."""
    min_h, max_h = max(8, int(0.015 * side)), max(12, int(0.3 * side))
    for dark, (ink_mask, ground) in ((True, (window <= 0.3, window >= 0.7)), (False, (window >= 0.7, window <= 0.3))):
        labels, n = ndimage.label(ink_mask, structure=np.ones((3, 3), bool))  # anti-aliased strokes meet at corners
        if n == 0:
            continue
        parts = []
        slices = ndimage.find_objects(labels)
        heights = np.array([sl[0].stop - sl[0].start for sl in slices])
        widths = np.array([sl[1].stop - sl[1].start for sl in slices])
        for i in np.flatnonzero((heights >= min_h) & (heights <= max_h) & (widths <= 1.6 * heights))[:200] + 1:
            sl = slices[i - 1]
            comp = labels[sl] == i
            if comp.sum() < 12:
                continue
            r0, r1 = max(0, sl[0].start - 3), min(window.shape[0], sl[0].stop + 3)
            c0, c1 = max(0, sl[1].start - 3), min(window.shape[1], sl[1].stop + 3)
            around = ~ndimage.binary_dilation(labels[r0:r1, c0:c1] == i, iterations=1)
            if ground[r0:r1, c0:c1][around].mean() < 0.85:
                continue
            parts.append((sl[0].start, sl[0].stop, sl[1].start, sl[1].stop))
        for group in _group_glyphs(parts):
            r0, r1 = min(p[0] for p in group), max(p[1] for p in group)
            c0, c1 = min(p[2] for p in group), max(p[3] for p in group)
            yield ink_mask[r0:r1, c0:c1], ((r0 + r1) / 2, (c0 + c1) / 2), (r0, r1, c0, c1), dark


def _group_glyphs(parts):
    """Glyphs side by side on one line (the parentheses of '(a)') as one group; at most 3 each."""
    parts = sorted(parts, key=lambda p: p[2])
    groups: list[list] = []
    for p in parts:
        for g in groups:
            last = g[-1]
            height = max(last[1] - last[0], p[1] - p[0])
            overlap = min(last[1], p[1]) - max(last[0], p[0])
            if 0 <= p[2] - last[3] <= 0.6 * height and overlap >= 0.5 * min(last[1] - last[0], p[1] - p[0]):
                g.append(p)
                break
        else:
            groups.append([p])
    return [g for g in groups if len(g) <= 3]


def _page(ink: np.ndarray):
    """A glyph group black on white, OCR_LINE_PX high, binarised again after scaling."""
    from PIL import Image

    scale = OCR_LINE_PX / max(1, ink.shape[0])
    page = Image.fromarray(np.where(ink, 0, 255).astype(np.uint8))
    size = (max(1, int(round(ink.shape[1] * scale))), OCR_LINE_PX)
    return page.resize(size, Image.Resampling.LANCZOS).point(lambda v: 255 if v > 127 else 0)


def _tesseract(canvas, psm: str) -> str | None:
    return ocr.read_text(canvas, int(psm), LETTER_WHITELIST)


def _ocr_lines(inks: list[np.ndarray]) -> list[str]:
    """Each ink crop read by Tesseract. Several go in one call (a page with one glyph group per
    line, mode 6), since each call costs 0.1–0.3 s; a line that comes back empty or not a letter,
    and a lone glyph, is read alone as a single character (mode 10), which reads letters that
    mode 6 drops when they stand alone. At most MAX_SINGLE_CALLS such calls."""
    from PIL import Image

    pages = [_page(ink) for ink in inks]
    out = [""] * len(inks)
    if len(inks) > 1:
        line_h = 2 * OCR_LINE_PX
        canvas = Image.new("L", (max(p.width for p in pages) + 2 * OCR_LINE_PX, line_h * len(pages) + OCR_LINE_PX), 255)
        for i, p in enumerate(pages):
            canvas.paste(p, (OCR_LINE_PX, OCR_LINE_PX // 2 + i * line_h))
        lines = [line for line in (_tesseract(canvas, "6") or "").splitlines() if line.strip()]
        if len(lines) == len(inks):
            out = lines
    retry = [i for i, text in enumerate(out) if parse_letter(text) is None][:MAX_SINGLE_CALLS]
    for i in retry:
        page = Image.new("L", (pages[i].width + 2 * OCR_LINE_PX, 3 * OCR_LINE_PX), 255)
        page.paste(pages[i], (OCR_LINE_PX, OCR_LINE_PX))
        out[i] = (_tesseract(page, "10") or "").strip()
    return out


def parse_letter(text: str) -> str | None:
    """'a', '(a)', 'A.' -> the letter; 'Cc' (Tesseract's answer for a letter whose two cases look
    alike: c, o, s, v, w, x, z) -> '?c', the case left to the other panels; else None."""
    text = text.strip().replace(" ", "").strip("().")
    if len(text) == 1 and text.isalpha():
        return text
    if len(text) == 2 and text[0].lower() == text[1].lower() and text.isalpha():
        return "?" + text[0].lower()
    return None
