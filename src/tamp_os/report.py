"""What a lithograph is, in one typed Report, and the one place that says it in words: the CLI's
one-line summary, the notes on what was removed, the description for people who cannot see the
print, and the web app's summary lines."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .params import LithoParams


@dataclass
class Report:
    """Facts about one lithograph. Lengths in mm; `print_mm` is the whole object (width, depth,
    height), `relief_mm` the picture's width and depth on the plate."""

    input: str
    print_mm: list[float]
    relief_mm: list[float]
    grid: list[int]  # grid points across and down (cols, rows)
    mm_per_px: float
    blur_px: float  # Gaussian blur sigma in grid pixels
    printer: str
    nozzle_mm: float
    layer_mm: float
    height_levels: int
    mesher: str
    max_error_mm: float
    triangles: int
    vertices: int
    uniform: bool
    pixel_size_m: float | None
    pixel_size_source: str | None
    scale: str  # a sentence: "1 mm on the print = ... in the sample"
    tactile: dict | None
    crop: dict
    annotations: list[str]
    warnings: list[str]
    timings_s: dict[str, float]
    print: dict | None = None  # slicing results, set by slicer.slice_outputs when sliced
    relief_style: str = "reference"  # the style that made the heights (auto resolved)
    relief_reason: str = ""  # why that style, or what it did, in one sentence
    legibility: dict | None = None  # relief.legibility.Legibility.as_dict(): figures and verdicts
    instrument: dict | None = None  # magnification, kv, detector, signal, source when the file records them
    panels: dict | None = None  # multi-panel figures (figure.py): split or not and why, this print's panel

    def as_dict(self) -> dict:
        """The report as a plain dict (JSON-ready), with the keys of the earlier untyped report
        (except `files`: `save()` returns the paths it wrote)."""
        d = dataclasses.asdict(self)
        if d["print"] is None:
            del d["print"]
        return d

    # Read-only dict-style access, kept for code and notebooks written against the old dict.
    def __getitem__(self, key: str):
        return self.as_dict()[key]

    def get(self, key: str, default=None):
        return self.as_dict().get(key, default)


def summary_line(report: Report, written_names: list[str]) -> str:
    """One plain line per converted file, as `tamp-os convert` prints it."""
    w, d, h = report.print_mm
    scale = f"; {report.scale}" if report.pixel_size_m else ""
    levels = "a flat plate" if report.uniform else f"{report.height_levels} height levels"
    return (
        f"{report.input}: {w:g} × {d:g} × {h:g} mm, grid {report.grid[0]} × {report.grid[1]}, "
        f"{report.triangles:,} triangles, {levels}, relief style {report.relief_style}{scale}; "
        f"wrote {', '.join(written_names)}"
    )


def touch_notes(report: Report) -> list[str]:
    """The legibility verdicts: what a finger will find, with advice."""
    return list((report.legibility or {}).get("verdicts", []))


def removed_notes(report: Report) -> list[str]:
    """Plain sentences for what was cropped or inpainted."""
    crop, notes = report.crop or {}, []
    for side in ("top", "bottom"):
        if crop.get(f"{side}_rows"):
            notes.append(f"removed the data band: {crop[f'{side}_rows']} rows at the {side} ({crop['source']})")
    if report.annotations:
        notes.append("removed burned-in annotations: " + "; ".join(report.annotations))
    return notes


_SIGNAL_WORDS = {
    "SE": ("a secondary-electron (SE) detector", "in SE images brightness shows edges and slopes, not height"),
    "BSE": ("a backscattered-electron (BSE) detector", "in BSE images brightness shows composition (heavier elements are brighter), not height"),
    "STEM": ("a scanning transmission (STEM) detector", "in STEM images brightness shows mass and thickness, not height"),
}


def _instrument_sentence(instrument: dict) -> str:
    """'Recorded with a secondary-electron (SE) detector at 5 kV: ... not height.' from Report.instrument."""
    kv = f" at {instrument['kv']:g} kV" if instrument.get("kv") else ""
    mag = f", magnification {instrument['magnification']:,.0f}×" if instrument.get("magnification") else ""
    signal = _SIGNAL_WORDS.get(instrument.get("signal") or "")
    if signal:
        return f"Recorded with {signal[0]}{kv}{mag}: {signal[1]}."
    detector = f" with the {instrument['detector']} detector" if instrument.get("detector") else ""
    return f"Recorded{detector}{kv}{mag}."


def describe(report: Report, params: LithoParams, source_name: str) -> str:
    """A plain-language description of the object for people who cannot see it."""
    w, d, h = report.print_mm
    rw, rd = report.relief_mm
    parts = [
        f"A tactile relief of the image {source_name}.",
        f"The object is {w:g} mm wide, {d:g} mm deep and up to {h:g} mm high, on a {params.base_mm:g} mm base.",
        f"The picture itself is {rw:g} by {rd:g} mm. The top edge of the image is the far edge of the print.",
        _what_is_raised(report, params),
        f"Scale: {report.scale}.",
    ]
    if not report.uniform and touch_notes(report):
        parts.append("What a finger will find: " + " ".join(touch_notes(report)))
    if report.instrument:
        parts.append(_instrument_sentence(report.instrument))
    t = report.tactile
    if t:
        if t["orientation"]:
            parts.append("The top right corner of the plate is cut off at 45 degrees: hold the print with that corner at the top right.")
        if t["frame_box_mm"]:
            parts.append(f"A raised frame {params.frame_mm:g} mm wide surrounds the picture.")
        if t["scale_bar_box_mm"]:
            parts.append(
                f"Below the picture, at the left, a raised scale bar with end ticks stands for {t['scale_bar_label']} "
                f"in the sample; its value is in braille {'to its right' if t['scale_label_beside'] else 'below it'}."
            )
        if t["caption_braille"]:
            parts.append(f"Along the bottom margin, a braille caption reads: {params.caption}.")
    return " ".join(parts)


def _what_is_raised(report: Report, params: LithoParams) -> str:
    """One sentence on what stands up from the base, by relief style."""
    raised, lowered = ("dark", "bright") if params.invert else ("bright", "dark")
    up = f"{params.relief_mm:g} mm"
    if report.uniform:
        return "The image is uniform, so the print is a flat plate with no raised parts."
    if report.relief_style == "levels":
        levels = (report.legibility or {}).get("levels_mm") or []
        heights = ", ".join(f"{v:g}" for v in levels)
        return (f"The picture is made of {len(levels)} flat levels, {heights} mm above the base: "
                f"{lowered} parts of the image lowest, {raised} parts highest.")
    if report.relief_style == "objects":
        n = (report.legibility or {}).get("object_count", 0)
        return (f"{n} object{'s' if n != 1 else ''} found in the picture stand{'s' if n == 1 else ''} up as rounded domes, "
                f"up to {up} above the base, over a flat, lightly textured background.")
    if report.relief_style == "structure":
        return (f"The {raised} parts of the image are raised, up to {up} above the base, simplified to shapes a "
                f"fingertip can follow; finer detail is kept only as a low texture.")
    return f"The {raised} parts of the image are raised, up to {up} above the base."
