"""The settings form: field labels and help in the web app's words, and form -> LithoParams with
every invalid field reported at once, by its label, with the allowed range and what to do."""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

from ..errors import ParameterError
from ..params import LithoParams, parse_field
from ..printers import PRESETS, get_printer


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
    Field("panels", "Panels of a figure", "auto finds the panels of a multi-panel figure and prints each, plus an overview; "
          "off prints it whole; or a grid of rows x columns such as 2x2."),
    Field("panel", "Panels to print", "Leave empty for every panel, or give their letters, such as b,c."),
)}
TEXT_FIELDS = ("caption", "pixel_size", "scale_bar", "panels", "panel")
# The relief styles in the web app's words: what each is for.
STYLE_CHOICES = (
    ("structure", "Shapes to feel (recommended)", "Large shapes a fingertip can follow; fine detail kept only as a low texture."),
    ("objects", "Raised objects", "Particles, spheres or cells raised as rounded domes over a flat ground. Good for SEM pictures."),
    ("levels", "A few flat levels", "Two to five plateaus, clearly apart by touch. Good for maps and diagrams."),
    ("auto", "Choose for me", "Picks one of the above from the picture and says why."),
    ("reference", "Brightness as height", "Every brightness step becomes height, as the published workflow does."),
)
NUMBER_FIELDS = tuple(n for n in FIELDS if n not in TEXT_FIELDS)
FLAGS = ("invert", "flip_x", "keep_annotations", "gcode")
LABELS = {**{n: f.label for n, f in FIELDS.items()}, "printer": "Printer profile", "preset": "Level of detail",
          "relief_style": "Relief style",
          "formats": "Output formats"}


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
    changes["relief_style"] = style if style in dict((c[0], c) for c in STYLE_CHOICES) else "structure"
    try:
        get_printer(changes["printer"])
    except ParameterError:
        errors["printer"] = "Printer profile: choose one of the profiles in the list."
    if errors:
        return None, FormErrors(errors)
    try:
        return LithoParams(**changes), FormErrors({})
    except ParameterError as exc:  # a rule between fields (say, blur and resolution together)
        return None, FormErrors({"general": plain(str(exc))})


def field_message(name: str, text: str) -> str:
    """'Relief height (mm): enter a number above 0 and up to 50 mm; you entered “0”.'"""
    f = {x.name: x for x in dataclasses.fields(LithoParams)}[name]
    m, label = f.metadata, LABELS[name]
    if m["lo"] is None:  # free text with its own grammar (lengths, braille)
        try:
            LithoParams(**{name: text})
        except ParameterError as exc:
            return f"{label}: {plain(str(exc))} You entered “{text}”."
        return f"{label}: this value cannot be used; you entered “{text}”."
    whole = isinstance(m["lo"], int) and isinstance(m["hi"], int)
    unit = f" {m['unit']}" if m["unit"] in ("mm",) else ""
    span = f"above {m['lo']:g} and up to {m['hi']:g}" if m["lo_open"] else f"from {m['lo']:g} to {m['hi']:g}"
    kind = "a whole number" if whole else "a number"
    return f"{label}: enter {kind} {span}{unit}, or leave it empty for the default; you entered “{text}”."


def plain(message: str) -> str:
    """A library message in the form's words: field names and command-line flags become labels."""
    message = re.sub(r"^\w+(?: and \w+)?: ", "", message)
    message = re.sub(r"--([a-z][a-z-]*)(?: \S+)?", lambda m: "“" + LABELS.get(m.group(1).replace("-", "_"), m.group(1)) + "”", message)
    for name, label in LABELS.items():
        message = re.sub(rf"\b{name}\b", f"“{label}”", message)
    return message[:1].upper() + message[1:]
