"""The settings form: field labels and help in the web app's words, and form -> LithoParams with
every invalid field reported at once, by its label, with the allowed range and what to do."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from ..errors import ParameterError
from ..params import LithoParams, parse_field
from ..printing.printers import PRESETS, get_printer


@dataclass(frozen=True)
class Field:
    name: str
    label: str
    help: str = ""
    numeric: str = ""  # "decimal" or "numeric" (whole numbers) for the keyboard; "" for text


FIELDS = {f.name: f for f in (
    Field("width_mm", "Print width (mm)", "Leave empty for the printer's width.", "decimal"),
    Field("depth_mm", "Print depth (mm)", "Leave empty to follow the image's shape.", "decimal"),
    Field("relief_mm", "Relief height (mm)", "Height of the raised parts above the base.", "decimal"),
    Field("base_mm", "Base thickness (mm)", "At least 0.8 mm; 1.0 to 1.5 mm is typical.", "decimal"),
    Field("nozzle_mm", "Nozzle diameter (mm)", "Leave empty for the profile's nozzle.", "decimal"),
    Field("layer_mm", "Layer height (mm)", "Leave empty for the profile's layer height.", "decimal"),
    Field("blur_px", "Blur (output pixels)", "Smooths noise; leave empty for the detail level's blur.", "decimal"),
    Field("resolution_px", "Resolution (grid points across)", "Overrides the level of detail.", "numeric"),
    Field("caption", "Braille caption", "Printed in braille along the bottom margin."),
    Field("scale_bar", "Scale bar", "auto (when the scale is known), off, or a length such as 5um."),
    Field("frame_mm", "Raised frame width (mm)", "0 for no frame.", "decimal"),
    Field("pixel_size", "Pixel size", "Overrides the file's scale, for example 4.2nm or 0.5um."),
    Field("detail_mm", "Finest shape (mm)", "Smaller detail becomes a low texture; leave empty for 2 mm.", "decimal"),
    Field("texture_mm", "Texture height (mm)", "Height of that fine texture; 0 for none.", "decimal"),
    Field("level_count", "Number of levels", "For the levels style: 2 to 5.", "numeric"),
    Field("bed_mm", "Printer bed size (mm)", "A larger print comes as tiles that fit, such as 180 or 180x180; "
          "leave empty for the printer's own bed.", "decimal"),
    Field("channel", "Channel", "luminance, or a channel's number (from 0) or name, as listed under the image."),
    Field("z_slice", "Z slice", "Leave empty for a projection of the whole z-stack; else a slice number from 0.", "numeric"),
    Field("time", "Time point", "Leave empty for the first time point; else a number from 0.", "numeric"),
    Field("scene", "Scene or series", "Leave empty for the first scene of a multi-scene file; else a number from 0.", "numeric"),
    Field("panels", "Panels of a figure", "auto finds the panels of a multi-panel figure and prints each, plus an overview; "
          "off prints it whole; or a grid of rows x columns such as 2x2."),
    Field("panel", "Panels to print", "With a grid above (such as 2x2): the cells to print by number in reading order, "
          "such as 1,3; leave empty for every cell. With auto, tick each figure's panels under Your images instead."),
)}
TEXT_FIELDS = ("caption", "pixel_size", "scale_bar", "bed_mm", "channel", "panels", "panel")
# The relief styles in the web app's words: what each is for.
STYLE_CHOICES = (
    ("structure", "Shapes to feel", "Large shapes a fingertip can follow; fine detail kept only as a low texture."),
    ("objects", "Raised objects", "Particles, spheres or cells raised as rounded domes over a flat ground. Good for SEM pictures."),
    ("levels", "A few flat levels", "Two to five plateaus, clearly apart by touch. Good for maps and diagrams."),
    ("content", "What the picture shows", "Every particle, bead or cell raised alike; grain boundaries, membranes and strokes as raised lines."),
    ("auto", "Choose for me (recommended)", "What the picture shows where it finds particles or lines, else one of the above; says why."),
    ("reference", "Brightness as height", "Every brightness step becomes height, as the published workflow does."),
)
NUMBER_FIELDS = tuple(n for n in FIELDS if n not in TEXT_FIELDS)
FLAGS = ("invert", "flip_x", "keep_annotations", "gcode", "multicolour", "volume")
LABELS = {**{n: f.label for n, f in FIELDS.items()}, "printer": "Printer profile", "preset": "Level of detail",
          "relief_style": "Relief style",
          "formats": "Output formats", "braille_table": "Braille code", "page_size": "Page size for PDF and SVG",
          "multicolour": "Two colours", "subject": "What the image shows", "volume": "Print as a 3-D model"}
PAGE_SIZE_CHOICES = ("plate", "a4", "letter")


def printer_choices() -> dict:
    """The printers the form offers: the profiles (built-in and the user's), then today's printers of
    the printer table (nozzle and resin), each as a PrinterProfile (name -> profile)."""
    from ..printing.printer_table import ALL_PRINTERS
    from ..printing.printers import all_printers, table_profile

    return {**all_printers(), **{p.model: table_profile(p.model) for p in ALL_PRINTERS}}


def braille_table_choices() -> list[tuple[str, str]]:
    """(table file name, label) for every braille code liblouis has here, by its name ('French contracted
    braille'), the default first; the default alone when no table folder is known."""
    from ..tactile.braille import DEFAULT_TABLE
    from ..tactile.braille_tables import installed_tables

    tables = sorted(installed_tables(), key=lambda t: (t.name != DEFAULT_TABLE, t.display_name.lower()))
    return [(t.name, f"{t.display_name} ({t.name})") for t in tables] or [(DEFAULT_TABLE, f"Unified English contracted braille ({DEFAULT_TABLE})")]


@dataclass
class FormErrors:
    """Invalid fields: name -> message in plain words (the page ties each to its field)."""

    by_field: dict[str, str]

    def summary(self) -> list[tuple[str, str]]:
        return list(self.by_field.items())


def params_from_form(form) -> tuple[LithoParams | None, FormErrors]:
    """The LithoParams a submitted settings form asks for, or None and every problem found."""
    changes, errors = {}, {}
    for name in (*NUMBER_FIELDS, *TEXT_FIELDS):
        text = (form.get(name) or "").strip()
        if not text:
            continue
        try:
            value = parse_field(name, text)
            LithoParams(**{name: value})  # this field's own range, alone
            changes[name] = value
        except ParameterError:
            errors[name] = field_message(name, text)
    changes.update({name: form.get(name) == "on" for name in FLAGS})
    changes["printer"] = form.get("printer") or "standard"
    changes["preset"] = form.get("preset") if form.get("preset") in PRESETS else "medium"
    changes["formats"] = tuple(f for f in form.getlist("formats")) or ("stl",)
    style = form.get("relief_style")
    changes["relief_style"] = style if style in dict((c[0], c) for c in STYLE_CHOICES) else "auto"
    table = form.get("braille_table")
    if table:
        if table in dict(braille_table_choices()):
            changes["braille_table"] = table
        else:
            errors["braille_table"] = "Braille code: choose one of the codes in the list."
    if form.get("page_size") in PAGE_SIZE_CHOICES:
        changes["page_size"] = form.get("page_size")
    try:
        get_printer(changes["printer"])
    except ParameterError:
        errors["printer"] = "Printer profile: choose one of the profiles in the list."
    if errors:
        return None, FormErrors(errors)
    try:
        return LithoParams(**changes), FormErrors({})
    except ParameterError as exc:  # a rule between fields (say, blur and resolution together)
        return None, FormErrors({"general": web_words(exc)})


def field_message(name: str, text: str) -> str:
    """'Relief height (mm): enter a number above 0 and up to 50 mm; you entered “0”.'"""
    f = {x.name: x for x in dataclasses.fields(LithoParams)}[name]
    m, label = f.metadata, LABELS[name]
    if m["lo"] is None:  # free text with its own grammar (lengths, braille)
        try:
            LithoParams(**{name: text})
        except ParameterError as exc:
            if exc.parameter == name and exc.allowed:  # laid out from the error's data, not its sentence
                hint = f" {web_words(exc.hint)}" if exc.hint else ""
                return f"{label}: enter {exc.allowed}.{hint} You entered “{text}”."
            return f"{label}: {web_words(exc)} You entered “{text}”."
        return f"{label}: this value cannot be used; you entered “{text}”."
    whole = isinstance(m["lo"], int) and isinstance(m["hi"], int)
    unit = f" {m['unit']}" if m["unit"] in ("mm",) else ""
    span = f"above {m['lo']:g} and up to {m['hi']:g}" if m["lo_open"] else f"from {m['lo']:g} to {m['hi']:g}"
    kind = "a whole number" if whole else "a number"
    return f"{label}: enter {kind} {span}{unit}, or leave it empty for the default; you entered “{text}”."


def label_of(name: str) -> str:
    """A parameter as the web app says it: its field's label, or its name in plain words for a
    setting this app does not show."""
    return f"“{LABELS[name]}”" if name in LABELS else f"“{name.replace('_', ' ')}”"


def offers(name: str) -> bool:
    """Whether the web app has a control for this parameter."""
    return name in LABELS or name in FLAGS


def web_words(message) -> str:
    """A library message (an error, a warning, a verdict) in the web app's words: each parameter
    it names becomes its field's label (errors.Text); a hint that names a setting this app does not
    have is left out."""
    from ..errors import TampError, words

    if isinstance(message, TampError) and message.hint and not all(offers(n) for n in message.hint_names()):
        text = message.words(label_of, hint=False)
    else:
        text = words(message, label_of, offers)
    return text[:1].upper() + text[1:]
