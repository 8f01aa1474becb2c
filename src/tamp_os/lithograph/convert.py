"""Converting one image into a relief: make the lithograph, save its files, slice it when `gcode`
asks, and say what happened. Front ends ask lithograph/products.py `convert`, which calls this for
the relief product (a picture or a figure); sweep calls it for each variant.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .outputs import save_outputs
from ..params import LithoParams
from .pipeline import Lithograph, stage_begins
from ..printing.printers import PrinterProfile
from .report import Report, removed_notes, summary_line, touch_notes


@dataclass(frozen=True)
class Print:
    """One print and the files written for it, recipe last. `suffix` is "" for a picture, or
    ".panel-a" … and ".overview" for the prints of a multi-panel figure. Its report includes the
    slicing result when sliced."""

    litho: Lithograph
    written: tuple[Path, ...]
    suffix: str = ""

    @property
    def report(self) -> Report:
        return self.litho.report

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.written]

    @property
    def label(self) -> str:
        """'' for a picture; 'panel a' or 'overview' for a print of a figure."""
        return self.suffix.lstrip(".").replace("panel-", "panel ")

    def summary(self) -> str:
        """The one-line summary `tamp-os convert` prints (a figure's print names its panel)."""
        return summary_line(self.report, self.names, f"{self.report.input}, {self.label}" if self.label else None,
                            folder=str(self.written[0].parent) if self.written else None)

    def notes(self) -> list[str]:
        """What was removed from the picture (data band, annotations), in sentences."""
        return removed_notes(self.report)

    def touch(self) -> list[str]:
        """What a finger will find (the legibility verdicts)."""
        return touch_notes(self.report)

    @property
    def printing(self) -> str:
        """The slicing result in one sentence, or '' when not sliced."""
        return self.report.print.summary if self.report.print else ""


@dataclass(frozen=True)
class Conversion(Print):
    """One converted image. For a single picture it is that print (`litho`, `written`); a
    multi-panel figure also has its `panels` (each a Print, in reading order) before it, this print
    being the overview, and the figure's own files (`figure_files`: NAME.pages.pdf with PDF, and the
    figure's recipe) and `layout_notes` (what was not printed, letters not read)."""

    panels: tuple[Print, ...] = ()
    figure_files: tuple[Path, ...] = ()
    layout_notes: tuple[str, ...] = ()

    @property
    def prints(self) -> tuple[Print, ...]:
        """Every print, the figure's panels first: a front end says each in turn."""
        return (*self.panels, self)

    @property
    def all_written(self) -> tuple[Path, ...]:
        """Every file written for this image, the figure's own last."""
        return tuple(p for each in self.prints for p in each.written) + self.figure_files


def convert(source, params: LithoParams | None, out_dir, *, stem: str | None = None,
            printer_profile: PrinterProfile | None = None, formats=None) -> Conversion:
    """Convert one image into `out_dir`, as every front end does: make, save, slice when asked.

    Parameters
    ----------
    source : str, pathlib.Path, numpy.ndarray or Picture
        An image file, a (rows, cols) array, or a Picture already read.
    params : LithoParams or None
        Every setting (None: the defaults). A multi-panel figure (`params.panels`) gives a print
        per panel plus an overview.
    out_dir : str or pathlib.Path
        The folder the files are written to (created when missing).
    stem : str, optional
        Names the files (default: after the input).
    printer_profile : PrinterProfile, optional
        Replaces the printer that `params.printer` names (a recipe brings its own).
    formats : sequence of str, optional
        Replaces `params.formats` ("stl", "3mf", "pdf" ...).

    Returns
    -------
    Conversion
        The print (`litho`, `written` with the recipe last, `summary()` the line the CLI prints),
        and for a figure its `panels` and `figure_files`.

    Examples
    --------
    >>> import numpy as np, tempfile
    >>> from tamp_os import LithoParams
    >>> ramp = np.tile(np.linspace(0, 1, 80), (60, 1))
    >>> done = convert(ramp, LithoParams(width_mm=40, preset="low"), tempfile.mkdtemp(), stem="ramp")
    >>> done.names
    ['ramp.stl', 'ramp.description.txt', 'ramp.tamp.json']
    """
    from ..read.image import decoded_once
    from .figure import make_figure

    if params is not None and params.volume:  # lithograph/volume.py makes those; a relief here would ignore it silently
        from ..errors import ParameterError

        raise ParameterError("`volume`: this makes reliefs; a z-stack's 3-D model is made by lithograph.products.convert, the "
                             "entry point every front end uses (sweep does not make models yet). Leave `volume` out for a relief.",
                             parameter="volume", value=True)
    if params is not None and params.sections:  # lithograph/sections.py makes the series, one convert per slice
        from ..errors import ParameterError

        raise ParameterError("`sections`: this makes one relief; a series of sections is made by lithograph.products.convert, "
                             "the entry point every front end uses (sweep does not make series yet). Leave `sections` out for one relief.",
                             parameter="sections", value=params.sections)
    with decoded_once():  # the file's pixels decoded once for the figure, the print and its colour channels
        figure = make_figure(source, params or LithoParams(), printer_profile=printer_profile)
    out = Path(out_dir)
    base = stem or figure.prints[0][1].name
    prints = []
    stage_begins("save")  # the last moment a front end may cancel: past it, every file is finished
    for suffix, litho in figure.prints:
        written, litho = save_outputs(litho, out, formats, stem=f"{base}{suffix}")
        prints.append(Print(litho, tuple(written), suffix))
    figure_files = figure.finish(out, base, [p for each in prints for p in each.written], formats=formats)
    last = prints[-1]
    warned = {w for each in prints for w in each.report.warnings}
    notes = tuple(n for n in figure.notes if n not in warned)  # a note a print already warns of is said once
    return Conversion(last.litho, last.written, last.suffix, tuple(prints[:-1]), tuple(figure_files), notes)
