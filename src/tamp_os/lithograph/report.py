"""What a lithograph is, in one typed Report, and the one place that says it in words: the CLI's
one-line summary, the notes on what was removed, the description for people who cannot see the
print, and the web app's summary lines."""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..clean.annotations import Annotation
from ..clean.band import Band
from ..clean.instrument import Instrument
from ..facts import Facts
from .layout_words import ReliefLayout
from ..params import LithoParams
from ..printing.printers import height_levels
from ..relief.legibility import Legibility

if TYPE_CHECKING:  # content_word: a figure's panels only
    from ..printing.slicer import SliceResult
    from .content_word import ContentWord
    from ..tactile.furniture import Placed


@dataclass(frozen=True)
class Plate(Facts):
    """Where the tactile furniture went on the plate (mm, x from the left, y from the near edge)."""

    plate_mm: list[float]
    relief_origin_mm: list[float]
    caption_braille: str | None
    caption_box_mm: Any
    scale_bar_box_mm: Any
    scale_bar_label: str | None  # the scale bar's chosen length in words ("5 µm")
    scale_bar_label_braille: str | None
    scale_label_box_mm: Any
    frame_box_mm: Any
    braille_dots: int
    scale_label_beside: bool
    orientation: str | None  # "cut corner at the top right", or None
    scale_bar_m: float | None = None  # the scale bar's chosen length in the sample, in metres
    scale_bar_mm: float | None = None  # and on the print


@dataclass(frozen=True)
class Printing(Facts):
    """What PrusaSlicer made of the print: the slicing result and its G-code file's name."""

    result: "SliceResult"
    gcode: str

    @property
    def summary(self) -> str:
        return self.result.sentence()

    def as_dict(self) -> dict:
        return {**self.result.as_dict(), "gcode": self.gcode, "summary": self.summary}


@dataclass(frozen=True)
class PanelFacts(Facts):
    """One print of a picture that may be a multi-panel figure (figure.py): whether the figure was
    split and why; for a panel its label, box (x, y, w, h in the figure's pixels), how it was
    found and whether its letter was read; for the overview every box, the panels printed and
    the braille written in each frame. `contents`: what each panel shows (relief/content_word.py),
    by label: every panel's on the overview, its own on a panel's print."""

    split: bool
    reason: str = ""
    panel: str | None = None
    box_px: tuple[int, int, int, int] | None = None
    found_by: str | None = None
    letter_read: bool | None = None
    panels: tuple[str, ...] = ()  # every panel's label, in reading order
    overview: bool = False
    boxes_px: tuple[tuple[int, int, int, int], ...] = ()
    printed: tuple[str, ...] = ()
    letters_braille: dict[str, str] = dataclasses.field(default_factory=dict)
    contents: dict[str, ContentWord] = dataclasses.field(default_factory=dict)


