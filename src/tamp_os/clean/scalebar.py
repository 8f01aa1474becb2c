"""A pixel size from a scale bar burned into the image, used only when the file records none.

Bars are found in the data band and among the annotations removed from the picture: a long,
thin, straight stroke (with or without end ticks, possibly split by its own label), or a label
box whose width is the bar. The label beside the bar is read with the Tesseract OCR command on
an upscaled, binarised crop limited to digits and length units. Only a label that reads cleanly
as exactly one length is used, and only when every bar found agrees: a misread scale is worse
than none.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from ..units import unit_factor_m
from . import ocr

PROVENANCE = "scale bar label"
LABEL = re.compile(r"^\s*([0-9]+(?:[.,][0-9]+)?)\s*(nm|µm|μm|um|mm|Å)\s*$")
# No "p": OCR reads µ as p, and a "500 pm" misread of "500 µm" would be off by a million.
WHITELIST = "0123456789.,µumnÅ "
OCR_UPSCALE = 4


@dataclass(frozen=True)
class Bar:
    """A scale-bar candidate: its length in pixels and the crop (rows, cols) holding its label."""

    length_px: int
    label_rows: tuple[int, int]
    label_cols: tuple[int, int]


@dataclass(frozen=True)
class BarReading:
    """What the scale bars said: a pixel size in m (or None) and a sentence on how it was found."""

    metres: float | None
    detail: str
    bar_seen: bool = False


OCR_CACHE_SIZE = 256  # label crops remembered per process (a few hundred bytes each)
_ocr_cache: OrderedDict[tuple, str | None] = OrderedDict()
_ocr_cache_lock = threading.Lock()


def ocr_text(ink: np.ndarray) -> str | None:
    """Text in a small crop, read by Tesseract (None when no OCR is installed).

    ink : (h, w) bool, True on the label's strokes. It is drawn black on white, upscaled and
    binarised again, with a white margin: the conditions Tesseract reads best.

    What a crop reads as is remembered by its content (its shape and strokes) within the process:
    the same picture converted again (a sweep, the web app's next setting) reads no label twice.
    """
    if not ink.any() or ocr.backend() is None:
        return None
    key = (ink.shape, np.packbits(ink.astype(bool, copy=False)).tobytes())
    with _ocr_cache_lock:
        if key in _ocr_cache:
            _ocr_cache.move_to_end(key)
            return _ocr_cache[key]
    text, answered = _tesseract(ink)
    if answered:  # a failed or timed-out run is not remembered: the next picture tries again
        with _ocr_cache_lock:
            _ocr_cache[key] = text
            while len(_ocr_cache) > OCR_CACHE_SIZE:
                _ocr_cache.popitem(last=False)
    return text


def clear_ocr_cache() -> None:
    """Forget every label read (benchmarks time a picture as if it were new)."""
    with _ocr_cache_lock:
        _ocr_cache.clear()


def _after_fork() -> None:
    """A forked batch worker gets a lock of its own: the parent's scale-bar thread may have held it."""
    global _ocr_cache_lock
    _ocr_cache_lock = threading.Lock()


os.register_at_fork(after_in_child=_after_fork)


def _tesseract(ink: np.ndarray) -> tuple[str | None, bool]:
    """(text or None, whether Tesseract answered) for `ink`: in this process by tesserocr when it
    is installed (its model loads once per process; a `tesseract` command spends 0.1-0.2 s of CPU
    starting and loading the model for every label), else by the command."""
    canvas = _label_canvas(ink)
    if ocr.backend() == "tesserocr":
        text = ocr.read_text(canvas, 7, WHITELIST)
        return text, text is not None
    exe = shutil.which("tesseract")
    if exe is None:
        return None, False
    with tempfile.TemporaryDirectory(prefix="tamp-ocr-") as tmp:
        path = Path(tmp) / "label.png"
        canvas.save(path)
        command = [exe, str(path), "stdout", "--psm", "7", "-l", "eng", "-c", f"tessedit_char_whitelist={WHITELIST}"]
        try:
            done = subprocess.run(command, capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=30,
                                  env=_ocr_env())
        except (OSError, subprocess.TimeoutExpired):
            return None, False
    return (done.stdout, True) if done.returncode == 0 else (None, False)


def _label_canvas(ink: np.ndarray):
    """The label drawn black on white, upscaled and binarised again, with a white margin."""
    from PIL import Image

    page = Image.fromarray(np.where(ink, 0, 255).astype(np.uint8))
    page = page.resize((ink.shape[1] * OCR_UPSCALE, ink.shape[0] * OCR_UPSCALE), Image.Resampling.LANCZOS)
    page = page.point(lambda v: 255 if v > 127 else 0)
    canvas = Image.new("L", (page.width + 40, page.height + 40), 255)
    canvas.paste(page, (20, 20))
    return canvas


def _ocr_env() -> dict[str, str]:
    """One label is a few hundred pixels: Tesseract's OpenMP threads only cost here (10-20 % more
    CPU), and they would take the core the relief runs on beside them; the text read is the same.
    A limit the user set is kept."""
    return {"OMP_THREAD_LIMIT": "1", **os.environ}


def parse_label(text: str) -> float | None:
    """'10 µm' -> 1e-5; None unless the text is exactly one length (OCR often reads µ as u)."""
    lines = [line for line in text.splitlines() if line.strip()]
    if len(lines) != 1:
        return None
    match = LABEL.match(lines[0].replace("μ", "µ"))
    if not match:
        return None
    return float(match.group(1).replace(",", ".")) * unit_factor_m(match.group(2))


def ink_of(values: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels far from the region's most common value (its background).

    Unknown (NaN) pixels are never ink; a region of NaN padding only (stitched or registered
    float images) has none.
    """
    finite = np.isfinite(values)
    if not finite.any():
        return np.zeros(values.shape, bool)
    lo, hi = float(np.min(values[finite])), float(np.max(values[finite]))
    if hi <= lo:
        return np.zeros(values.shape, bool)
    scaled = np.where(finite, (values - lo) / (hi - lo), 0.0)
    background = np.bincount(np.clip((scaled * 15).astype(int), 0, 15).ravel()).argmax() / 15
    return np.abs(scaled - background) > 0.5


def _text_block(ink: np.ndarray, start: int, step: int, cols: slice, limit: int) -> tuple[int, int] | None:
    """Rows of the first block of inked rows met going from `start` by `step` within `cols`."""
    inked = ink[:, cols].any(axis=1)
    r, blank = start, 0
    while 0 <= r < ink.shape[0] and not inked[r]:
        r, blank = r + step, blank + 1
        if blank > limit:
            return None
    first = r
    while 0 <= r < ink.shape[0] and inked[r]:
        r += step
        if abs(r - first) > limit:  # taller than a line of text: picture, not a label
            return None
    if r == first:
        return None
    return (first, r) if step > 0 else (r + 1, first + 1)


def _segments(ink: np.ndarray, min_length_px: int) -> list[tuple[int, int, int, int]]:
    """(r0, r1, c0, c1) of thin horizontal strokes: runs of ink at least half of min_length_px
    long (the halves of a bar split by its label), a few rows thick, not spanning the width."""
    h, w = ink.shape
    min_len = max(min_length_px // 2, w // 50)
    long = ndimage.binary_opening(ink, structure=np.ones((1, min_len), bool))
    labels, _ = ndimage.label(long)
    found = []
    for sl in ndimage.find_objects(labels):
        r0, r1, c0, c1 = sl[0].start, sl[0].stop, sl[1].start, sl[1].stop
        if r1 - r0 <= max(10, h // 10) and c1 - c0 < 0.6 * w and c1 - c0 >= 4 * (r1 - r0):
            found.append((r0, r1, c0, c1))
    return found


def _join_split_bars(segments):
    """Join collinear strokes with a short gap between them (a label written inside the bar)."""
    segments = sorted(segments, key=lambda s: (s[0], s[2]))
    joined, gaps = [], []
    for seg in segments:
        if joined:
            r0, r1, c0, c1 = joined[-1]
            gap = seg[2] - c1
            if abs(seg[0] - r0) <= 1 and abs(seg[1] - r1) <= 1 and 0 < gap <= (c1 - c0) + (seg[3] - seg[2]):
                joined[-1] = (min(r0, seg[0]), max(r1, seg[1]), c0, seg[3])
                gaps[-1] = (c1, seg[2])
                continue
        joined.append(seg)
        gaps.append(None)
    return list(zip(joined, gaps))


def find_bars(ink: np.ndarray, min_length_px: int = 20) -> list[Bar]:
    """Scale-bar candidates among the strokes of `ink` (H, W bool) and where their labels are.

    A candidate is a thin horizontal stroke (end ticks allowed) whose connected ink is not part
    of a frame or table, with a block of text-like ink beside it (or in its gap).
    """
    h, w = ink.shape
    labels, _ = ndimage.label(ink)
    big = [i for i, sl in enumerate(ndimage.find_objects(labels), start=1)
           if sl[0].stop - sl[0].start > 0.6 * h or sl[1].stop - sl[1].start > 0.6 * w]
    frame = np.isin(labels, big)  # frame and table lines: never part of a label
    bars = []
    for (r0, r1, c0, c1), gap in _join_split_bars(_segments(ink, min_length_px)):
        if c1 - c0 < min_length_px:
            continue
        stroke = labels[r0:r1, c0:c1] if gap is None else np.hstack([labels[r0:r1, c0 : gap[0]], labels[r0:r1, gap[1] : c1]])
        ids = np.unique(stroke)
        own = np.isin(labels, ids[ids > 0])  # the stroke with its end ticks
        own_rows = np.flatnonzero(own.any(axis=1))
        if own_rows[-1] - own_rows[0] + 1 > max(0.6 * h, 6 * (r1 - r0) + 24) and gap is None:
            continue  # part of a frame or table, or of the picture
        text, length = ink & ~own & ~frame, c1 - c0
        if gap is not None:  # the label sits in the gap
            bars.append(Bar(length, _grow_rows(text, r0, r1, slice(*gap)), gap))
            continue
        cols = slice(max(0, c0 - length // 4), min(w, c1 + length // 4))
        limit = max(6 * (r1 - r0), 30)
        for block in (_text_block(text, own_rows[0] - 1, -1, cols, limit), _text_block(text, own_rows[-1] + 1, 1, cols, limit)):
            if block is not None and _looks_like_text(text[block[0] : block[1], cols]):
                bars.append(Bar(length, block, (cols.start, cols.stop)))
        rows = (int(own_rows[0]), int(own_rows[-1]) + 1)
        for side in (_side_block(text, rows, c1, 1, length), _side_block(text, rows, c0 - 1, -1, length)):
            if side is not None and _looks_like_text(text[rows[0] : rows[1], side[0] : side[1]]):
                bars.append(Bar(length, _grow_rows(text, *rows, slice(*side)), side))
    return bars


def _side_block(ink: np.ndarray, rows: tuple[int, int], start: int, step: int, length: int) -> tuple[int, int] | None:
    """Columns of the words beside a bar, on its own line (FEI and many SEM databars write
    "|----|  5 µm"): the first inked columns within half the bar's length of its end, up to a
    blank run as wide as the line is tall (the space between a label and the next field)."""
    inked = ink[rows[0] : rows[1]].any(axis=0)
    gap_px = max(4, rows[1] - rows[0])
    c, blank = start + step, 0
    while 0 <= c < ink.shape[1] and not inked[c]:
        c, blank = c + step, blank + 1
        if blank > length // 2:
            return None
    if not 0 <= c < ink.shape[1]:
        return None
    first, last, blank = c, c, 0
    while 0 <= c < ink.shape[1] and blank <= gap_px and abs(c - first) <= 2 * length:
        if inked[c]:
            last, blank = c, 0
        else:
            blank += 1
        c += step
    return (min(first, last), max(first, last) + 1)


def _looks_like_text(block: np.ndarray) -> bool:
    """At least two glyphs (a number and a unit) on one line of plausible height."""
    _, n = ndimage.label(block)
    return 2 <= n <= 12 and 5 <= block.shape[0] <= 80


def _one_short_line(ink: np.ndarray) -> bool:
    """Whether a box holds one line of text clearly narrower than the box (a label, not a table cell)."""
    rows = np.flatnonzero(ink.any(axis=1))
    cols = np.flatnonzero(ink.any(axis=0))
    if rows.size == 0 or rows.size != rows[-1] - rows[0] + 1:
        return False  # empty, or several lines
    return cols[-1] - cols[0] + 1 <= 0.7 * ink.shape[1]


def _grow_rows(ink: np.ndarray, r0: int, r1: int, cols: slice) -> tuple[int, int]:
    """Rows around r0..r1 that are inked within `cols`, up to the first blank row each way."""
    inked = ink[:, cols].any(axis=1)
    while r0 > 0 and inked[r0 - 1]:
        r0 -= 1
    while r1 < ink.shape[0] and inked[r1]:
        r1 += 1
    return r0, r1


def read_bar(ink: np.ndarray, bar: Bar) -> float | None:
    """The pixel size in m that `bar`'s label gives, or None when it does not read cleanly."""
    (r0, r1), (c0, c1) = bar.label_rows, bar.label_cols
    # Widen by a few rows for descenders (µ), keeping only the strokes that reach the label rows.
    top, bottom = max(0, r0 - 3), min(ink.shape[0], r1 + 3)
    labels, _ = ndimage.label(ink[top:bottom, c0:c1])
    keep = np.unique(labels[r0 - top : r1 - top])
    crop = np.isin(labels, keep[keep > 0])
    cols = np.flatnonzero(crop.any(axis=0))
    if cols.size == 0 or r1 - r0 < 5:
        return None
    metres = parse_label(ocr_text(crop[:, cols[0] : cols[-1] + 1]) or "")
    return metres / bar.length_px if metres else None


MIN_BOX_ASPECT = 1.5  # a label box holding a scale bar is at least this many times as wide as tall
MAX_OCR_CALLS = 12  # each call is 0.1–0.3 s; a picture with many strokes must not stall a conversion


def scale_from_bars(regions: list[np.ndarray], boxes: list[np.ndarray], strips: list[np.ndarray] = ()) -> BarReading:
    """The pixel size that the scale bars in `regions` and label `boxes` agree on.

    regions : (h, w) float crops where bars may be (the data band, the picture's edges).
    boxes : (h, w) float crops of label boxes found in the picture; a box with no bar inside
        is taken as the bar itself (its width is the length its label names).
    strips : crops of the picture's edges, where a bar may be; strokes there that do not read
        as a scale bar are not reported (natural pictures have many).
    """
    candidates = []
    for region in regions:
        ink = ink_of(region)
        candidates += [(ink, bar) for bar in find_bars(ink)]
    for box in boxes:
        if box.shape[1] < MIN_BOX_ASPECT * box.shape[0]:
            continue  # a square label box holds a panel letter or a symbol: a bar with its label is wide
        ink = ink_of(box)
        # A bar fills much of a small label box; in a wide databar box it is one field of several.
        inside = find_bars(ink, min(box.shape[1] // 3, max(20, 2 * box.shape[0])))
        if not inside and _one_short_line(ink):  # the label box is the bar
            inside = [Bar(box.shape[1], (0, box.shape[0]), (0, box.shape[1]))]
        candidates += [(ink, bar) for bar in inside]
    seen = bool(candidates)
    for strip in strips:
        ink = ink_of(strip)
        candidates += [(ink, bar) for bar in find_bars(ink)]
    if not candidates:
        return BarReading(None, "no scale bar found in the image")
    if ocr.backend() is None:
        return BarReading(None, "a scale bar may be in the image, but reading its label needs Tesseract (apt-get install tesseract-ocr)", seen)
    readings = [size for ink, bar in candidates[:MAX_OCR_CALLS] if (size := read_bar(ink, bar))]
    if not readings:
        return BarReading(None, "a scale bar was found, but its label did not read cleanly; no scale is known", seen)
    if max(readings) > 1.03 * min(readings):
        return BarReading(None, "scale bars in the image disagree; no scale is taken from them", True)
    return BarReading(float(np.median(readings)), PROVENANCE, True)
