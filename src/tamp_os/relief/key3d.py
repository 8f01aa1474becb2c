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
from ..tactile.braille import block_size_mm, dot_centres, to_braille, wrap_cells
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


OUTLINE_MM = 0.8  # a swatch's raised outline: its outer rim, inside the swatch so the 3 mm gaps stay


def _swatch(encoding: str, rows: int, cols: int, mm_per_px: float, relief_mm: float) -> np.ndarray:
    img = np.zeros((rows, cols))
    if encoding == "domes":  # two domes of 3.5 mm, as nuclei
        yy, xx = np.mgrid[0:rows, 0:cols] * mm_per_px
        for cx in (cols * mm_per_px * 0.27, cols * mm_per_px * 0.73):
            img[(xx - cx) ** 2 + (yy - rows * mm_per_px / 2) ** 2 <= 1.75 ** 2] = 1.0
    else:
        img[1:-1, 1:-1] = 1.0
    h, _ = encode(img, encoding, mm_per_px, relief_mm)
    return h


def key_strip(entries: tuple[KeyEntry, ...], *, width_mm: float, mm_per_px: float, relief_mm: float,
              table: str, spec: BrailleSpec | None = None) -> KeyStrip:
    spec = spec or BrailleSpec()
    cols = round(width_mm / mm_per_px) + 1
    text_left_mm = KEY_GAP_MM + SWATCH_W_MM + KEY_GAP_MM
    max_cells = max(1, int((width_mm - text_left_mm - KEY_GAP_MM - spec.dot_spacing_mm - spec.dot_diameter_mm) // spec.cell_spacing_mm) + 1)
    rows_layout, done, y = [], [], KEY_GAP_MM
    for e in entries:
        braille = to_braille(e.label, table, what="key_labels")
        lines = wrap_cells(braille, max_cells)
        _, text_h = block_size_mm(lines, spec)
        row_h = max(SWATCH_H_MM, text_h)
        rows_layout.append((e, lines, y, row_h))
        done.append(dataclasses.replace(e, braille=braille))
        y += row_h + KEY_GAP_MM
    depth_mm = y
    rows = int(math.ceil(depth_mm / mm_per_px)) + 1
    h = np.zeros((rows, cols))
    yy, xx = np.mgrid[0:rows, 0:cols] * mm_per_px
    centres = []
    outline = np.zeros((rows, cols))
    dots = np.zeros((rows, cols))
    r = spec.dot_diameter_mm / 2
    for e, lines, top, row_h in rows_layout:
        r0, c0 = int(round((top + (row_h - SWATCH_H_MM) / 2) / mm_per_px)), round(KEY_GAP_MM / mm_per_px)
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
        _, text_h = block_size_mm(lines, spec)
        text_top = top + (row_h - text_h) / 2
        for x, y_up in dot_centres(lines, spec, text_left_mm, 0.0):
            y_dn = text_top - y_up
            centres.append((x, y_dn))
            # only the grid points within the dot's radius can be raised: work on that window
            y0, y1 = max(0, int((y_dn - r) / mm_per_px) - 1), min(rows, int((y_dn + r) / mm_per_px) + 2)
            x0, x1 = max(0, int((x - r) / mm_per_px) - 1), min(cols, int((x + r) / mm_per_px) + 2)
            d2 = ((xx[y0:y1, x0:x1] - x) ** 2 + (yy[y0:y1, x0:x1] - y_dn) ** 2) / r ** 2
            win = dots[y0:y1, x0:x1]
            np.maximum(win, spec.dot_height_mm * np.sqrt(np.clip(1 - d2, 0, 1)), out=win)
    h = np.maximum(h, dots)
    return KeyStrip(h, tuple(done), rows * mm_per_px - mm_per_px, tuple(centres), np.maximum(dots, outline))