@dataclass(frozen=True)
class Report:
    """Facts about one lithograph, built once, frozen.

    Lengths are in mm: `print_mm` is the whole object (width, depth, height), `relief_mm` the
    picture's width and depth on the plate, `mm_per_px` the grid pitch; `grid` is (cols, rows).
    The parts (tactile plate, crop, annotations, instrument, legibility, printing) are typed;
    `as_dict()` gives the JSON of the recipe and `report["key"]` reads it.

    Examples
    --------
    >>> import numpy as np
    >>> from tamp_os import make_lithograph
    >>> report = make_lithograph(np.tile(np.linspace(0, 1, 80), (60, 1)), width_mm=40, preset="low").report
    >>> report.grid, report.mm_per_px, report.height_levels
    ([50, 38], 0.8163, 25)
    >>> report["print_mm"]
    [40.0, 30.0, 4.0]
    """

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
    tactile: Plate | None
    crop: Band
    annotations: tuple[Annotation, ...]
    warnings: tuple[str, ...]
    timings_s: dict[str, float]
    print: Printing | None = None  # slicing results; `with_printing` makes the report of a sliced print
    relief_style: str = "reference"  # the style that made the heights (auto resolved)
    relief_reason: str = ""  # why that style, or what it did, in one sentence
    content_kind: str = ""  # the content style: "members", "lattice", "lines", "grains", "plateau" or "shape" (what it raised)
    lattice_pitch_mm: float | None = None  # content_kind "lattice": the columns' spacing on the print
    key_depth_mm: float = 0.0  # the depth the braille key added below the picture (in relief_mm's depth)
    legibility: Legibility | None = None  # figures and verdicts
    check_flags: tuple[str, ...] = ()  # what the print may get wrong against its picture (relief/agreement.py), one line each with the option that changes it
    instrument: Instrument | None = None  # magnification, kv, detector, signal, source when the file records them
    source_px: tuple[int, int] = (0, 0)  # the source image's width and height (where annotations were)
    layout: "ReliefLayout | None" = None  # where the raised pieces are (layout_words.py), for the description
    key: tuple = ()  # KeyEntry (label, encoding, braille) of a channel print's key; empty otherwise
    panels: "PanelFacts | None" = None  # a multi-panel figure (figure.py): split or not and why, this print's panel

    def as_dict(self) -> dict:
        """The report as a plain dict (JSON-ready), with the keys of the earlier untyped report
        (except `files`: `save()` returns the paths it wrote)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "source_px"}
        if self.key:
            d["key"] = [dataclasses.asdict(e) for e in self.key]
        else:
            del d["key"]
        d["tactile"] = self.tactile.as_dict() if self.tactile else None
        d["crop"] = self.crop.as_dict()
        d["annotations"] = [a.describe() for a in self.annotations]
        d["warnings"] = [str(w) for w in self.warnings]
        d["legibility"] = self.legibility.as_dict() if self.legibility else None
        d["instrument"] = self.instrument.as_dict() if self.instrument else None
        d["timings_s"] = dict(self.timings_s)
        d["layout"] = self.layout.as_dict() if self.layout else None
        if self.panels is None:  # only a figure's prints say so (other reports keep their keys)
            del d["panels"]
        else:
            d["panels"] = self.panels.as_dict()
        for key in ("print_mm", "relief_mm", "grid"):
            d[key] = list(d[key])
        if not self.content_kind:  # only content prints say it (other recipes keep their keys)
            del d["content_kind"]
        if self.lattice_pitch_mm is None:
            del d["lattice_pitch_mm"]
        if not self.key_depth_mm:  # only prints with a key say it (other reports keep their keys)
            del d["key_depth_mm"]
        if self.check_flags:  # only a print the check doubts says it (other reports keep their keys)
            d["check_flags"] = [str(f) for f in self.check_flags]
        else:
            del d["check_flags"]
        if self.print is None:
            del d["print"]
        else:
            d["print"] = self.print.as_dict()
        return d

    def with_printing(self, printing: Printing) -> "Report":
        """This report for the print once sliced (a new report: a report is never changed)."""
        return dataclasses.replace(self, print=printing)

    # Read-only dict-style access, kept for code and notebooks written against the old dict.
    def __getitem__(self, key: str):
        return self.as_dict()[key]

    def get(self, key: str, default=None):
        return self.as_dict().get(key, default)


MAX_LINE_CHARS = 160  # a result line a screen reader reads in one go; details go to the verbose lines and the report


def summary_line(report: Report, written_names: list[str], shown: str | None = None, *, folder: str | None = None) -> str:
    """One plain line per converted file, as `tamp-os convert` prints it: at most MAX_LINE_CHARS
    characters where the names allow (the mesh, printer, scale and every file name are in
    detail_lines). `shown` names the print instead of the input's name (a figure's "fig.png,
    panel a"); `folder` is where the files went, said when the line has no room for their names."""
    if shown:
        report = dataclasses.replace(report, input=shown)
    w, d, h = report.print_mm
    levels = "a flat plate" if report.uniform else f"up to {report.height_levels} levels"
    size = f"{_mm(w)} × {_mm(d)} × {_mm(h)} mm"  # to 0.1 mm, as the description says it
    full = f"{size}, grid {report.grid[0]} × {report.grid[1]}, {report.triangles:,} triangles, {levels}, relief style {report.relief_style}"
    return fitted_line(report.input, [full, f"{size}, {levels}, relief style {report.relief_style}"], written_names, folder=folder)


