"""LithoParams: every setting of a lithograph in one frozen, validated object.

Fields left as None are derived when the lithograph is made (from the printer profile and
preset); `dataclasses.replace()` makes variants for sweeps; `to_json`/`from_json` round-trip
it for the recipe sidecar. Each field carries its help text, unit and allowed range.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from typing import Any

from .errors import ParameterError
from .tactile.braille import DEFAULT_TABLE, BrailleSpec
from .printers import PRESETS
from .units import parse_length_m

FORMATS = ("stl", "3mf", "glb", "obj", "ply", "step", "pdf", "svg")
GRAPHIC_FORMATS = ("pdf", "svg")  # 2-D tactile graphics for swell paper and embossers
FITS = ("pad", "crop", "stretch")
MESHERS = ("adaptive", "grid")
# The relief styles (relief/styles.py implements them; a test keeps the two lists equal).
RELIEF_STYLES = ("reference", "structure", "levels", "objects", "auto")


def _f(default, help, unit="", lo=None, hi=None, choices=None, lo_open=False):
    return field(
        default=default,
        metadata={"help": help, "unit": unit, "lo": lo, "hi": hi, "choices": choices, "lo_open": lo_open},
    )


@dataclass(frozen=True)
class LithoParams:
    preset: str = _f("medium", "grid density from the nozzle: low, medium or high", choices=tuple(PRESETS))
    printer: str = _f("standard", "printer profile (standard, fine, large, one of yours, or a PrusaSlicer system printer: see the printers command)")
    nozzle_mm: float | None = _f(None, "nozzle diameter (default: from the printer)", "mm", 0.05, 2.0)
    layer_mm: float | None = _f(None, "layer height (default: from the printer)", "mm", 0.005, 1.0)
    width_mm: float | None = _f(None, "print width (default: from the printer, or from the height)", "mm", 5.0, 1000.0)
    depth_mm: float | None = _f(None, "print depth, top to bottom of the image (default: from the aspect ratio)", "mm", 5.0, 1000.0)
    fit: str | None = _f(None, "when width and height both disagree with the image: pad, crop or stretch", choices=FITS)
    resolution_px: int | None = _f(None, "grid points across the width (default: from the preset)", "px", 2, 16384)
    base_mm: float = _f(1.0, "solid base under the relief", "mm", 0.0, 50.0, lo_open=True)
    relief_mm: float = _f(3.0, "height of the relief above the base", "mm", 0.0, 50.0, lo_open=True)
    blur_px: float | None = _f(None, "Gaussian blur sigma in output pixels (default: from the preset)", "px", 0.0, 100.0)
    blur_mm: float | None = _f(None, "Gaussian blur sigma on the print (instead of blur_px)", "mm", 0.0, 50.0)
    invert: bool = _f(False, "raise dark parts instead of bright ones")
    flip_x: bool = _f(False, "mirror the image left to right")
    stretch_low_pct: float = _f(2.0, "lower percentile of the contrast stretch", "%", 0.0, 100.0)
    stretch_high_pct: float = _f(98.0, "upper percentile of the contrast stretch", "%", 0.0, 100.0)
    quantize: bool = _f(False, "round heights to whole layers")
    relief_style: str = _f(
        "structure",
        "how the picture becomes heights: structure (shapes a finger can find, fine detail as low texture), "
        "levels (a few flat plateaus), objects (particles and cells raised as domes), auto (chosen from the "
        "picture), reference (brightness = height, as the published workflow)",
        choices=RELIEF_STYLES,
    )
    detail_mm: float | None = _f(
        None, "finest shape read as shape; finer detail becomes texture (default: 2 mm, or the grid pitch if coarser)", "mm", 0.05, 50.0
    )
    texture_mm: float = _f(0.3, "height of the fine texture kept on the shapes (0 = none)", "mm", 0.0, 2.0)
    level_count: int = _f(3, "plateaus of the levels style", "", 2, 5)
    channel: str = _f("luminance", "luminance, or a channel: a number from 0 or red/green/blue/alpha")
    page: int | None = _f(None, "TIFF page or series to read (default: the first, or the data page beside a preview)", "", 0, 100000)
    z_slice: int | None = _f(None, "z-stack slice to use (default: maximum-intensity projection)", "", 0, 100000)
    pixel_size: str | None = _f(None, "physical pixel size, overriding the file's, e.g. 4.2nm, 0.5um, 3 micron, 0.01mm")
    keep_annotations: bool = _f(False, "keep burned-in scale bars, labels and data bands (default: remove them)")
    save_masks: bool = _f(False, "write NAME.annotations.png showing what was removed")
    max_megapixels: float = _f(400.0, "refuse larger images (decompression-bomb guard)", "Mpx", 0.0, 1e6, lo_open=True)
    max_decoded_gb: float = _f(2.0, "refuse images whose decoded pixels would take more memory (checked before decoding)", "GB", 0.0, 1024.0, lo_open=True)
    caption: str | None = _f(None, "braille caption along the bottom margin (text, or Unicode braille as is)")
    braille_table: str = _f(DEFAULT_TABLE, "liblouis table for braille (en-ueb-g1.ctb for grade 1, or any other)")
    scale_bar: str = _f("auto", "auto (when the pixel size is known), off, or a length such as 5um")
    orientation_corner: str = _f("cut", "orientation mark: cut (top right corner cut off, as on braille cards) or none", choices=("cut", "none"))
    frame_mm: float = _f(0.0, "width of a raised frame around the relief (0 = none)", "mm", 0.0, 10.0)
    dot_diameter_mm: float = _f(1.5, "braille dot base diameter", "mm", *BrailleSpec.RANGES["dot_diameter_mm"])
    dot_height_mm: float = _f(0.7, "braille dot height", "mm", *BrailleSpec.RANGES["dot_height_mm"])
    dot_spacing_mm: float = _f(2.5, "braille dot spacing within a cell", "mm", *BrailleSpec.RANGES["dot_spacing_mm"])
    cell_spacing_mm: float = _f(6.0, "braille cell to cell spacing", "mm", *BrailleSpec.RANGES["cell_spacing_mm"])
    line_spacing_mm: float = _f(10.0, "braille line to line spacing", "mm", *BrailleSpec.RANGES["line_spacing_mm"])
    multicolour: bool = _f(False, "two-colour print: the braille, scale bar and frame as a second part (a 3MF with two coloured parts; with STL, NAME.base.stl and NAME.raised.stl)")
    bed_mm: str | None = _f(None, "printer bed size, e.g. 120 or 120x200: a larger plate is split into tiles that fit, with pegs and sockets, written as NAME.tile-R-C.*")
    mesher: str = _f("adaptive", "adaptive: fewest triangles within max_error_mm; grid: every pixel a vertex", choices=MESHERS)
    max_error_mm: float | None = _f(None, "largest height error of the adaptive mesh (default: half the layer height; 0 = exact grid)", "mm", 0.0, 5.0)
    gcode: bool = _f(False, "also slice with PrusaSlicer to NAME.gcode and report print time, grams and cost")
    material: str = _f("PLA", "filament for slicing and estimates", choices=("PLA", "PETG", "ABS"))
    filament_price_per_kg: float = _f(25.0, "filament price per kg, in your currency", "", 0.0, 1000.0, lo_open=True)
    slice_timeout_s: float = _f(600.0, "stop PrusaSlicer after this long", "s", 0.0, 86400.0, lo_open=True)
    formats: tuple[str, ...] = _f(("stl",), "output formats (pdf and svg: a 2-D tactile graphic for swell paper or an embosser)", choices=FORMATS)
    panels: str = _f("auto", "multi-panel figures: auto (find the panels; print each on its own plus an overview), off (print the figure whole), or a grid of rows x columns such as 2x3")
    panel: str | None = _f(None, "print only these panels of a figure, by letter or number, e.g. b,c")
    panel_boxes: str | None = _f(None, "the panels' boxes in source pixels, label=x,y,w,h;… (the recipe records them, so a rebuild is identical)")
    page_size: str = _f("plate", "page of the pdf and svg graphics: plate (its own size), a4 or letter (centred)", choices=("plate", "a4", "letter"))

    def __post_init__(self):
        for f in dataclasses.fields(self):
            _check_field(f, getattr(self, f.name))
        if self.blur_px is not None and self.blur_mm is not None:
            raise ParameterError(
                f"blur_px and blur_mm: give one of them, not both (got blur_px={self.blur_px}, blur_mm={self.blur_mm})."
            )
        if self.stretch_low_pct >= self.stretch_high_pct:
            raise ParameterError(
                f"stretch_low_pct must be below stretch_high_pct; got {self.stretch_low_pct} and {self.stretch_high_pct}."
            )
        if self.pixel_size is not None:
            parse_length_m(self.pixel_size, "pixel_size")
        if self.scale_bar not in ("auto", "off"):
            parse_length_m(self.scale_bar, "scale_bar")
        self.braille_spec()  # checks the dot sizes against each other
        if self.bed_mm is not None:
            from .tiles import parse_bed_mm

            parse_bed_mm(self.bed_mm)
            if self.multicolour:
                raise ParameterError("multicolour and bed_mm: tiled two-colour prints are not made yet; choose one of them.")
        if self.panels not in ("auto", "off"):
            from .clean.panels import parse_grid

            parse_grid(self.panels)
        if self.panel_boxes is not None:
            from .clean.panels import parse_boxes

            parse_boxes(self.panel_boxes)
        if not self.formats:
            raise ParameterError(f"formats: choose at least one of {', '.join(FORMATS)}.")

    def braille_spec(self) -> BrailleSpec:
        return BrailleSpec(self.dot_diameter_mm, self.dot_height_mm, self.dot_spacing_mm, self.cell_spacing_mm, self.line_spacing_mm)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2, ensure_ascii=False)

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["formats"] = list(self.formats)
        return d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "LithoParams":
        if not isinstance(data, dict):
            raise ParameterError(f"parameters: expected a mapping of parameter names to values; got {type(data).__name__}.")
        data = _renamed(dict(data))
        _check_known(data)
        if "formats" in data:
            data["formats"] = tuple(data["formats"])
        return cls(**data)

    @classmethod
    def from_json(cls, text: str) -> "LithoParams":
        return cls.from_dict(json.loads(text))

    def replace(self, **changes) -> "LithoParams":
        changes = _renamed(changes)
        _check_known(changes)
        return dataclasses.replace(self, **changes)


# Earlier names of parameters, still accepted (older recipes, scripts): old -> new.
RENAMED = {"height_mm": "depth_mm"}


def _renamed(changes: dict) -> dict:
    for old, new in RENAMED.items():
        if old in changes:
            if new in changes:
                raise ParameterError(f"{old} and {new}: {old} is the old name of {new}; give one of them.")
            changes[new] = changes.pop(old)
    return changes


def _check_known(names) -> None:
    known = {f.name for f in dataclasses.fields(LithoParams)}
    unknown = sorted(set(names) - known)
    if unknown:
        raise ParameterError(f"unknown parameter(s) {', '.join(map(str, unknown))}; known: {', '.join(sorted(known))}.")


def parse_field(name: str, text: str):
    """A field's value from text (a CSV cell, a form field, a sweep value), typed by the field.

    Raises ParameterError naming the field, what it takes and the text received. Range checks
    happen when the LithoParams is built.
    """
    _check_known([name])
    f, text = next(f for f in dataclasses.fields(LithoParams) if f.name == name), text.strip()
    m = f.metadata
    if isinstance(f.default, bool):
        if text.lower() not in ("true", "false", "yes", "no", "1", "0", "on", "off"):
            raise ParameterError(f"{name}: must be true or false; got {text!r}.")
        return text.lower() in ("true", "yes", "1", "on")
    if name == "formats":
        return tuple(v.strip().lower().lstrip(".") for v in text.split(",") if v.strip())
    if m["lo"] is None or m["choices"]:
        return text
    whole = isinstance(m["lo"], int) and isinstance(m["hi"], int)
    try:
        return int(text) if whole else float(text)
    except ValueError:
        raise ParameterError(f"{name}: must be a {'whole ' if whole else ''}number ({describe_range(f)}); got {text!r}.") from None


def describe_range(f: dataclasses.Field) -> str:
    m = f.metadata
    if m["choices"]:
        return "one of " + ", ".join(m["choices"])
    if m["lo"] is None:
        return "any"
    lo_sign = ">" if m["lo_open"] else "≥"
    return f"{lo_sign} {m['lo']} and ≤ {m['hi']} {m['unit']}".rstrip()


def _check_field(f: dataclasses.Field, value: Any) -> None:
    m = f.metadata
    if value is None:
        if f.default is None:
            return
        raise ParameterError(f"{f.name}: a value is required ({describe_range(f)}).")
    if f.name == "formats":
        if isinstance(value, str) or not all(v in FORMATS for v in value):
            raise ParameterError(f"formats: each must be one of {', '.join(FORMATS)}; got {value!r}.")
        return
    if m["choices"]:
        if value not in m["choices"]:
            raise ParameterError(f"{f.name}: must be {describe_range(f)}; got {value!r}.")
        return
    if isinstance(f.default, bool):
        if not isinstance(value, bool):
            raise ParameterError(f"{f.name}: must be true or false; got {value!r}.")
        return
    if m["lo"] is None:
        if not isinstance(value, str) or not value.strip():
            raise ParameterError(f"{f.name}: must be text; got {value!r}.")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParameterError(f"{f.name}: must be a number {describe_range(f)}; got {value!r}.")
    if isinstance(m["lo"], int) and isinstance(m["hi"], int) and value != int(value):
        raise ParameterError(f"{f.name}: must be a whole number {describe_range(f)}; got {value!r}.")
    too_low = value <= m["lo"] if m["lo_open"] else value < m["lo"]
    if too_low or value > m["hi"]:
        raise ParameterError(f"{f.name}: must be {describe_range(f)}; got {value}{(' ' + m['unit']) if m['unit'] else ''}.")
