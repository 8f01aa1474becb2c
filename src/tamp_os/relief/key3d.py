"""A braille key on the print: one row per encoding, a swatch of its texture then its label in braille.

The key is a strip added below the picture (the plate grows to hold it); every element keeps at
least KEY_GAP_MM from every other, and from the picture, so a finger finds each on its own.
Braille follows the standard cell (standards.BrailleSpec), dots as rounded domes like the caption's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..standards import BrailleSpec
from ..tactile.braille import BLANK, block_size_mm, dot_centres, to_braille, wrap_cells
from .channels import KeyEntry, encode

KEY_GAP_MM = 3.0
SWATCH_W_MM = 10.0
SWATCH_H_MM = 8.0


@dataclasses.dataclass(frozen=True)
class KeyStrip:
    heights_mm: np.ndarray  # (rows, cols) relief above the base, to put below the picture
    entries: tuple[KeyEntry, ...]  # with braille filled in
    depth_mm: float
    dot_centres_mm: tuple[tuple[float, float], ...]  # braille dots, (x, y) from the strip's top-left, y down
    # (rows, cols) the part of heights_mm a two-colour print makes in its second colour: the braille
    # dots and each swatch's outline (0 elsewhere), as the caption's braille is
    overlay_mm: np.ndarray | None = None
    # per entry, (swatch, braille) boxes (x0, y0, x1, y1) in mm from the strip's top-left, y down;
    # the braille box spans its dots' outer edges
    boxes_mm: tuple = ()


OUTLINE_MM = 0.8  # a swatch's raised outline: its outer rim, inside the swatch so the 3 mm gaps stay


def _swatch(encoding: str, rows: int, cols: int, mm_per_px: float, relief_mm: float) -> np.ndarray:
    img = np.zeros((rows, cols))
    if encoding == "domes":  # two domes of 3.5 mm, as nuclei
        yy, xx = np.mgrid[0:rows, 0:cols] * mm_per_px
        for cx in (cols * mm_per_px * 0.27, cols * mm_per_px * 0.73):
            img[(xx - cx) ** 2 + (yy - rows * mm_per_px / 2) ** 2 <= 1.75 ** 2] = 1.0
    else:
        img[1:-1, 1:-1] = 1.0
    h, _ = encode(img, encoding, mm_per_px, relief_mm=relief_mm)
    return h


MAX_LABEL_LINES = 2  # a key label longer than this is written in a shorter form (relief/key_labels.py)


@dataclasses.dataclass(frozen=True)
class _Placed:
    entry: KeyEntry
    lines: list[str]  # braille lines of the form written
    left_mm: float  # the column's left edge
    top_mm: float  # the row's top
    row_h_mm: float


def _fit(entry: KeyEntry, table: str, max_cells: int) -> tuple[str, str, list[str], int]:
    """(form written, its braille, its lines, what was lost: 0 nothing, 1 the role word, 2 a word
    split across the lines, 3 the end cut off).

    The fullest form with its role word on one line; else, on two lines, the shortest with its role
    word first (the name on its own line needs no parentheses: "nuclei" / "DAPI"); else the dye
    alone. Only when even that does not fit two lines whole is a word split across them, and only
    when it needs more than two lines is its end cut off."""
    forms = tuple(entry.key_forms) or (entry.label,)
    role = to_braille(entry.key_role, table, what="key_labels") if entry.key_role else ""
    wrapped = []
    for form in forms:
        # The label may come from the file (a channel's name): say which, and how to give another.
        braille = to_braille(form, table, what=f"the key's label {form!r} (give the channel a label braille can write with `key_labels`)")
        whole = all(len(word) <= max_cells for word in braille.split(BLANK))
        lines = wrap_cells(braille, max_cells)
        rest = braille[len(role) + 1:]
        if (len(lines) > 1 and role and braille.startswith(role + BLANK) and len(role) <= max_cells
                and len(wrap_cells(rest, max_cells)) == 1):
            lines = [role, rest]  # the role on the first line, the name on the second
        wrapped.append((form, braille, lines, whole))
    with_role = wrapped[:-1] if len(wrapped) > 1 else wrapped
    for most_lines, order in ((1, with_role), (MAX_LABEL_LINES, with_role[::-1])):
        for form, braille, lines, whole in order:
            if whole and len(lines) <= most_lines:
                return form, braille, lines, 0
    form, braille, lines, whole = wrapped[-1]
    if len(lines) <= MAX_LABEL_LINES:
        return form, braille, lines, int(len(wrapped) > 1) if whole else 2
    return form, BLANK.join(lines[:MAX_LABEL_LINES]), lines[:MAX_LABEL_LINES], 3


def _layout(entries, table: str, spec: BrailleSpec, width_mm: float, columns: int):
    """Entries placed in `columns` columns, read row by row; (placed, depth in mm, what each label lost
    (_fit's codes, worst first))."""
    col_w = (width_mm - KEY_GAP_MM) / columns  # each column: gap, swatch, gap, braille; the next column's gap closes it
    placed, loss, y = [], [], KEY_GAP_MM
    for start in range(0, len(entries), columns):
        row = []
        for j, e in enumerate(entries[start:start + columns]):
            left = j * col_w
            text_w = (left + col_w) - (left + KEY_GAP_MM + SWATCH_W_MM + KEY_GAP_MM)
            max_cells = int((text_w - spec.dot_spacing_mm - spec.dot_diameter_mm) // spec.cell_spacing_mm) + 1
            if max_cells < 1:
                return [], math.inf, [4] * len(entries)
            form, braille, lines, lost = _fit(e, table, max_cells)
            loss.append(lost)
            done = dataclasses.replace(e, braille=braille, braille_label=form)
            row.append((done, lines, left))
        row_h = max(max(SWATCH_H_MM, block_size_mm(lines, spec)[1]) for _, lines, _ in row)
        placed += [_Placed(done, lines, left, y, row_h) for done, lines, left in row]
        y += row_h + KEY_GAP_MM
    return placed, y, sorted(loss, reverse=True)


def key_depth_bound_mm(n_entries: int, spec: BrailleSpec | None = None) -> float:
    """The most a key of `n_entries` adds to the plate: one column, every label on two braille lines."""
    spec = spec or BrailleSpec()
    two_lines = (MAX_LABEL_LINES - 1) * spec.line_spacing_mm + spec.cell_height_mm
    return KEY_GAP_MM + n_entries * (max(SWATCH_H_MM, two_lines) + KEY_GAP_MM)


def key_strip(entries: tuple[KeyEntry, ...], *, width_mm: float, mm_per_px: float, relief_mm: float,
              table: str, spec: BrailleSpec | None = None) -> KeyStrip:
    """The key below the picture: one column, or two when the plate is wide enough and that makes
    the key shallower; each label in at most MAX_LABEL_LINES braille lines (a shorter form when needed)."""
    spec = spec or BrailleSpec()
    cols = round(width_mm / mm_per_px) + 1
    layouts = [_layout(entries, table, spec, width_mm, n) for n in ((1, 2) if len(entries) > 1 else (1,))]
    placed, depth_mm, _ = min(layouts, key=lambda lay: (lay[2], lay[1]))  # the least lost from the labels, then shallowest
    done = [p.entry for p in placed]
    rows = int(math.ceil(depth_mm / mm_per_px)) + 1
    h = np.zeros((rows, cols))
    yy, xx = np.mgrid[0:rows, 0:cols] * mm_per_px
    centres = []
    outline = np.zeros((rows, cols))
    dots = np.zeros((rows, cols))
    r = spec.dot_diameter_mm / 2
    boxes = []
    for p in placed:
        e, lines, top, row_h, text_left_mm = p.entry, p.lines, p.top_mm, p.row_h_mm, p.left_mm + KEY_GAP_MM + SWATCH_W_MM + KEY_GAP_MM
        r0, c0 = int(round((top + (row_h - SWATCH_H_MM) / 2) / mm_per_px)), round((p.left_mm + KEY_GAP_MM) / mm_per_px)
        sr, sc = round(SWATCH_H_MM / mm_per_px), round(SWATCH_W_MM / mm_per_px)
        ring = max(1, round(OUTLINE_MM / mm_per_px))
        inner = _swatch(e.encoding, sr - 2 * ring, sc - 2 * ring, mm_per_px, relief_mm) if min(sr, sc) > 4 * ring else np.zeros((0, 0))
        sw = np.full((sr, sc), spec.dot_height_mm)
        if inner.size:
            sw[ring:-ring, ring:-ring] = inner
        outline[r0:r0 + sr, c0:c0 + sc] = spec.dot_height_mm
        if inner.size:
            outline[r0 + ring:r0 + sr - ring, c0 + ring:c0 + sc - ring] = 0.0
        h[r0:r0 + sr, c0:c0 + sc] = np.maximum(h[r0:r0 + sr, c0:c0 + sc], sw)
        # dot_centres works y-up from top_mm; we work y-down from the strip's top, so mirror it
        text_w, text_h = block_size_mm(lines, spec)
        text_top = top + (row_h - text_h) / 2
        sw_top = top + (row_h - SWATCH_H_MM) / 2
        boxes.append(((p.left_mm + KEY_GAP_MM, sw_top, p.left_mm + KEY_GAP_MM + SWATCH_W_MM, sw_top + SWATCH_H_MM),
                      (text_left_mm, text_top, text_left_mm + text_w, text_top + text_h)))
        for x, y_up in dot_centres(lines, spec, text_left_mm, top_mm=0.0):
            y_dn = text_top - y_up
            centres.append((x, y_dn))
            # only the grid points within the dot's radius can be raised: work on that window
            y0, y1 = max(0, int((y_dn - r) / mm_per_px) - 1), min(rows, int((y_dn + r) / mm_per_px) + 2)
            x0, x1 = max(0, int((x - r) / mm_per_px) - 1), min(cols, int((x + r) / mm_per_px) + 2)
            d2 = ((xx[y0:y1, x0:x1] - x) ** 2 + (yy[y0:y1, x0:x1] - y_dn) ** 2) / r ** 2
            win = dots[y0:y1, x0:x1]
            np.maximum(win, spec.dot_height_mm * np.sqrt(np.clip(1 - d2, 0, 1)), out=win)
    h = np.maximum(h, dots)
    return KeyStrip(h, tuple(done), rows * mm_per_px - mm_per_px, tuple(centres), np.maximum(dots, outline),
                    tuple(boxes))