def fitted_line(name: str, bodies: list[str], written_names: list[str], *, folder: str | None) -> str:
    """'NAME: BODY; wrote FILES' with the first body (fullest first) that keeps the line within
    MAX_LINE_CHARS; else the shortest body and the files said as a count and their folder ("wrote 7
    files to out_czi/"). A name is never cut: a screen reader then reads a name that is not on the
    disk, and two lines cut differently read as two files."""
    phrase = files_phrase(written_names)
    for body in bodies:
        line = f"{name}: {body}; wrote {phrase}"
        if len(line) <= MAX_LINE_CHARS:
            return line
    return f"{name}: {bodies[-1]}; wrote {count_phrase(written_names, folder)}"


def count_phrase(names: list[str], folder: str | None) -> str:
    """'7 files to out_czi/' (or '7 files' when the folder is not known)."""
    count = f"{len(names)} file{'s' * (len(names) != 1)}"
    if folder is None:
        return count
    return f"{count} to {folder.rstrip(os.sep) + os.sep if folder not in ('', '.') else 'the current folder'}"


def detail_lines(report: Report, written_names: list[str]) -> list[str]:
    """What summary_line leaves out, one short line each (the verbose option of `tamp-os convert`)."""
    mesh = f"{report.mesher} mesh within {report.max_error_mm:g} mm" if report.mesher == "adaptive" else "grid mesh"
    lines = [f"  mesh: {report.triangles:,} triangles, {mesh}, {report.mm_per_px:g} mm per grid point",
             f"  printer: {report.printer}, nozzle {report.nozzle_mm:g} mm, layer {report.layer_mm:g} mm",
             f"  scale: {report.scale}"]
    return lines + [f"  wrote: {name}" for name in written_names]


def files_phrase(names: list[str]) -> str:
    """'ramp.{stl,3mf}, its description and recipe' for the files of one print; the first and last
    of them when they share no name. Names are said whole."""
    extras = [n for n in names if n.endswith((".description.txt", ".tamp.json"))]
    main = [n for n in names if n not in extras]
    stem = os.path.commonprefix(main).rpartition(".")[0] if len(main) > 1 else ""
    if len(main) == 1:
        text = main[0]
    elif stem and all(n.count(".") == stem.count(".") + 1 for n in main):
        text = f"{stem}.{{{','.join(n[len(stem) + 1:] for n in main)}}}"
    elif main:
        text = f"{len(main)} files ({main[0]} … {main[-1]})"
    else:
        text = ""
    said = {".description.txt": "description", ".tamp.json": "recipe"}
    extra = [word for suffix, word in said.items() if any(n.endswith(suffix) for n in extras)]
    if text and extra:
        return f"{text}, its {' and '.join(extra)}"
    return text or " and ".join(extra)


def advice_notes(report: Report) -> list:
    """The verdicts and the tool's decisions that carry advice naming a parameter (errors.Text):
    the description leaves that advice out, so each front end says these in its own words, leaving
    out advice for controls it does not have."""
    from ..errors import is_decision, names_in

    said = [*touch_notes(report), *(w for w in report.warnings if is_decision(w))]
    return [n for n in said if names_in(getattr(n, "template", str(n)))]


def touch_notes(report: Report) -> list[str]:
    """The legibility verdicts: what a finger will find, with advice."""
    return list(report.legibility.verdicts) if report.legibility else []


def removed_notes(report: Report) -> list[str]:
    """Plain sentences for what was cropped or inpainted."""
    crop, notes = report.crop, []
    for side, rows in (("top", crop.top_rows), ("bottom", crop.bottom_rows)):
        if rows:
            notes.append(f"removed the data band: {rows} rows at the {side} ({crop.provenance or None})")
    if report.annotations:
        notes.append("removed burned-in annotations: " + "; ".join(a.describe() for a in report.annotations))
    return notes


