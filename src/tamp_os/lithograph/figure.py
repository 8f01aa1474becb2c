"""make_figure(): a picture that may be a multi-panel figure -> its lithographs.

A single picture gives one lithograph, as make_lithograph. A figure of several panels gives one
lithograph per panel (each through the whole pipeline: its own data band, scale bar, annotations
and scale, its letter in braille at the start of its caption and in its description), named
NAME.panel-<letter>, and an overview of the layout, NAME.overview. The front ends call this one
function through convert.convert, which saves each print; nothing here writes files except
Figure.finish (the figure's own recipe and pages).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..clean.panels import Panel, PanelLayout, detect_panels, forced_grid, given_layout, parse_grid
from ..errors import ParameterError, Text
from ..params import LithoParams
from .pipeline import Lithograph, make_lithograph, read_source
from .sizing import layout_for, resolve_printer
from ..printing.printers import PrinterProfile
from ..read.model import Picture
from .report import PanelFacts, Report, describe, plate_report

if TYPE_CHECKING:  # a figure's panels only
    from .content_word import ContentWord

log = logging.getLogger(__name__)

# A panel with fewer source pixels than this on its shorter side is not printed on its own: at a
# plate's width (about 100 mm) each of its pixels would be over 2 mm, coarser than a fingertip
# resolves, so the print would show the pixels, not the picture.
MIN_PANEL_PX = 48
NUMBER_WORDS = ["no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten", "eleven", "twelve"]


@dataclass
class Figure:
    """What a picture prints as.

    layout : the panels found (layout.split False: one picture).
    prints : (name suffix, lithograph) in order: ("", whole) for one picture, else
        (".panel-a", …) for each panel printed and (".overview", overview) last. convert.convert
        saves each (and slices it when asked), then calls `finish`.
    notes : sentences on the layout (what was not printed, letters not read, why not split).
    """

    layout: PanelLayout
    prints: list[tuple[str, Lithograph]]
    notes: list[str] = field(default_factory=list)
    params: LithoParams = field(default_factory=LithoParams)  # as given (the figure's recipe records them)

    @property
    def split(self) -> bool:
        return len(self.prints) > 1 or (bool(self.prints) and self.prints[0][0] != "")

    @property
    def lithographs(self) -> list[Lithograph]:
        return [litho for _, litho in self.prints]

    def finish(self, folder: Path, stem: str, written: list[Path], *, formats=None) -> list[Path]:
        """After each print is saved: for a figure, NAME.pages.pdf (when PDF is asked for) and the
        figure's recipe NAME.tamp.json, listing every file and the parameters as given (so that a
        batch rerun sees the figure done, and a rebuild from this recipe remakes it all)."""
        if not self.split:
            return []
        extra = []
        if "pdf" in (formats or self.params.formats):
            extra.append(self.save_pages_pdf(folder, stem))
        return extra + [self._save_recipe(folder, stem, [p.name for p in written + extra])]

    def _save_recipe(self, folder: Path, stem: str, files: list[str]) -> Path:
        from .outputs import RECIPE_SUFFIX, write_recipe

        panels = {"boxes": self.layout.record(), "reason": self.layout.reason, "notes": [str(n) for n in self.notes]}
        return write_recipe(self.prints[-1][1], folder / f"{stem}{RECIPE_SUFFIX}", files,
                            changes={"params": self.params.to_dict(), "panels": panels, "relief": None})

    def save_pages_pdf(self, folder: Path, stem: str) -> Path:
        """NAME.pages.pdf: the overview's page first, then each panel's, for swell paper or an embosser."""
        from ..export.tactile2d import write_pdf_pages
        from ..export.files import write_atomic
        from .outputs import tactile_graphic

        order = [litho for suffix, litho in self.prints if suffix == ".overview"] + [litho for suffix, litho in self.prints if suffix != ".overview"]
        graphics = [tactile_graphic(litho) for litho in order]
        params = order[0].params
        title = f"Tactile graphics of the figure {order[0].picture.file.name}: overview, then panels {', '.join(s[7:] for s, _ in self.prints[:-1])}"
        return write_atomic(folder / f"{stem}.pages.pdf", lambda fh: write_pdf_pages(graphics, fh, params.page_size, title=title))


def make_figure(source, params: LithoParams | None = None, *, printer_profile: PrinterProfile | None = None, **changes) -> Figure:
    """The lithographs of a picture: itself, or each of its panels plus an overview.

    `params.panels` auto finds the panels (a single micrograph is never split), off prints the
    picture whole, RxC cuts an equal grid; `params.panel_boxes` (as recorded in a recipe) gives
    the boxes; `params.panel` ('b,c') prints only those panels.
    """
    params = params or LithoParams()
    if changes:
        params = params.replace(**changes)
    if params.panels == "off" and not params.panel_boxes:
        return Figure(PanelLayout(False, reason="panels is off"), [("", make_lithograph(source, params, printer_profile=printer_profile))], [], params)
    picture = read_source(source, params, keep_colour=True)
    pixels = None  # an RGB file's colour pixels from this one read, for its panels (figure_colour)
    if isinstance(source, (str, Path)) and picture.colour is not None:
        pixels, picture = picture.colour, dataclasses.replace(picture, colour=None)
    layout = _layout(picture, params)
    if not layout.split:
        given = _printed_from(source, picture)
        del picture, pixels  # not held while a picture with channels is read again: its memory peak stays as alone
        # A single picture (nothing suggests a figure) gets no figure talk on the terminal: its report
        # keeps the reason (report.panels.reason); only an ambiguous layout is warned about.
        return _whole(given, params, printer_profile, layout, [layout.reason] if layout.ambiguous else [])
    notes = list(layout.notes)
    chosen = _chosen(layout, params)
    printable = []
    for panel in chosen:
        if min(panel.w, panel.h) < MIN_PANEL_PX:
            notes.append(Text(f"panel {panel.label} ({panel.w}×{panel.h} pixels) is not printed on its own: below {MIN_PANEL_PX} pixels on a side, "
                         f"each of its pixels would be over 2 mm on a plate, too coarse to feel as a picture. Print the figure "
                         f"whole (`panels` off), or use a larger original of the figure."))
        else:
            printable.append(panel)
    if not printable:
        notes.append("no panel of the figure is large enough to print on its own, so the figure is printed whole")
        given = _printed_from(source, picture)
        del picture, pixels
        return _whole(given, params, printer_profile, layout, notes)
    record = params.replace(panel_boxes=layout.record())
    # A colour figure's panels carry their own colour pixels, so that each takes the channel path
    # (a fluorescence composite, a stained slide) as it would saved as a file of its own.
    colour = figure_colour(source, picture, params, pixels=pixels)
    del pixels
    # What each panel shows, for every panel of the layout (not only those printed now), so the
    # overview is the same file whichever panel's recipe rebuilds it.
    contents = panel_contents(picture.values, layout, colour, params=params, printer_profile=printer_profile)
    prints = [(f".panel-{p.label}", _panel_print(picture, p, layout, params, record, printer_profile, colour, contents[p.label]))
              for p in printable]
    # The overview names every panel large enough to print, whichever `panel` chose, so that it is
    # the same file whichever panel's recipe rebuilds it.
    big = [p.label for p in layout.panels if min(p.w, p.h) >= MIN_PANEL_PX]
    overview = _overview(picture, layout, params, record.replace(panel=None), printer_profile, notes, big, contents)
    for note in notes:
        log.warning(note)
    return Figure(layout, prints + [(".overview", overview)], notes, params)


def _layout(picture: Picture, params: LithoParams) -> PanelLayout:
    if params.panel_boxes:
        return given_layout(picture.values, params.panel_boxes)
    if params.panels not in ("auto", "off"):
        _check_grid(params.panels, picture.values.shape)
        return forced_grid(picture.values, params.panels)
    return detect_panels(picture.values)


def _check_grid(grid: str, shape: tuple[int, int]) -> None:
    """Refuse, before any cutting, a grid whose cells are under MIN_PANEL_PX on a side: none of
    its panels would be printed on its own (each of their pixels over 2 mm on a plate)."""
    rows, cols = parse_grid(grid)
    height, width = shape
    if width // cols >= MIN_PANEL_PX and height // rows >= MIN_PANEL_PX:
        return
    most = f"{max(1, min(height // MIN_PANEL_PX, 99))}x{max(1, min(width // MIN_PANEL_PX, 99))}"
    raise ParameterError(f"`panels`: each panel of the grid is at least {MIN_PANEL_PX} pixels on a side, so this "
                         f"{width}×{height} figure takes at most {most}; got {grid.strip()} ({width // cols}×{height // rows} pixels each).",
                         parameter="panels", value=grid, allowed=f"RxC up to {most} for this figure",
                         hint="Give the grid the figure has, or print the figure whole with `panels` off.")


def _chosen(layout: PanelLayout, params: LithoParams) -> list[Panel]:
    if not params.panel:
        return list(layout.panels)
    labels = layout.labels()
    # A number that is not a label counts panels in reading order (panel 2 = the second panel).
    wanted = [w.strip() for w in params.panel.split(",") if w.strip()]
    wanted = [labels[int(w) - 1] if w not in labels and w.isdigit() and 1 <= int(w) <= len(labels) else w for w in wanted]
    unknown = [w for w in wanted if w not in labels]
    if unknown:
        raise ParameterError(f"`panel`: the figure has panels {', '.join(labels)}; there is no panel {', '.join(unknown)}.",
                             parameter="panel", value=params.panel, allowed=", ".join(labels),
                             hint=f"Give some of {', '.join(labels)}, separated by commas (for example {labels[0]}), or their numbers in reading order.")
    return [p for p in layout.panels if p.label in wanted]


def _printed_from(source, picture: Picture):
    """What a picture printed whole is made from: its source when it has several channels or
    colours, as make_lithograph is given it alone (the channel path reads its channels there; a
    read Picture keeps only its brightness, so a fluorescence composite or a CZI's channels would
    print as one grey), else the picture already read."""
    return source if _has_channels(picture) and isinstance(source, (str, Path, np.ndarray)) else picture


def _whole(given, params, printer_profile, layout: PanelLayout, notes: list[str]) -> Figure:
    litho = make_lithograph(given, params, printer_profile=printer_profile)
    new = [note for note in notes if note not in litho.report.warnings]
    for note in new:
        log.warning(note)
    report = dataclasses.replace(litho.report, panels=PanelFacts(split=False, reason=layout.reason),
                                 warnings=litho.report.warnings + tuple(new))
    return Figure(layout, [("", dataclasses.replace(litho, report=report))], notes, params)


def _has_channels(picture: Picture) -> bool:
    """Several channels in the file, or colour with some chroma: the channel path may take it."""
    sample = picture.file.colour_sample
    return picture.file.channel_count > 1 and (sample is None or _has_chroma(sample))


def _has_chroma(sample: np.ndarray) -> bool:
    """Whether any pixel of a colour sample is coloured (not grey stored as RGB)."""
    from ..relief.channel_auto import CHROMA

    # max - min of the three channels, channel by channel: the same numbers as np.ptp(axis=2),
    # which reduces over the 3-element axis one pixel at a time (14 ms on a 512 px sample, here 1 ms)
    channels = [sample[..., k] for k in range(sample.shape[2])]
    return bool((functools.reduce(np.maximum, channels) - functools.reduce(np.minimum, channels) >= CHROMA).any())


def crop_picture(picture: Picture, box: tuple[int, int, int, int], colour: np.ndarray | None = None) -> Picture:
    """One panel of a figure as a Picture of its own. The file's vendor metadata is dropped: it
    describes the figure's file, not the panel (a panel's scale comes from its own scale bar, or
    pixel_size); the file's name and hash stay, so the recipe names the figure.

    `colour` (the figure's colour pixels, figure_colour) gives the panel its own: its colour
    sample, which the channel path decides by, and the pixels it splits, as a file of the panel
    would have them. Without it the panel is grey (its brightness only)."""
    from ..read.model import colour_sample

    x, y, w, h = box
    alpha = None if picture.alpha is None else picture.alpha[y:y + h, x:x + w]
    own = None if colour is None else np.ascontiguousarray(colour[y:y + h, x:x + w])
    file = dataclasses.replace(picture.file, width=w, height=h, metadata={}, tiff_tags={}, notes=list(picture.file.notes),
                               colour_sample=None if own is None else colour_sample(own))
    return Picture(np.ascontiguousarray(picture.values[y:y + h, x:x + w]), alpha, file, own)


def figure_colour(source, picture: Picture, params: LithoParams, *, pixels: np.ndarray | None = None) -> np.ndarray | None:
    """The figure's colour pixels (H, W, 3) at the file's own precision, for its panels; None for a
    grey figure (also one stored in colour: no pixel of its colour sample has chroma), for a file of
    several channels rather than colours, or for a Picture given without them. `pixels`: the colour
    pixels kept from the figure's own read (read_image's keep_colour), the same the channel path
    would read; without them (a vendor file) the file is read again as the channel path reads one
    (red, green and blue planes: four reads of the file)."""
    sample = picture.file.colour_sample
    if isinstance(source, Picture):
        return source.colour
    if sample is None or not _has_chroma(sample):
        return None
    if pixels is not None and pixels.shape[:2] == picture.values.shape:
        if picture.file.channel_count > 1 and "C" in picture.file.axes:
            return None  # channels, not colours: the channel path names them, not red, green and blue
        dtype = np.dtype(picture.file.dtype)
        return pixels if dtype.kind in "ui" else pixels.astype(np.float32)  # as read_channels gives float planes
    from ..relief.channel_stage import raw_channels

    raw = raw_channels(source, params)
    if [r[0] for r in raw[:3]] != ["red", "green", "blue"]:
        return None
    rgb = np.stack([r[1] for r in raw[:3]], axis=-1)
    if rgb.shape[:2] != picture.values.shape:
        return None
    dtype = np.dtype(picture.file.dtype)
    return rgb.astype(dtype) if dtype.kind in "ui" else rgb  # integer samples come back exactly


def panel_contents(values: np.ndarray, layout: PanelLayout, colour: np.ndarray | None, *, params: LithoParams | None = None,
                   printer_profile: PrinterProfile | None = None) -> dict[str, ContentWord]:
    """What each panel of the layout shows (relief/content_word.py), by label, in reading order:
    `values` the figure's brightness, `colour` its colour pixels (figure_colour) or None; `params`
    and `printer_profile` the figure's (each panel's word is decided on the grid its print uses).
    Only the pixels and the parameters decide, never which panels a run prints."""
    from .content_word import content_word

    out = {}
    params = params or LithoParams()
    for p in layout.panels:
        own = None if colour is None else colour[p.y:p.y + p.h, p.x:p.x + p.w]
        out[p.label] = content_word(values[p.y:p.y + p.h, p.x:p.x + p.w], own, params=params, printer=printer_profile)
    return out


def position_words(layout: PanelLayout) -> dict[str, str]:
    """'top left', 'bottom right', 'middle', … for each panel label, from the layout's rows."""
    out = {}
    n_rows = len(layout.rows)
    for r, row in enumerate(layout.rows):
        vertical = "" if n_rows == 1 else ("top" if r == 0 else "bottom" if r == n_rows - 1 else "middle")
        for c, i in enumerate(row):
            horizontal = "" if len(row) == 1 else ("left" if c == 0 else "right" if c == len(row) - 1 else "centre")
            out[layout.panels[i].label] = " ".join(w for w in (vertical, horizontal) if w) or "alone"
    return out


