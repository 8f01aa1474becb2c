"""The raised scale bar's value and the place of its braille label, chosen to fit the plate.

A bar is a round sample length (1, 2 or 5 × 10^n) drawn MIN_BAR_MM to MAX_BAR_MM long on the
print; its value is written in braille to its right when there is room, else on the line(s)
below it (broken only between words, so a number is never split).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .braille import BLANK, BrailleSpec, block_size_mm, to_braille
from ..errors import ParameterError
from ..units import format_length

MIN_BAR_MM = 8.0  # shorter bars read as one bump: their end ticks merge under a fingertip
MAX_BAR_MM = 40.0
TARGET_BAR_MM = 20.0
GAP_MM = 4.0  # between the bar and its label (the furniture's clearance)
TICK_LENGTH_MM = 5.0  # the row is at least as tall as the ticks


@dataclass(frozen=True)
class ScaleBar:
    """A scale bar ready to place: sizes in mm on the print."""

    value_m: float  # the sample length it stands for
    length_mm: float
    label: str  # e.g. "20 µm"
    label_lines: tuple[str, ...]  # the label in braille, one or more lines
    beside: bool  # label to the right of the bar (else below it)
    spec: BrailleSpec

    @property
    def label_size_mm(self) -> tuple[float, float]:
        return block_size_mm(list(self.label_lines), self.spec)

    @property
    def row_mm(self) -> tuple[float, float]:
        """Width and height of the whole row (bar, ticks and label)."""
        label_w, label_h = self.label_size_mm
        if self.beside:
            return self.length_mm + GAP_MM + label_w, max(TICK_LENGTH_MM, label_h)
        return max(self.length_mm, label_w), TICK_LENGTH_MM + GAP_MM + label_h


def label_text(value_m: float) -> str:
    """'20 µm', '0.5 mm': the value as the description and the braille label say it."""
    return format_length(value_m).replace(".0 ", " ")


def arrange(value_m: float, sample_m_per_mm: float, inner_mm: float, *, spec: BrailleSpec, table: str) -> ScaleBar:
    """The bar for `value_m`, its label beside it if the row fits `inner_mm`, else below it."""
    label = label_text(value_m)
    line = to_braille(label, table)
    length = value_m / sample_m_per_mm
    bar = ScaleBar(value_m, length, label, (line,), True, spec)
    if bar.row_mm[0] <= inner_mm:
        return bar
    one_line = ScaleBar(value_m, length, label, (line,), False, spec)
    if one_line.row_mm[0] <= inner_mm:
        return one_line
    words = tuple(w for w in line.split(BLANK) if w)
    return ScaleBar(value_m, length, label, words, False, spec)


def round_lengths_m(sample_m_per_mm: float, lo_mm: float, hi_mm: float) -> list[float]:
    """Every 1, 2 or 5 × 10^n sample length whose bar is lo_mm..hi_mm long on the print."""
    out = []
    start = math.floor(math.log10(sample_m_per_mm * lo_mm)) - 1
    for exponent in range(start, start + 4):
        for mantissa in (1, 2, 5):
            value = float(f"{mantissa}e{exponent}")  # exact decimal, not 5 * 10.0**-7
            if lo_mm * (1 - 1e-9) <= value / sample_m_per_mm <= hi_mm * (1 + 1e-9):
                out.append(value)
    return out


def auto_scale_bar(sample_m_per_mm: float, inner_mm: float, spec: BrailleSpec, *, table: str) -> ScaleBar | None:
    """The automatic bar: fits `inner_mm` (the plate's width inside its borders), its label beside
    it if possible, nearest TARGET_BAR_MM long; None when no bar of MIN_BAR_MM fits."""
    hi = min(MAX_BAR_MM, inner_mm)
    if hi < MIN_BAR_MM:
        return None
    bars = [arrange(v, sample_m_per_mm, inner_mm, spec=spec, table=table) for v in round_lengths_m(sample_m_per_mm, MIN_BAR_MM, hi)]
    if not bars:
        return None

    def cost(bar: ScaleBar):  # fits without growing the plate, label beside, length near the target
        return (bar.row_mm[0] > inner_mm, not bar.beside, abs(bar.length_mm - TARGET_BAR_MM))

    return min(bars, key=cost)


def chosen_scale_bar(value_m: float, sample_m_per_mm: float, inner_mm: float, *, spec: BrailleSpec, table: str) -> ScaleBar:
    """The bar the user asked for, refused with a clear message if it cannot be felt or placed."""
    length = value_m / sample_m_per_mm
    label = label_text(value_m)
    if length < MIN_BAR_MM:
        raise ParameterError(
            f"`scale_bar`: {label} is {length:.2g} mm on this print, shorter than the {MIN_BAR_MM:g} mm a finger "
            f"can read as a bar with two ends; choose a longer `scale_bar` (at least {format_length(MIN_BAR_MM * sample_m_per_mm)}) or 'auto'."
        )
    if length > inner_mm:
        raise ParameterError(
            f"`scale_bar`: {label} is {length:.1f} mm on this print, longer than the {inner_mm:.1f} mm of the plate "
            f"inside its borders; choose a shorter `scale_bar`, 'auto', or a wider print (`width_mm`)."
        )
    return arrange(value_m, sample_m_per_mm, inner_mm, spec=spec, table=table)