ANNOTATION_KINDS = {"box": "a label or scale-bar box", "bar": "a scale bar", "text": "a text label"}


def annotation_words(annotation: Annotation, width_px: int, height_px: int) -> str:
    """An annotation in plain words, by where it sat: 'a label or scale-bar box near the bottom
    left', "a text label 'nucleus' near the top right"."""
    words = "" if annotation.text is None else f" '{annotation.text}'" if annotation.text else " (unreadable)"
    return f"{ANNOTATION_KINDS.get(annotation.kind, annotation.kind)}{words} near the {annotation_place(annotation, width_px, height_px)}"


def annotation_place(annotation: Annotation, width_px: int, height_px: int) -> str:
    """Where an annotation sat in the picture: 'bottom left', 'top', 'centre'."""
    (r0, r1), (c0, c1) = annotation.rows, annotation.cols
    row, col = (r0 + r1 - 1) / 2 / max(height_px, 1), (c0 + c1 - 1) / 2 / max(width_px, 1)
    vertical = "top" if row < 1 / 3 else "bottom" if row > 2 / 3 else "middle"
    horizontal = "left" if col < 1 / 3 else "right" if col > 2 / 3 else "centre"
    return "centre" if (vertical, horizontal) == ("middle", "centre") else f"{vertical} {horizontal}".replace("middle ", "")


def labels_sentence(annotations, width_px: int, height_px: int) -> str | None:
    """"Labels removed: 'cell A' (bottom left), unreadable (top right)." for the removed text
    labels that were read (labels.read_labels), or None when there are none."""
    read = [a for a in annotations if a.kind == "text" and a.text is not None]
    if not read:
        return None
    items = [(f"'{a.text}'" if a.text else "unreadable") + f" ({annotation_place(a, width_px, height_px)})" for a in read]
    return f"Text label{'s' * (len(items) != 1)} removed from the relief: " + ", ".join(items) + "."


def web_summary_lines(report: Report, namer=None, offers=None) -> list[str]:
    """The web app's result lines: size, grid, scale, notes (in its words: `namer`; advice naming a
    control it does not have, by `offers`, left out), what was removed, printing."""
    from ..errors import words

    w, d, top = report.print_mm
    levels = "a flat plate." if report.uniform else f"up to {report.height_levels} height levels (relief ÷ layer)."
    lines = [
        f"Print {_mm(w)} × {_mm(d)} mm, up to {_mm(top)} mm high.",
        f"Grid {report.grid[0]} × {report.grid[1]} points, {report.triangles:,} triangles, {levels}",
        f"Scale: {report.scale}.",
        *[f"Note: {words(x, namer, offers)}" for x in report.warnings],
        *[f"Check: {words(x, namer, offers)}" for x in report.check_flags],
    ]
    removed = [annotation_words(a, *report.source_px) for a in report.annotations]
    if removed:
        lines.append("Removed before printing, so they do not print as raised blocks: " + "; ".join(removed) + ".")
    if report.print:
        lines.append(f"Printing: {report.print.summary}.")
    return lines


_SIGNAL_NAMES = {"SE": "secondary electrons", "BSE": "backscattered electrons", "STEM": "scanning transmission",
                 "BF": "bright field"}


def instrument_words(instrument: Instrument) -> str:
    """'magnification 105×, 25 kV, detector HE-SE2 (secondary electrons), from Zeiss SmartSEM'."""
    words = []
    if instrument.magnification:
        words.append(f"magnification {instrument.magnification:,.0f}×")
    if instrument.kv:
        words.append(f"{instrument.kv:g} kV")
    if instrument.detector:
        signal = _SIGNAL_NAMES.get(instrument.signal or "")
        words.append(f"detector {instrument.detector}" + (f" ({signal})" if signal else ""))
    return ", ".join(words) + (f", from {instrument.source}" if instrument.source else "")


