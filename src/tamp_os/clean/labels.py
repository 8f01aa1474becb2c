"""Printed text labels: the words of a diagram or drawing (dark letters on empty bright paper)
found from their glyphs, removed with the other annotations, and every removed label's text
read by OCR (clean/ocr.py) so the description can name it ("labels removed: 'nucleus' (bottom
right)"). Only what OCR reads with confidence is given as text; the rest is "unreadable".

Glyphs are ink components a few pixels to GLYPH_MAX_SHARE of the picture high, drawn with
strokes (their widest stroke at most STROKE_SHARE of their height: cells, beads and stains are
solid); glyphs side by side on one line (gaps under a glyph's height) are a label when they
stand on clean paper (CLEAN_SHARE of their box and margin is paper or ink, not mid-grey).
Only pictures on empty paper are searched (PAPER_SHARE of the pixels within PAPER_TOLERANCE of
the lightest): a micrograph costs one histogram.
"""

from __future__ import annotations

import logging
import re
from dataclasses import replace

import numpy as np
from scipy import ndimage

from .annotations import Annotation

log = logging.getLogger(__name__)

PAPER_SHARE = 0.5  # share of the picture within PAPER_TOLERANCE of its lightest value: empty paper
PAPER_TOLERANCE = 0.1  # of the picture's range
GLYPH_MIN_PX = 5  # glyph height in pixels (smaller marks are specks)
GLYPH_MAX_SHARE = 0.08  # glyph height at most this share of the picture's height
STROKE_SHARE = 0.4  # a glyph's widest stroke at most this share of its height
MIN_GLYPHS = 2  # a label has at least this many glyphs (single marks are left to the picture)
CLEAN_SHARE = 0.8  # of a label's box and margin, this share is paper or ink (measured 0.90-1.0 on printed words, 0.24-0.57 on tissue)
MIN_CONFIDENCE = 70.0  # Tesseract's mean word confidence (0-100) for a reading to be given as text
READ_HEIGHT_PX = 60  # labels are scaled so their glyphs are this high for OCR
UNREADABLE = ""  # an Annotation's text when OCR could not read it with confidence


def on_paper(values: np.ndarray) -> bool:
    """Whether the picture is drawn on empty bright paper (PAPER_SHARE of it near its lightest)."""
    # The finite pixels; a picture finite everywhere is used as it is, without a copy.
    finite = values if np.isfinite(values).all() else values[np.isfinite(values)]
    if finite.size == 0:
        return False
    lo, hi = float(finite.min()), float(finite.max())
    if hi <= lo:
        return False
    return float(np.mean(finite >= hi - PAPER_TOLERANCE * (hi - lo))) >= PAPER_SHARE


