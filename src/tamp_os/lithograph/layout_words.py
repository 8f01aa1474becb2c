"""The layout of a relief in words, for alt text: what is raised, how many, where, which is largest.

The raised parts are found on the heights themselves (what a finger meets), not on the image:
the relief above half its height, in pieces of at least a fingertip's area (4 mm²). Each piece gets
a place on a 3 × 3 grid of the picture (top left … centre … bottom right), seen as the print is
held (the image's top row at the far edge), a size relative to the largest, and a shape word
(round, rectangular, long or irregular) from its filled area against its bounding box and its elongation.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

MIN_PIECE_MM2 = 4.0  # smaller raised spots are felt as texture, not as things to count
RAISED_FRACTION = 0.5  # of the relief height
MAX_LISTED = 5  # more pieces than this are told as a count and a spread, not one by one

NUMBER_WORDS = ("no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten", "eleven", "twelve")


@dataclass(frozen=True)
class Piece:
    """One raised piece of the relief. Positions are fractions of the picture: x from the left, y from the far (top) edge."""

    x: float
    y: float
    area_mm2: float
    shape: str  # "round", "rectangular", "long" or "irregular"

    @property
    def place(self) -> str:
        return place_word(self.x, self.y)


@dataclass(frozen=True)
class ReliefLayout:
    pieces: tuple[Piece, ...]  # largest first
    raised_share: float  # share of the picture's area that is raised

    def as_dict(self) -> dict:
        return {"pieces": [asdict(p) | {"place": p.place} for p in self.pieces], "raised_share": round(self.raised_share, 3)}

    @classmethod
    def from_dict(cls, data: dict) -> "ReliefLayout":
        pieces = tuple(Piece(p["x"], p["y"], p["area_mm2"], p["shape"]) for p in data.get("pieces", []))
        return cls(pieces, float(data.get("raised_share", 0.0)))


def place_word(x: float, y: float) -> str:
    """'top left', 'top', 'centre', 'right', … for a position given as fractions (x from the left, y from the top)."""
    row = "top" if y < 1 / 3 else ("bottom" if y > 2 / 3 else "")
    col = "left" if x < 1 / 3 else ("right" if x > 2 / 3 else "")
    if row and col:
        return f"{row} {col}"
    return row or col or "centre"


def count_words(n: int, singular: str, plural: str | None = None) -> str:
    """'one bump', 'four bumps', '14 bumps': the number in words up to twelve, the noun agreeing."""
    noun = singular if n == 1 else (plural or singular + "s")
    number = NUMBER_WORDS[n] if 0 <= n < len(NUMBER_WORDS) else f"{n:,}"
    return f"{number} {noun}"


def find_layout(heights_mm: np.ndarray, mm_per_px: float, base_mm: float, *, relief_mm: float) -> ReliefLayout:
    """The raised pieces of `heights_mm` ((rows, cols), row 0 at the far edge), largest first."""
    from scipy import ndimage

    from ..relief.legibility import ASSESS_MAX_POINTS

    h = np.asarray(heights_mm, dtype=np.float64)
    if h.size > ASSESS_MAX_POINTS:  # a plate over about 500 mm at High: every step-th point (a piece is 4 mm² or more: 25 points at 0.4 mm)
        step = math.ceil(math.sqrt(h.size / ASSESS_MAX_POINTS))
        h, mm_per_px = h[::step, ::step], mm_per_px * step
    raised = (h - base_mm) > RAISED_FRACTION * relief_mm
    labels, count = ndimage.label(raised)
    rows, cols = h.shape
    pieces = []
    if count:
        sizes, centres = _sizes_and_centres(labels, count)
        boxes = ndimage.find_objects(labels)
        for k, (size, (cy, cx), box) in enumerate(zip(sizes, centres, boxes)):
            area = float(size) * mm_per_px * mm_per_px
            if area < MIN_PIECE_MM2:
                continue
            pieces.append(Piece(round(float(cx) / max(cols - 1, 1), 3), round(float(cy) / max(rows - 1, 1), 3),
                                round(area, 1), _shape(labels[box] == k + 1)))
    pieces.sort(key=lambda p: (-p.area_mm2, p.y, p.x))
    return ReliefLayout(tuple(pieces), float(raised.mean()) if raised.size else 0.0)


def _sizes_and_centres(labels: np.ndarray, count: int) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Points and centre (row, column) of each of the labels 1..count: the numbers that
    ndimage.sum_labels and center_of_mass give with weights of one (their bincounts, in the same
    order), without their image of ones; the row and column indices are one image at a time
    (at 1000 mm, High: 150 MB each)."""
    flat = labels.ravel()
    rows, cols = labels.shape
    sizes = np.bincount(flat, minlength=count + 1)[1 : count + 1].astype(np.float64)  # sums of ones: exact counts
    row_sums = np.bincount(flat, weights=np.repeat(np.arange(rows, dtype=np.float64), cols), minlength=count + 1)[1 : count + 1]
    col_sums = np.bincount(flat, weights=np.tile(np.arange(cols, dtype=np.float64), rows), minlength=count + 1)[1 : count + 1]
    return sizes, list(zip(row_sums / sizes, col_sums / sizes))