_SIGNAL_WORDS = {
    "SE": ("a secondary-electron (SE) detector", "in SE images brightness shows edges and slopes, not height"),
    "BSE": ("a backscattered-electron (BSE) detector", "in BSE images brightness shows composition (heavier elements are brighter), not height"),
    "STEM": ("a scanning transmission (STEM) detector", "in STEM images brightness shows mass and thickness, not height"),
    "BF": ("a bright-field (BF) detector", "in bright-field images matter is dark (it scatters the beam away), and brightness is not height"),
}


def _instrument_sentence(instrument: Instrument) -> str:
    """'Recorded with a secondary-electron (SE) detector at 5 kV: ... not height.' from Report.instrument."""
    kv = f" at {instrument.kv:g} kV" if instrument.kv else ""
    mag = f", magnification {instrument.magnification:,.0f}×" if instrument.magnification else ""
    signal = _SIGNAL_WORDS.get(instrument.signal or "")
    if signal:
        return f"Recorded with {signal[0]}{kv}{mag}: {signal[1]}."
    detector = f" with the {instrument.detector} detector" if instrument.detector else ""
    return f"Recorded{detector}{kv}{mag}."


def describe(report: Report, params: LithoParams, source_name: str) -> str:
    """A plain-language description of the object for people who cannot see it, written as alt text:
    what the print shows, its layout (what is raised, how many, where), then scale, caption and
    orientation, and the technical figures last. It names no control of any front end
    (errors.file_words): each says its own advice beside it (advice_notes)."""
    from ..errors import file_words

    w, d, h = report.print_mm
    rw, rd = report.relief_mm
    rd -= report.key_depth_mm  # the picture alone: the key below it is described on its own
    t = report.tactile
    parts = [_what_it_shows(report, params, source_name), _what_is_raised(report, params)]
    layout = _layout_sentence(report)
    if layout:
        parts.append(layout)
    labels = labels_sentence(report.annotations, *report.source_px)
    if labels:
        parts.append(labels)
    if report.pixel_size_m:
        parts.append(f"Scale: {report.scale}.")
    if t and t.scale_bar_box_mm:
        parts.append(
            f"Below the picture, at the left, a raised scale bar with end ticks stands for {t.scale_bar_label} "
            f"in the sample; its value is in braille {'to its right' if t.scale_label_beside else 'below it'}."
        )
    if t and t.caption_braille:
        parts.append(f"Along the bottom margin, a braille caption reads: {params.caption}.")
    if t and t.frame_box_mm:
        parts.append(f"A raised frame {params.frame_mm:g} mm wide surrounds the picture.")
    if t and t.orientation:
        parts.append("The top right corner of the plate is cut off: hold the print with that corner at the top right, "
                     "and the top of the image is the far edge.")
    else:
        parts.append("The top edge of the image is the far edge of the print.")
    parts.append(f"The print is {_mm(w)} mm wide, {_mm(d)} mm deep and up to {_mm(h)} mm high, on a {params.base_mm:g} mm base; "
                 f"the picture on it is {_mm(rw)} by {_mm(rd)} mm.")
    if not report.pixel_size_m:
        parts.append("No physical scale is known for the image.")
    if not report.uniform and touch_notes(report):
        parts.append("What a finger will find: " + " ".join(file_words(v) for v in touch_notes(report)))
    if report.instrument:
        parts.append(_instrument_sentence(report.instrument))
    from ..errors import is_decision

    decided = [file_words(w) for w in report.warnings if is_decision(w)]
    if decided:  # the tool's own choices, for the record (the command line says them only when asked to be verbose)
        parts.append("How it was made: " + " ".join(decided))
    return " ".join(parts)


def _mm(value: float) -> str:
    """A length as read aloud: to 0.1 mm (a finger's resolution is 1 mm)."""
    return f"{round(value, 1):g}"


_SEM_SOURCES = ("SEM", "FEI", "THERMO", "TESCAN", "HITACHI", "ZEISS", "JEOL")


def _modality(instrument: Instrument | None) -> str | None:
    """'a scanning electron microscope (SEM) image' and the like, from what the file records."""
    if not instrument:
        return None
    signal = instrument.signal
    if signal == "STEM":
        return "a scanning transmission electron microscope (STEM) image"
    electrons = {"SE": " made with secondary electrons", "BSE": " made with backscattered electrons"}.get(signal or "", "")
    if electrons or any(word in str(instrument.source or "").upper() for word in _SEM_SOURCES):
        return f"a scanning electron microscope (SEM) image{electrons}"
    return None


