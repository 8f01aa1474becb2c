"""The panels of a figure in the web app (issue 23.4): found when the image is added (in the decode
worker, with a thumbnail each), chosen per image by checkboxes on the settings page, and each
panel's print listed on its own on the results page and in the zip's README.txt.

The choice is that upload's own `panel` parameter (like its caption: never another image's). It
applies only when "Panels of a figure" is auto, the setting under which the panels shown were
found: with off the figure is printed whole, and with a grid the grid's cells are the panels, so
"Panels to print" chooses among those instead.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

log = logging.getLogger(__name__)

PANEL_THUMB_PX = 120  # one small picture per panel beside its checkbox


@dataclass(frozen=True)
class PanelFound:
    """One panel of an uploaded figure, as the settings page shows it."""

    label: str  # "b", or "2" when no letter was read
    where: str  # "top right", from figure.position_words
    box_px: tuple[int, int, int, int]  # x, y, w, h in the figure's pixels
    thumb: str  # file name in the job's thumbs folder
    content: str = ""  # what it shows, as the overview says it ("particles (about 40)"); "" when not known

    @property
    def title(self) -> str:
        """'Panel b (top right)': the checkbox's label and the results' heading."""
        return f"Panel {self.label} ({self.where})"

    @property
    def printable(self) -> bool:
        """Large enough to print on its own plate (figure.MIN_PANEL_PX); a smaller one shows only on the overview."""
        from ..lithograph.figure import MIN_PANEL_PX

        return min(self.box_px[2], self.box_px[3]) >= MIN_PANEL_PX


def find_panels(values: np.ndarray, thumbs: Path, index: int, *, colour=None) -> tuple[PanelFound, ...]:
    """The panels of a figure (none for a single picture), each with its thumbnail written to
    `thumbs` and what it shows in words (as the overview says it). The same detection make_figure
    runs with `panels` auto, so the labels shown are the labels the conversion knows. `colour`: a
    function giving the figure's colour pixels (figure.figure_colour), asked only for a figure.
    Runs in the decode worker: OCR of the letters takes a second or two."""
    from ..clean.panels import detect_panels
    from ..lithograph.figure import panel_contents, position_words
    from ..export.files import write_png
    from .thumbnail import thumbnail

    layout = detect_panels(values)
    if not layout.split:
        return ()
    where = position_words(layout)
    try:
        contents = {k: w.words for k, w in panel_contents(values, layout, colour() if colour else None).items()}
    except Exception:  # the words are a help, not the choice: the panels are offered without them
        log.warning("the panels' content words failed", exc_info=True)
        contents = {}
    found = []
    for panel in layout.panels:
        name = f"{index}.panel-{panel.label}.png"
        x, y, w, h = panel.box_px
        write_png(thumbs / name, thumbnail(values[y:y + h, x:x + w], PANEL_THUMB_PX))
        found.append(PanelFound(panel.label, where[panel.label], tuple(int(v) for v in panel.box_px), name,
                                contents.get(panel.label, "")))
    return tuple(found)


def checkbox_id(index: int, label: str) -> str:
    return f"panel_{index}_{label}"


def chosen_panels(form, index: int, found: tuple[PanelFound, ...]) -> tuple[str, ...] | None:
    """The panels ticked for upload `index`, in the figure's order; None when the form did not
    show this upload's checkboxes (a form without them means every panel, as before)."""
    if not found or form.get(f"panels_shown_{index}") != "1":
        return None
    ticked = set(form.getlist(f"panel_{index}"))
    return tuple(p.label for p in found if p.label in ticked)


def panel_parameter(found: tuple[PanelFound, ...], chosen: tuple[str, ...] | None) -> str | None:
    """The `panel` parameter of an upload: None for every panel (all ticked, or no choice made),
    else the ticked labels ('a,c'). An empty choice is refused before this (choice_errors)."""
    if not found or chosen is None or set(chosen) >= {p.label for p in found}:
        return None
    return ",".join(chosen)


def choice_errors(uploads, panels_mode: str) -> dict[str, str]:
    """An error per figure with no panel ticked, keyed by its first checkbox's id (the error
    summary links to it). Only with auto: otherwise the checkboxes do not apply."""
    if panels_mode != "auto":
        return {}
    return {checkbox_id(i, u.panels[0].label): f"Panels found in {u.name}: tick at least one panel to print, "
            "or set “Panels of a figure” to off to print the figure whole."
            for i, u in enumerate(uploads) if u.panels and u.panel_choice == ()}


def global_panel_error(panels_mode: str, panel: str | None) -> dict[str, str]:
    """'Panels to print' chooses among a grid's cells; with auto each figure's own checkboxes
    choose, and with off there is nothing to choose, so a value there would contradict them."""
    if panel and panels_mode in ("auto", "off"):
        return {"panel": "Panels to print: this applies only with a grid in “Panels of a figure”, such as 2x2. "
                "With auto, tick each figure's panels under Your images; leave this empty."}
    return {}


@dataclass(frozen=True)
class PrintShown:
    """One print of a converted figure on the results page: the overview, or a panel."""

    title: str  # "Overview of the layout", "Panel b (top right)"
    key: str  # "overview", "panel-b": ids on the page
    description: str
    files: tuple  # OutputFile, in the order written
    where: str = ""  # a panel's place in the figure ("top right")


def figure_prints(made, found: tuple[PanelFound, ...], output_file) -> list[PrintShown]:
    """The prints of a converted figure for the results page, the overview first, then each
    panel printed in reading order; [] for a single picture."""
    if not made.panels:
        return []
    where = {p.label: p.where for p in found}
    shown = [PrintShown("Overview of the layout", "overview", made.litho.metadata()["description"],
                        tuple(output_file(p) for p in made.written))]
    for each in made.panels:
        label = each.suffix[len(".panel-"):]
        title = f"Panel {label} ({where[label]})" if label in where else f"Panel {label}"
        shown.append(PrintShown(title, f"panel-{label}", each.litho.metadata()["description"],
                                tuple(output_file(p) for p in each.written), where.get(label, "")))
    return shown


def readme_note(name: str, where: dict[str, str], names=()) -> str:
    """What a figure's file is besides its format, for README.txt: '' for a single picture's.
    `names`: every file of the zip (a figure's own recipe is told by its overview beside it)."""
    import re

    if name.endswith(".tamp.json") and f"{name[:-len('.tamp.json')]}.overview.tamp.json" in names:
        return " (the whole figure's recipe: it lists every file of the figure and rebuilds its panels and overview)"
    if ".overview." in name:
        return " (the figure's overview: how its panels sit, each a raised frame with its label in braille)"
    panel = re.search(r"^(.*)\.panel-([A-Za-z0-9]+)\.", name)
    if panel:
        at = where.get(f"{panel.group(1)}.panel-{panel.group(2)}")
        return f" (panel {panel.group(2)} of the figure{', ' + at if at else ''}, on its own plate)"
    return ""