def _number(n: int) -> str:
    return NUMBER_WORDS[n] if n < len(NUMBER_WORDS) else str(n)


def _panel_print(picture, panel: Panel, layout: PanelLayout, params: LithoParams, record: LithoParams, printer_profile,
                 colour: np.ndarray | None = None, content: ContentWord | None = None) -> Lithograph:
    caption = f"{panel.label} {params.caption}" if params.caption else panel.label
    panel_params = params.replace(panels="off", panel=None, panel_boxes=None, caption=caption)
    litho = make_lithograph(crop_picture(picture, panel.box_px, colour), panel_params, printer_profile=printer_profile)
    where = position_words(layout)[panel.label]
    letter = "letter" if panel.label.isalpha() else "number"
    said = "" if panel.letter_read or not panel.label.isalpha() else " (inferred from the order of the others)"
    if not panel.label.isalpha():
        said = " (no letter was read on the figure, so panels are numbered in reading order)"
    lead = (f"Panel {panel.label} of {_number(len(layout.panels))} in the figure {picture.file.name}, {where} "
            f"(x {panel.x}–{panel.x + panel.w - 1}, y {panel.y}–{panel.y + panel.h - 1} of the figure's pixels); "
            f"its {letter}{said} is the first braille word of the caption.")
    report = dataclasses.replace(litho.report, panels=PanelFacts(
        split=True, panel=panel.label, box_px=tuple(panel.box_px), found_by=panel.found_by, letter_read=panel.letter_read,
        panels=tuple(layout.labels()), contents={panel.label: content} if content else {}))
    return dataclasses.replace(litho, report=report, recipe_params=record.replace(panel=panel.label),
                               description=lead + " " + describe(litho.report, litho.params, picture.file.name))