def _what_it_shows(report: Report, params: LithoParams, source_name: str) -> str:
    """The first sentence: the subject the user gave, and the kind of image when the file says it."""
    subject = (getattr(params, "subject", None) or "").strip().rstrip(".")
    kind = _modality(report.instrument)
    if subject and kind:
        return f"A tactile print of {subject}, from {kind}."
    if subject:
        return f"A tactile print of {subject}."
    if kind:
        return f"A tactile print of {kind} ({source_name})."
    return f"A tactile print of the image {source_name}."


def _layout_sentence(report: Report) -> str | None:
    """Where the raised shapes are (layout_words.py), or None for a flat plate or no layout."""
    if report.uniform or not report.layout:
        return None
    from .layout_words import layout_sentence

    if report.content_kind in ("lines", "grains", "plateau", "lattice"):
        return None  # a network, plateaus or a lattice tiling the picture: the sentence before says what to find
    layout = report.layout
    noun = {"objects": "dome", "levels": "raised area"}.get(report.relief_style, "raised shape")
    if report.content_kind == "members":  # a piece is one dome, or touching members grouped
        if not layout.pieces:  # domes under a fingertip's area each: the check sentences count them (one count)
            return None
        same = report.legibility is not None and report.legibility.object_count == len(layout.pieces)
        if not same:  # touching members grouped: where they stand, without a second count beside the check's
            return layout_sentence(layout, "raised group", counted=True)
        noun = "dome"

    counted = report.relief_style == "objects" and report.legibility is not None and report.legibility.object_count == len(layout.pieces)
    return layout_sentence(layout, noun, counted=counted)


# What the content style raised (relief/content.py), said as tactile graphics describe it.
_CONTENT_RAISED = {
    "members": ("Every member of the population found in the picture (particles, beads, cells or nuclei, dim or "
                "bright alike) stands up as a dome by the same lift, up to {up} above a flat ground; touching "
                "members are parted by a groove."),
    "lattice": ("The picture is a lattice (atomic columns or a grid of dots): every column stands up as a small, "
                "rounded dome of the same height over a flat ground, in a regular grid{pitch}."),
    "lines": ("The picture's lines (boundaries, membranes or drawn strokes, whether dark or bright in the image) "
              "stand up as raised lines about {line_mm} mm high over a flat ground; the areas they enclose stay low."),
    "grains": ("The grains, told apart by their weak contrast, stand up as a few flat plateaus above the mount, "
               "up to {up} above the base; the empty mount stays at the base."),
    "plateau": ("The region that stands out from the empty ground (one object, or the specimen) is raised as one "
                "flat plateau, {up} above the base; the ground stays at the base."),
    "shape": ("The picture's shape at fingertip scale is raised, its contrast evened out locally, up to {up} above "
              "the base; the empty background stays at the base."),
}


def _lattice_pitch_words(report: Report) -> str:
    """', 1.3 mm apart on the print (0.39 nm in the sample)' for a lattice print; without a known
    scale the pitch in the picture's pixels instead."""
    if report.content_kind != "lattice" or not report.lattice_pitch_mm:
        return ""
    mm = report.lattice_pitch_mm
    source_px_per_mm = report.source_px[0] / max(report.relief_mm[0], 1e-9) if report.source_px[0] else None
    if report.pixel_size_m and source_px_per_mm:
        metres = mm * source_px_per_mm * report.pixel_size_m
        if metres < 1e-6:  # atomic lattices: said in nm, as crystallographers do
            return f", {mm:.1f} mm apart on the print ({metres * 1e9:.3g} nm in the sample)"
        from ..units import format_length

        return f", {mm:.1f} mm apart on the print ({format_length(metres)} in the sample)"
    if source_px_per_mm:
        return f", {mm:.1f} mm apart on the print (about {mm * source_px_per_mm:.0f} pixels of the picture; its scale is not known)"
    return f", {mm:.1f} mm apart on the print"