def find_labels(values: np.ndarray, exclude: np.ndarray | None = None) -> tuple[np.ndarray, list[Annotation]]:
    """Mask of printed text labels (their glyphs, grown by a pixel) and one 'text' Annotation per label, outside
    `exclude` (annotations already found). Empty unless the picture is on empty paper."""
    mask = np.zeros(values.shape, bool)
    if not on_paper(values):
        return mask, []
    finite = np.isfinite(values)
    lo, hi = float(values[finite].min()), float(values[finite].max())
    ink_below, paper = (lo + hi) / 2, hi - PAPER_TOLERANCE * (hi - lo)
    ink = finite & (values < ink_below)
    if exclude is not None:
        ink &= ~exclude
    parts, n = ndimage.label(ink, structure=np.ones((3, 3)))
    if n == 0:
        return mask, []
    h = values.shape[0]
    boxes = ndimage.find_objects(parts)
    heights = np.array([b[0].stop - b[0].start for b in boxes])
    widths = np.array([b[1].stop - b[1].start for b in boxes])
    size_ok = (heights >= GLYPH_MIN_PX) & (heights <= max(GLYPH_MIN_PX, GLYPH_MAX_SHARE * h)) & (widths <= 2 * heights)
    glyph = np.zeros(n + 1, bool)
    for i in np.flatnonzero(size_ok):
        sl = boxes[i]
        piece = np.pad(parts[sl] == i + 1, 1)
        stroke = 2 * float(ndimage.distance_transform_edt(piece).max())
        glyph[i + 1] = stroke <= STROKE_SHARE * heights[i]
    if not glyph.any():
        return mask, []
    glyphs = glyph[parts]
    # Glyphs on one line: joined across gaps narrower than their height, not across lines.
    tall = int(np.median(heights[glyph[1:]]))
    joined = ndimage.binary_dilation(glyphs, structure=np.ones((max(1, tall // 3), max(3, tall)), bool))
    groups, _ = ndimage.label(joined)
    found = []
    for k, sl in enumerate(ndimage.find_objects(groups), start=1):
        members = np.unique(parts[sl][(groups[sl] == k) & glyphs[sl]])
        members = members[members > 0]
        if members.size < MIN_GLYPHS:
            continue
        rows = [boxes[j - 1][0] for j in members]
        cols = [boxes[j - 1][1] for j in members]
        r0, r1 = min(r.start for r in rows), max(r.stop for r in rows)
        c0, c1 = min(c.start for c in cols), max(c.stop for c in cols)
        if c1 - c0 < 1.5 * (r1 - r0):  # a word is wider than tall
            continue
        pad = max(3, (r1 - r0) // 2)
        around = values[max(0, r0 - pad) : r1 + pad, max(0, c0 - pad) : c1 + pad]
        if float(np.mean((around >= paper) | (around < ink_below))) < CLEAN_SHARE:
            continue  # mid-greys around it: texture of the picture (tissue), not letters on paper
        # With the marks that lie wholly inside the label (the dots of i and j, punctuation).
        inside = np.unique(parts[r0:r1, c0:c1])
        inside = [j for j in inside if j > 0 and boxes[j - 1][0].start >= r0 and boxes[j - 1][0].stop <= r1
                  and boxes[j - 1][1].start >= c0 and boxes[j - 1][1].stop <= c1]
        mask[r0:r1, c0:c1] |= np.isin(parts[r0:r1, c0:c1], np.union1d(members, inside))
        found.append(Annotation("text", (r0, r1), (c0, c1)))
    log.debug("text labels on paper: %d glyphs, %d labels", int(glyph.sum()), len(found))
    if found:
        mask = ndimage.binary_dilation(mask, iterations=1)  # the letters' antialiased edges
    return mask, found


def read_labels(values: np.ndarray, annotations: list[Annotation]) -> list[Annotation]:
    """The annotations with every text label's words read by OCR (UNREADABLE when OCR is
    missing or not confident); the other kinds unchanged."""
    from . import ocr

    out = []
    for a in annotations:
        if a.kind != "text":
            out.append(a)
            continue
        # Two renderings (smooth grey, and sharp black and white): small bitmap letters read
        # with confidence in one or the other; the second is read only when the first is not
        # confident, and the more confident reading is taken.
        readings = []
        for image in _for_ocr(values, a):
            reading = ocr.read_line(image)
            if reading is not None:
                readings.append(reading)
                if reading[1] >= MIN_CONFIDENCE:
                    break
        text = UNREADABLE
        if readings:
            words, confidence = max(readings, key=lambda r: r[1])
            words = " ".join(words.split())
            if confidence >= MIN_CONFIDENCE and re.search(r"[0-9A-Za-z]", words):
                text = words
            log.debug("label at rows %s, columns %s: %r (confidence %.0f)", a.rows, a.cols, words, confidence)
        out.append(replace(a, text=text))
    return out


def _for_ocr(values: np.ndarray, a: Annotation) -> list:
    """The label's box with a small margin, dark letters on white, as two PIL images: grey,
    scaled smoothly so its glyphs are READ_HEIGHT_PX high, and black and white, scaled by whole
    pixels to two thirds of that."""
    from PIL import Image

    (r0, r1), (c0, c1) = a.rows, a.cols
    pad = max(3, (r1 - r0) // 3)
    crop = values[max(0, r0 - pad) : r1 + pad, max(0, c0 - pad) : c1 + pad].astype(np.float32)
    crop = np.nan_to_num(crop, nan=float(np.nanmax(crop)) if np.isfinite(crop).any() else 0.0)
    lo, hi = float(crop.min()), float(crop.max())
    gray = np.zeros(crop.shape, np.uint8) if hi <= lo else ((crop - lo) / (hi - lo) * 255).astype(np.uint8)
    if np.mean(gray) < 128:  # light letters on a dark box: Tesseract reads dark on light best
        gray = 255 - gray
    images = []
    for picture, height, method in ((gray, READ_HEIGHT_PX, Image.Resampling.BICUBIC),
                                    (np.where(gray < 128, 0, 255).astype(np.uint8), 2 * READ_HEIGHT_PX // 3, Image.Resampling.NEAREST)):
        image = Image.fromarray(np.pad(picture, 10, constant_values=255))
        scale = max(1.0, height / max(r1 - r0, 1))
        images.append(image.resize((round(image.width * scale), round(image.height * scale)), method) if scale > 1 else image)
    return images
