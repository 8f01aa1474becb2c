"""What a picture shows, in a word or a short phrase: the overview of a multi-panel figure names
each panel's content with it ("a, top left, particles (about 40); b, top right, a network of
lines; …").

It asks the questions the panel's own print answers, with the same measurements on the same grid:
- the colour decision of the channel path (channel_auto.py) on the panel's colour sample: a
  fluorescence composite ("fluorescence, 3 colours") or a stained slide ("stained tissue");
- else the content style's decision (content.py, without its fallback shape) on the grid the
  panel's print decides on (print_grid: the print's width and grid from the figure's parameters
  and printer, the data band cropped, stretched and blurred as `prepare` does, the working grid at
  the nozzle pitch): a line network, line art, a population (counted), grains of weak contrast;
  and its lattice test;
- else "picture" (the print makes a shape of it, or the content style found nothing it names).
Once the grid decided on a coarse 128-point grid of its own, and the words disagreed with the
prints (FePt's 4 spheres read as a network of lines; the SiO2 fields and the Al2O3 grain
boundaries as "picture"); README, "Multi-panel figures", has the table of words against prints.
Nothing is random and the words depend only on the pixels and the parameters, so the overview
is the same file whichever panels a run prints. The print removes annotations by inpainting where
this only fills a panel letter's label box, so a count may differ by a member or two ("about").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WORD_COLOUR_PX = 256  # the colour decision on at most this many pixels a side (the prints': 512; 4× less work)
RELIEF_MM = 3.0  # the default relief (the content style's thresholds do not depend on it)
MIN_AREA_MM2 = 6.0  # the styles' smallest region (StyleOptions.min_area_mm2)
LABEL_SIDE = 0.3  # a panel letter's label box lies within this share of the shorter side from its corner
PLAIN = 0.02  # and is plain: within this of pure white or black (0..1 after the stretch)
DRAWING_REGIONS = 6  # lines on empty paper enclosing at most this many regions are a drawing, not a network
# A lattice: a few peaks holding a clear share of the detail's power, repeating at least
# MIN_REPEATS times across the panel: relief/content.py's lattice_spectrum (one FFT for both) and
# its PEAK_BINS, PEAK_SHARE and MIN_REPEATS, imported where used (the CLI starts without scipy).

KINDS = ("fluorescence", "stain", "lines", "line art", "grains", "region", "lattice", "members", "picture")


@dataclass(frozen=True)
class ContentWord:
    """What a panel shows: `kind` (one of KINDS), `words` (the phrase), `count` (members, or the
    colours of a fluorescence composite; None otherwise)."""

    kind: str
    words: str
    count: int | None = None


def content_word(values: np.ndarray, colour: np.ndarray | None = None, *, params=None, printer=None) -> ContentWord:
    """The content word of a picture: `values` (H, W) its brightness (any range, NaN unknown);
    `colour` (H, W, 3) its colour pixels at their own precision, or None for a grey picture.
    `params` (LithoParams) and `printer` (a PrinterProfile) are those the picture would be printed
    with on its own (a panel's print: the figure's parameters); the grey decision is made on that
    print's grid (default: LithoParams(), on its printer 100 mm wide)."""
    if colour is not None:
        from ..read.model import colour_sample
        from ..relief.channel_auto import colour_facts, colour_kind

        sample = colour_sample(np.asarray(colour))
        step = -(-max(sample.shape[:2]) // WORD_COLOUR_PX)
        facts = colour_facts(sample[::step, ::step])
        kind, _ = colour_kind(facts)
        if kind == "fluorescence":
            n = facts.colour_channels
            return ContentWord("fluorescence", f"fluorescence, {n} colours", n)
        if kind == "stain":
            return ContentWord("stain", "stained tissue")
    grid = print_grid(values, params, printer)
    if grid is None:
        return ContentWord("picture", "a flat picture")
    return _grey_word(grid)


@dataclass(frozen=True)
class PrintGrid:
    """The picture as its print's content style sees it: `work` (0..1) on the working grid of
    `pitch_mm`, the print `width_mm` wide; `fine` the finer picture (Prepared.finer); `nozzle_mm`."""

    work: np.ndarray
    pitch_mm: float
    width_mm: float
    nozzle_mm: float
    fine: object = None


def print_grid(values: np.ndarray, params=None, printer=None) -> PrintGrid | None:
    """The picture on the grid its own print would decide its content on (pipeline.py: a data
    band cropped, stretched, resampled to the print's grid and blurred as `prepare` does, then the
    working grid at the nozzle pitch, styles.py), or None when it is flat.

    Cheaper than the print: the picture is first shrunk (block means) to the finest grid the
    print ever looks at (FINE_PITCH_MM across its width, for lines thinner than a print pixel),
    the data band and the burned-in boxes (scale bar, labels) are found on that and inpainted as the
    print does (no arrows, no OCR), and a panel letter's label box that is not such a box is filled
    (without_corner_labels, on the picture scaled to its own 0..1). Unknown (NaN) pixels count as the darkest known value."""
    from PIL import Image

    from ..clean.band import detect_info_band
    from ..params import LithoParams
    from .sizing import layout_for, resolve_printer
    from ..relief.lines import FINE_PITCH_MM
    from ..relief.preprocess import prepare
    from ..relief.scales import WORK_MAX_POINTS, WorkGrid

    params = params or LithoParams()
    machine = resolve_printer(params, printer)
    v = np.asarray(values, np.float32)
    finite = np.isfinite(v)
    if not finite.all():
        if not finite.any():
            return None
        v = np.where(finite, v, np.float32(v[finite].min()))
    h, w = v.shape
    plan = layout_for(params, machine, w, image_h_px=h)
    fine_cols = round(plan.width_mm / FINE_PITCH_MM) + 1
    if w > fine_cols:
        rows_px = max(2, round(h * fine_cols / w))
        v = np.asarray(Image.fromarray(np.ascontiguousarray(v)).resize((fine_cols, rows_px), Image.Resampling.BOX), np.float32)
    if not params.keep_annotations:
        top, bottom = detect_info_band(v[:, ::max(1, v.shape[1] // (2 * plan.cols))])  # whole rows, every k-th column
        if top + bottom and top + bottom < v.shape[0] - 16:
            v = v[top:v.shape[0] - bottom]
        v = _without_boxes(v, plan.cols)
    lo, hi = float(v.min()), float(v.max())
    if hi > lo:  # a letter's label box filled before the stretch, as the print inpaints it before its own
        v = without_corner_labels((v - np.float32(lo)) / np.float32(hi - lo))
    prepared = prepare(v, None, rows=plan.rows, cols=plan.cols, target_aspect=plan.target_aspect, fit=plan.fit,
                       low_pct=params.stretch_low_pct, high_pct=params.stretch_high_pct, sigma_px=plan.blur_px,
                       invert=params.invert, flip_x=False)
    if prepared.uniform or float(np.ptp(prepared.image)) <= 1e-6:
        return None
    image = prepared.image
    grid = WorkGrid.plan(image.shape, plan.mm_per_px, machine.nozzle_mm, max_points=WORK_MAX_POINTS)
    width_mm = (image.shape[1] - 1) * plan.mm_per_px
    return PrintGrid(grid.down(image), grid.pitch_mm, width_mm, machine.nozzle_mm, prepared.finer)


def without_corner_labels(work: np.ndarray) -> np.ndarray:
    """The picture with a panel letter's label box, if any, filled with its median: a plain patch
    (within PLAIN of pure white or black) that holds the panel's corner point and stays inside
    that corner (LABEL_SIDE of the shorter side each way), the glyph inside it included. A letter's
    box in a particle field would count as one more particle, and on a specimen against a dark
    mount it hides that the contrast is weak. The prints clean it as an annotation; this is the
    cheap stand-in, from the pixels alone (a rebuilt overview has no OCR of its letters to go by)."""
    from scipy import ndimage

    rows, cols = work.shape
    q = max(2, int(LABEL_SIDE * min(rows, cols)))
    out = None
    for r0, c0 in ((0, 0), (0, cols - q), (rows - q, 0), (rows - q, cols - q)):
        window = work[r0:r0 + q, c0:c0 + q]
        corner = (0 if r0 == 0 else q - 1, 0 if c0 == 0 else q - 1)
        for plain in (window >= 1.0 - PLAIN, window <= PLAIN):
            if not plain[corner]:
                continue
            labels, _ = ndimage.label(plain)
            patch = labels == labels[corner]
            rr, cc = np.flatnonzero(patch.any(axis=1)), np.flatnonzero(patch.any(axis=0))
            inner_r = rr[-1] == q - 1 if r0 == 0 else rr[0] == 0
            inner_c = cc[-1] == q - 1 if c0 == 0 else cc[0] == 0
            if inner_r or inner_c:  # reaches out of the corner: the picture's own ground, not a label
                continue
            out = work.copy() if out is None else out
            out[r0 + rr[0]:r0 + rr[-1] + 1, c0 + cc[0]:c0 + cc[-1] + 1] = float(np.median(work))
    return work if out is None else out


def _without_boxes(v: np.ndarray, cols: int) -> np.ndarray:
    """The picture with its burned-in boxes (a scale bar's, a label's: annotations.detect_annotations,
    no arrows) inpainted as the print removes them. Both on every k-th pixel, k keeping at least
    twice the print grid's columns (the values stay exact, so a saturated box stays saturated), the
    filled patches then laid back on the full grid: 3-4 times less work on a 1000-px panel, and a
    sparse solve on a quarter of the pixels."""
    from scipy import ndimage

    from ..clean import annotations as marks

    k = max(1, v.shape[1] // (2 * cols))
    small = v[::k, ::k] if k > 1 else v
    mask, _ = marks.detect_annotations(small, arrows=False)
    if not mask.any():
        return v
    if k == 1:
        return marks.inpaint(v, mask)
    mask = ndimage.binary_dilation(mask, iterations=1)  # the pixels between the samples at its edge
    filled = marks.inpaint(small, mask)

    def full(a: np.ndarray) -> np.ndarray:
        a = np.repeat(np.repeat(a, k, axis=0), k, axis=1)[:v.shape[0], :v.shape[1]]
        return np.pad(a, ((0, v.shape[0] - a.shape[0]), (0, v.shape[1] - a.shape[1])), mode="edge")

    return np.where(full(mask), full(filled), v).astype(np.float32)


def _grey_word(grid: PrintGrid) -> ContentWord:
    from ..relief.content import MIN_PITCH_MM, MIN_REPEATS, PEAK_SHARE, lattice_spectrum, make_content
    from ..relief.picture_scale import find_objects_in_picture

    work, pitch_mm = grid.work, grid.pitch_mm

    def found():
        return find_objects_in_picture(work, pitch_mm=pitch_mm, min_area_mm2=MIN_AREA_MM2, nozzle_mm=grid.nozzle_mm)

    made = make_content(work, pitch_mm=pitch_mm, relief_mm=RELIEF_MM, width_mm=grid.width_mm, found=found,
                        min_area_mm2=MIN_AREA_MM2, fallback=False, fine=grid.fine)
    kind = made.kind if made is not None else None
    if kind == "lattice":
        return ContentWord("lattice", "a lattice")
    if kind == "lines":
        if _drawing(made.reason):
            return ContentWord("line art", "line drawing")
        return ContentWord("lines", "a network of lines")
    if kind == "grains":
        return ContentWord("grains", "grains")
    if kind == "plateau" and made.labels is not None and made.labels.max():
        n = int(made.labels.max())
        return ContentWord("region", "one region on an empty ground" if n == 1 else f"{n} regions on an empty ground", n)
    spectrum = lattice_spectrum(work, pitch_mm)
    period = spectrum.period
    if period is not None and MIN_PITCH_MM <= period.pitch_mm <= grid.width_mm / MIN_REPEATS and spectrum.peaked >= PEAK_SHARE:
        return ContentWord("lattice", "a lattice")
    if kind == "members" and made.labels is not None:
        n = int(made.labels.max())
        if n > 0:
            return ContentWord("members", count_phrase(n), n)
    return ContentWord("picture", "picture")


def _drawing(reason: str) -> bool:
    """Lines that are a drawing, from what content.py's reason says: line art, or a few regions
    (at most DRAWING_REGIONS: a box and a circle) outlined on an empty bright ground (paper); a
    network of grain boundaries on a bright ground encloses dozens."""
    import re

    if "line art" in reason:
        return True
    regions = re.search(r"enclosing (\d+) regions", reason)
    return bool(regions) and "an empty bright ground" in reason and int(regions.group(1)) <= DRAWING_REGIONS


def peaked(work: np.ndarray, pitch_mm: float) -> bool:
    """The detail's spectrum is a lattice's, a few sharp peaks: its strongest PEAK_BINS frequencies
    hold at least PEAK_SHARE of the power that content.lattice_period measures. A field of blobs
    of one size (noise smoothed to a scale) has a ring of power at that scale too, but spread over
    every direction (measured: particle fields and noisy textures 0.14-0.28; dot lattices and a
    grating 0.9-1.0). The same FFT as the content style's (content.lattice_spectrum)."""
    from ..relief.content import PEAK_SHARE, lattice_spectrum

    return lattice_spectrum(work, pitch_mm).peaked >= PEAK_SHARE


def count_phrase(n: int) -> str:
    """'particles (about 40)': about, because the small grid and the panel's uncleaned corners
    (a letter's label box can count as one more) make the count approximate."""
    return f"particles (about {n})"