def _shape(mask: np.ndarray) -> str:
    """round: a squarish box filled about as a disc fills it (π/4); rectangular: a box filled almost
    whole; long: one side 2.5 times the other or more; else irregular."""
    h, w = mask.shape
    fill = mask.sum() / float(h * w)
    elongation = max(h, w) / max(min(h, w), 1)
    if elongation >= 2.5:
        return "long"
    if fill >= 0.9:
        return "rectangular"
    if fill >= 0.65 and elongation <= 1.5:
        return "round"
    return "irregular"


def _spread(pieces) -> str:
    """Where a group lies: 'across the middle', 'down the left side', 'at the top right', 'all over the picture'."""
    xs, ys = [p.x for p in pieces], [p.y for p in pieces]
    wide, tall = max(xs) - min(xs) > 0.45, max(ys) - min(ys) > 0.45
    if wide and tall:
        return "spread over the picture"
    mean_x, mean_y = float(np.mean(xs)), float(np.mean(ys))
    if wide:
        row = "top" if mean_y < 1 / 3 else ("bottom" if mean_y > 2 / 3 else "middle")
        return f"across the {row}"
    if tall:
        col = "left side" if mean_x < 1 / 3 else ("right side" if mean_x > 2 / 3 else "middle")
        return f"down the {col}"
    place = place_word(mean_x, mean_y)
    return "at the centre" if place == "centre" else f"at the {place}"


def layout_sentence(layout: ReliefLayout, noun: str = "raised shape", counted: bool = False) -> str:
    """The layout in one sentence: 'Four round bumps stand up across the middle, the largest at the right.'
    With `counted` (an earlier sentence gave the count), it starts 'They stand up …' ('It stands up …')."""
    pieces = layout.pieces
    if not pieces:
        return "No raised shape is large enough to find by touch; the picture is felt as texture."
    shapes = {p.shape for p in pieces}
    kind = f"{next(iter(shapes))} " if len(shapes) == 1 and pieces[0].shape != "irregular" else ""
    n = len(pieces)
    head = ("It" if n == 1 else "They") if counted else count_words(n, f"{kind}{noun}").capitalize()
    verb = "stands" if n == 1 else "stand"
    if n == 1:
        return f"{head} {verb} up {_at(pieces[0].place)}."
    text = f"{head} {verb} up {_spread(pieces)}"
    largest = pieces[0]
    stands_out = largest.area_mm2 >= 1.5 * pieces[1].area_mm2
    if stands_out:
        text += f", the largest {_at(largest.place)}"
    if n <= MAX_LISTED and len({p.place for p in pieces}) == n:  # few, each in its own place: say where
        if stands_out:
            rest = _and_list([p.place for p in pieces[1:]])
            text += f"; the other is at the {rest}" if n == 2 else f"; the others are at the {rest}"
        else:
            in_reading_order = sorted(pieces, key=lambda p: (round(p.y * 3), p.x))
            text += f": at the {_and_list([p.place for p in in_reading_order])}"
    return text + "."


def _and_list(words: list[str]) -> str:
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def _at(place: str) -> str:
    return "in the centre" if place == "centre" else f"at the {place}"