def _overview(picture, layout: PanelLayout, params: LithoParams, record: LithoParams, printer_profile, notes: list[str],
              printed: list[str], contents: dict[str, ContentWord] | None = None) -> Lithograph:
    """The overview lithograph: the layout at plate size (tactile/overview.py)."""
    from .pipeline import furniture_for
    from ..tactile.overview import OverviewPanel, build_overview

    machine = resolve_printer(params, printer_profile)
    h, w = picture.values.shape
    plan = layout_for(params, machine, w, image_h_px=h)
    caption = f"overview {params.caption}" if params.caption else "overview"
    over_params = params.replace(caption=caption, panels="off", panel=None, panel_boxes=None)
    furniture = dataclasses.replace(furniture_for(over_params.replace(scale_bar="off"), None))
    panels = [OverviewPanel(p.box_px, p.label, picture.values[p.y:p.y + p.h, p.x:p.x + p.w]) for p in layout.panels]
    max_error = params.max_error_mm if params.max_error_mm is not None else machine.layer_mm / 2
    built = build_overview((w, h), panels, plan.cols, rows=plan.rows, width_mm=plan.width_mm, depth_mm=plan.depth_mm, base_mm=params.base_mm, furniture=furniture,
                           mesher=params.mesher, max_error_mm=max_error)
    notes += built.notes
    contents = contents or {}
    description = overview_description(picture.file.name, layout, printed, notes=built.notes, contents={k: c.words for k, c in contents.items()})
    facts = PanelFacts(split=True, reason=layout.reason, panels=tuple(layout.labels()), overview=True,
                       boxes_px=tuple(tuple(b) for b in layout.boxes()), printed=tuple(printed), letters_braille=dict(built.letters_braille),
                       contents=dict(contents))
    report = _overview_report(picture, plan, machine, params, built, description, facts)
    litho = Lithograph(mesh=built.mesh, heightmap=built.heights_mm, params=over_params, printer=machine, layout=plan, picture=picture,
                       report=report, furniture=furniture, description=description, recipe_params=record)
    return litho


