"""What a picture shows, in a word or a short phrase, cheaply: the overview of a multi-panel
figure names each panel's content with it ("a, top left, particles (about 40); b, top right, a
network of lines; …").

It asks the questions the prints answer, with the same measurements, on a small grid:
- the colour decision of the channel path (channel_auto.py) on the panel's colour sample: a
  fluorescence composite ("fluorescence, 3 colours") or a stained slide ("stained tissue");
- else the content style's decision (content.py, without its fallback shape) on the panel shrunk
  to WORD_GRID_PX points on its longer side, as if printed WORD_WIDTH_MM wide: a line network,
  line art, a population (counted), grains of weak contrast; and its lattice test;
- else "picture".
The grid is fixed and nothing is random, so the words are the same on every run. A panel's own
print decides on a finer grid and its cleaned picture, so it may count a few members more or less
("about").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WORD_GRID_PX = 128  # points on the panel's longer side: a 0.8 mm pitch on a 100 mm plate, under a fingertip
WORD_WIDTH_MM = 100.0  # the panel as if printed this wide (a plate's width) for the mm-based thresholds
RELIEF_MM = 3.0  # the default relief (the content style's thresholds do not depend on it)
MIN_AREA_MM2 = 6.0  # the styles' smallest region (StyleOptions.min_area_mm2)
NOZZLE_MM = 0.4

KINDS = ("fluorescence", "stain", "lines", "line art", "grains", "lattice", "members", "picture")


@dataclass(frozen=True)
class ContentWord:
    """What a panel shows: `kind` (one of KINDS), `words` (the phrase), `count` (members, or the
    colours of a fluorescence composite; None otherwise)."""

    kind: str
    words: str
    count: int | None = None


def content_word(values: np.ndarray, colour: np.ndarray | None = None) -> ContentWord:
    """The content word of a picture: `values` (H, W) its brightness (any range, NaN unknown);
    `colour` (H, W, 3) its colour pixels at their own precision, or None for a grey picture."""
    if colour is not None:
        from ..read import colour_sample
        from .channel_auto import colour_facts, colour_kind

        facts = colour_facts(colour_sample(np.asarray(colour)))
        kind, _ = colour_kind(facts)
        if kind == "fluorescence":
            n = facts.colour_channels
            return ContentWord("fluorescence", f"fluorescence, {n} colours", n)
        if kind == "stain":
            return ContentWord("stain", "stained tissue")
    work = _small(values)
    if work is None:
        return ContentWord("picture", "a flat picture")
    return _grey_word(work)


def _small(values: np.ndarray) -> np.ndarray | None:
    """The picture at WORD_GRID_PX on its longer side (block means of its pixels), stretched 2nd–98th
    percentile to 0..1 as the prints are, or None when it is flat. Unknown (NaN) pixels count as
    the darkest known value."""
    from PIL import Image

    v = np.asarray(values, np.float32)
    h, w = v.shape
    finite = np.isfinite(v)
    if not finite.all():
        if not finite.any():
            return None
        v = np.where(finite, v, np.float32(v[finite].min()))
    scale = WORD_GRID_PX / max(h, w)
    cols, rows = max(8, round(w * scale)), max(8, round(h * scale))
    small = np.asarray(Image.fromarray(np.ascontiguousarray(v)).resize((cols, rows), Image.Resampling.BOX), np.float32)
    lo, hi = np.percentile(small, [2, 98])
    if hi - lo <= 1e-6 * max(abs(float(hi)), 1.0):
        return None
    return np.clip((small - lo) / (hi - lo), 0, 1).astype(np.float32)


def _grey_word(work: np.ndarray) -> ContentWord:
    from .content import MIN_PITCH_MM, lattice_period, make_content
    from .objects import find_objects

    pitch_mm = WORD_WIDTH_MM / max(work.shape[1] - 1, 1)

    def found():
        return find_objects(work, pitch_mm=pitch_mm, min_area_mm2=MIN_AREA_MM2, nozzle_mm=NOZZLE_MM)

    made = make_content(work, pitch_mm=pitch_mm, relief_mm=RELIEF_MM, width_mm=WORD_WIDTH_MM, found=found,
                        min_area_mm2=MIN_AREA_MM2, fallback=False)
    kind = made.kind if made is not None else None
    if kind == "lines":
        if "line art" in made.reason:  # content.py's reason names strokes on empty paper so
            return ContentWord("line art", "line drawing")
        return ContentWord("lines", "a network of lines")
    if kind == "grains":
        return ContentWord("grains", "grains")
    period = lattice_period(work, pitch_mm)
    if period is not None and period.pitch_mm >= MIN_PITCH_MM:
        return ContentWord("lattice", "a lattice")
    if kind == "members" and made.labels is not None:
        n = int(made.labels.max())
        if n > 0:
            return ContentWord("members", count_phrase(n), n)
    return ContentWord("picture", "picture")


def count_phrase(n: int) -> str:
    """'particles (about 40)': about, because the small grid and the panel's uncleaned corners
    (a letter's label box can count as one more) make the count approximate."""
    return f"particles (about {n})"