def _what_is_raised(report: Report, params: LithoParams) -> str:
    """One sentence on what stands up from the base, by relief style."""
    raised, lowered = ("dark", "bright") if params.invert else ("bright", "dark")
    up = f"{params.relief_mm:g} mm"
    if report.uniform:
        return "The image is uniform, so the print is a flat plate with no raised parts."
    if report.relief_style == "levels":
        levels = (report.legibility.levels_mm if report.legibility else None) or []
        heights = ", ".join(f"{v:g}" for v in levels)
        return (f"The picture is made of {len(levels)} flat levels, {heights} mm above the base: "
                f"{lowered} parts of the image lowest, {raised} parts highest.")
    if report.relief_style == "objects":
        n = report.legibility.object_count if report.legibility else 0
        from .layout_words import count_words

        return (f"{count_words(n, 'object').capitalize()} found in the picture {'stands' if n == 1 else 'stand'} up as "
                f"rounded domes, up to {up} above the base, over a flat, lightly textured background.")
    if report.relief_style == "channels" and report.key:
        entries = "; ".join(f"{e.encoding}: {e.label}" for e in report.key)
        return (f"Each channel or stain of the picture is its own texture ({entries}), up to {up} above the base. "
                f"Below the picture, along the near margin, a key shows a swatch of each texture with its label in braille.")
    if report.relief_style == "content" and report.content_kind in _CONTENT_RAISED:
        from ..relief.lines import LINE_HEIGHT_MM

        return _CONTENT_RAISED[report.content_kind].format(up=up, line_mm=f"{LINE_HEIGHT_MM:g}", raised=raised,
                                                           pitch=_lattice_pitch_words(report))
    if report.relief_style == "structure":
        return (f"The {raised} parts of the image are raised, up to {up} above the base, simplified to shapes a "
                f"fingertip can follow; finer detail is kept only as a low texture.")
    return f"The {raised} parts of the image are raised, up to {up} above the base."


def plate_report(*, picture, mesh, plan, machine, params: LithoParams, placed: Placed | None, **facts) -> Report:
    """The one place a Report is made: what every plate shares (its size, grid, printer, mesh and
    tactile furniture) from the plate itself, and the rest (`facts`: scale, relief, warnings …) as
    the caller found it. `plan` is the relief's Layout (its width, depth, grid and pitch)."""
    return Report(
        input=picture.file.name,
        print_mm=[round(float(v), 3) for v in mesh.bounds_mm[1]],
        relief_mm=[round(plan.width_mm, 3), round(plan.depth_mm, 3)],
        grid=[plan.cols, plan.rows],
        mm_per_px=round(plan.mm_per_px, 4),
        printer=machine.name,
        nozzle_mm=machine.nozzle_mm,
        layer_mm=machine.layer_mm,
        height_levels=height_levels(params.relief_mm, machine.layer_mm),
        mesher=params.mesher,
        triangles=mesh.n_triangles,
        vertices=len(mesh.vertices),
        tactile=tactile_report(placed),
        source_px=(picture.file.width, picture.file.height),
        **facts,
    )


def tactile_report(placed: Placed | None) -> Plate | None:
    if placed is None:
        return None
    return Plate(
        plate_mm=[round(v, 3) for v in placed.plate_mm],
        relief_origin_mm=[round(v, 3) for v in placed.relief_origin_mm],
        caption_braille=placed.caption_braille,
        caption_box_mm=placed.caption_box,
        scale_bar_box_mm=placed.scale_bar_box,
        scale_bar_label=placed.scale_label,
        scale_bar_label_braille=placed.scale_label_braille,
        scale_label_box_mm=placed.scale_label_box,
        frame_box_mm=placed.frame_box,
        braille_dots=placed.dots,
        scale_label_beside=placed.scale_label_beside,
        orientation="cut corner at the top right" if placed.corner_cut_mm else None,
        scale_bar_m=placed.scale_bar_m,
        scale_bar_mm=placed.scale_bar_mm,
    )