def overview_description(name: str, layout: PanelLayout, printed: list[str], *, notes: list[str], contents: dict[str, str] | None = None) -> str:
    """The overview in words: 'Four panels in two rows: a, top left, particles (about 12); b, top right, …'
    (`contents`: each label's words, relief/content_word.py)."""
    where = position_words(layout)
    contents = contents or {}
    n, rows = len(layout.panels), len(layout.rows)
    parts = [f"Overview of the figure {name}. {_number(n).capitalize()} panels in {_number(rows)} row{'s' if rows != 1 else ''}: "
             + "; ".join(", ".join([p.label, where[p.label]] + ([contents[p.label]] if p.label in contents else [])) for p in layout.panels) + "."]
    parts.append("Each panel is a raised frame with its label in braille inside its top-left corner and a low, "
                 "blurred relief of its content; the caption along the bottom reads overview.")
    if printed:
        # "can be": the overview is the same file whichever panels a run prints (see make_figure).
        parts.append(f"Panel{'s' if len(printed) > 1 else ''} {', '.join(printed)} {'can each' if len(printed) > 1 else 'can'} be printed "
                     f"on {'a plate of its own' if len(printed) > 1 else 'its own plate'}, at full size, named after the label.")
    inferred = [p.label for p in layout.panels if p.label.isalpha() and not p.letter_read]
    if inferred:
        parts.append(f"The letter{'s' if len(inferred) > 1 else ''} {', '.join(inferred)} did not read on the figure and "
                     f"{'were' if len(inferred) > 1 else 'was'} inferred from the order of the others.")
    if not any(p.label.isalpha() for p in layout.panels):
        parts.append("No panel letters were read on the figure, so the panels are numbered in reading order.")
    from ..errors import file_words

    parts += [f"Note: {file_words(n_)}." for n_ in notes]  # from the overview itself (a panel too small for its frame)
    return " ".join(parts)


def _overview_report(picture, plan, machine, params, built, description, facts: PanelFacts) -> Report:
    from ..clean.band import Band

    return plate_report(
        picture=picture, mesh=built.mesh, plan=plan, machine=machine, params=params, placed=built.placed,
        blur_px=0.0,
        max_error_mm=0.0,
        uniform=False,
        pixel_size_m=None,
        pixel_size_source=None,
        scale="no physical scale: the overview shows the layout, not the sample",
        crop=Band(),
        annotations=(),
        warnings=tuple(built.notes),
        timings_s={},
        relief_style="overview",
        relief_reason=description,
        panels=facts,
    )
