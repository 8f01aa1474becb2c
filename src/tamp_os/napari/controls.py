"""The dock widget's controls in its own words: each control's label and help, the choices it
offers, and messages with each parameter they name said as the control that sets it (errors.Text).
No Qt here: the words are tested without a viewer."""

from __future__ import annotations

from ..errors import TampError, words
from ..params import LithoParams

# Each control: its label (what a screen reader says) and its help (the tooltip).
CONTROLS = {
    "layers": ("Layers", "The image or labels layers to print: one picture, or the channels of one picture (one layer each)."),
    "printer": ("Printer", "The printer profile: its nozzle, layer height and bed size set the level of detail."),
    "preset": ("Level of detail", "Low, medium or high: grid points per nozzle width."),
    "caption": ("Braille caption", "Printed in braille along the bottom margin; leave empty for none."),
    "relief_style": ("Relief style", "How the picture becomes heights (auto says why it chose)."),
    "formats": ("Files", "The files to write: STL for any slicer, 3MF with units and the description inside."),
    "output": ("Output folder", "The folder the print's files are written to."),
    "make": ("Make print", "Make the print off the viewer's thread; the relief and the mesh come back as layers."),
    "cancel": ("Cancel", "Stop the print at its next step; nothing is written before the files are made."),
    "progress": ("Progress", "The step the print is at."),
    "message": ("Message", "What went wrong, or what was made."),
    "description": ("Description", "The print described in words, as its description file says it."),
}
# Parameters the widget sets, and the control each is set with; the pixel size is the layer's scale.
PARAMETER_CONTROLS = {"printer": "printer", "preset": "preset", "caption": "caption", "relief_style": "relief_style",
                      "formats": "formats"}
STYLE_WORDS = {
    "auto": "Choose for me (recommended)",
    "content": "What the picture shows",
    "structure": "Shapes to feel",
    "objects": "Raised objects",
    "levels": "A few flat levels",
    "reference": "Brightness as height",
}
FORMAT_CHOICES = (("STL", ("stl",)), ("STL and 3MF", ("stl", "3mf")), ("3MF", ("3mf",)))


def label(control: str) -> str:
    return CONTROLS[control][0]


def namer(parameter: str) -> str | None:
    """A parameter as this widget says it: the control that sets it ("“Relief style”"), the layer's
    scale for the pixel size, or None (kept as the library says it) for one it does not set."""
    if parameter in PARAMETER_CONTROLS:
        return f"“{label(PARAMETER_CONTROLS[parameter])}”"
    if parameter == "pixel_size":
        return "the layer's scale (with its units)"
    return None


def offers(parameter: str) -> bool:
    """Whether this widget has a control for the parameter (advice naming one it lacks is left out)."""
    return parameter in PARAMETER_CONTROLS or parameter == "pixel_size"


def widget_words(message) -> str:
    """A library message (an error, a warning, a note) in this widget's words."""
    if isinstance(message, TampError) and message.hint and not all(offers(n) for n in message.hint_names()):
        text = message.words(namer, hint=False)
    else:
        text = words(message, namer, offers)
    text = text.replace("choose another with -o", f"choose another with “{label('output')}”")  # export.files says the CLI's option
    return text[:1].upper() + text[1:]


def advice_words(report) -> list[str]:
    """What the description leaves out, said for this widget: each verdict or decision whose advice
    names a control the widget has, in its words ("try “Relief style” objects")."""
    from ..errors import file_words
    from ..lithograph.report import advice_notes

    # only where the widget has something to add: a note whose advice it cannot offer reads as in the description
    return [widget_words(n) for n in advice_notes(report) if words(n, namer, offers) != file_words(n)]


def result_words(summary: str, folder) -> str:
    """The result message: the print's line as the command line says it, its file's name spelt as on
    the disk (never capitalised), a full stop, and the folder when the line does not name it."""
    text = words(summary, namer, offers).rstrip(".") + "."
    return text if f" to {folder}" in text else f"{text} The files are in {folder}."


def printer_names() -> list[str]:
    """The printers offered: the profiles (built-in and the user's), then the printer table's."""
    from ..printing.printer_table import ALL_PRINTERS
    from ..printing.printers import all_printers

    names = list(all_printers())
    return names + [p.model for p in ALL_PRINTERS if p.model not in names]


def params_for(*, printer: str, preset: str, caption: str, relief_style: str, formats: tuple[str, ...],
               pixel_size_m: float | None = None, channel: str | None = None) -> LithoParams:
    """The LithoParams the controls ask for, as `tamp-os convert` builds them from its options."""
    changes = {"printer": printer, "preset": preset, "relief_style": relief_style, "formats": tuple(formats)}
    if caption.strip():
        changes["caption"] = caption.strip()
    if pixel_size_m is not None:
        changes["pixel_size"] = pixel_size_m
    if channel is not None:
        changes["channel"] = channel
    return LithoParams(**changes)
