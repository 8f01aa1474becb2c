"""LithoParams: every setting of a lithograph in one frozen, validated object.

Fields left as None are derived when the lithograph is made (from the printer profile and
preset); `dataclasses.replace()` makes variants for sweeps; `to_json`/`from_json` round-trip
it for the recipe sidecar. Each field carries its help text, unit and allowed range.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import re
from dataclasses import dataclass, field
from typing import Any

from .errors import ParameterError, register_parameter_names, render
from .formats import GRAPHIC_FORMATS, NAMES as FORMATS  # noqa: F401  (GRAPHIC_FORMATS: re-exported)
from .printing.printers import PRESETS
from .standards import DEFAULT_TABLE, BrailleSpec
from .texts import parse_boxes, parse_grid
from .units import MAX_LENGTH_TEXT, PIXEL_SIZE_RANGE_M, format_length, parse_bed_mm, parse_length_m
FITS = ("pad", "crop", "stretch")
MESHERS = ("adaptive", "grid")
# The relief styles (relief/styles.py implements them; a test keeps the two lists equal).
RELIEF_STYLES = ("reference", "structure", "levels", "objects", "content", "auto")


def _f(default, help, unit="", lo=None, hi=None, choices=None, lo_open=False):
    return field(
        default=default,
        metadata={"help": help, "unit": unit, "lo": lo, "hi": hi, "choices": choices, "lo_open": lo_open},
    )


@dataclass(frozen=True)
class LithoParams:
    """Every setting of a lithograph in one frozen, validated object.

    Each field's unit, range, default and meaning is listed below (and by `field_table()`);
    the CLI's options, the web app's fields and a batch's CSV columns are these fields by name.
    Lengths are in millimetres (`_mm`), and
    pixel size and scale bar take SI numbers (metres) or text ("4.2nm"). Fields left as None are
    derived when the lithograph is made, from the printer profile and preset. A value out of range
    raises ParameterError naming the field, the range and the value.

    Examples
    --------
    >>> p = LithoParams(width_mm=60, relief_mm=2.5)
    >>> p.replace(preset="high").preset, p.width_mm
    ('high', 60)
    >>> LithoParams(relief_mm=-1)
    Traceback (most recent call last):
    ...
    tamp_os.errors.ParameterError: relief_mm: must be > 0.0 and ≤ 50.0 mm; got -1 mm.
    """


    # --- printer and size ---
    preset: str = _f("medium", "grid density from the nozzle: low, medium or high", choices=tuple(PRESETS))
    printer: str = _f("standard", "printer profile (standard, fine, large, one of yours, or a PrusaSlicer system printer: see the printers command)")
    nozzle_mm: float | None = _f(None, "nozzle diameter (default: from the printer)", "mm", 0.05, 2.0)
    layer_mm: float | None = _f(None, "layer height (default: from the printer)", "mm", 0.005, 1.0)
    width_mm: float | None = _f(None, "print width (default: from the printer, or from the height)", "mm", 5.0, 1000.0)
    depth_mm: float | None = _f(None, "print depth, top to bottom of the image (default: from the aspect ratio)", "mm", 5.0, 1000.0)
    fit: str | None = _f(None, "when width and height both disagree with the image: pad, crop or stretch", choices=FITS)
    resolution_px: int | None = _f(None, "grid points across the width (default: from the preset)", "px", 2, 16384)

    # --- heights and contrast ---
    base_mm: float = _f(1.0, "solid base under the relief", "mm", 0.0, 50.0, lo_open=True)
    relief_mm: float = _f(3.0, "height of the relief above the base", "mm", 0.0, 50.0, lo_open=True)
    blur_px: float | None = _f(None, "Gaussian blur sigma in output pixels (default: from the preset)", "px", 0.0, 100.0)
    blur_mm: float | None = _f(None, "Gaussian blur sigma on the print (instead of `blur_px`)", "mm", 0.0, 50.0)
    invert: bool = _f(False, "raise dark parts instead of bright ones")
    flip_x: bool = _f(False, "mirror the image left to right")
    stretch_low_pct: float = _f(2.0, "lower percentile of the contrast stretch", "%", 0.0, 100.0)
    stretch_high_pct: float = _f(98.0, "upper percentile of the contrast stretch", "%", 0.0, 100.0)
    quantize: bool = _f(False, "round heights to whole layers")

    # --- relief style ---
    relief_style: str = _f(
        "auto",
        "how the picture becomes heights: structure (shapes a finger can find, fine detail as low texture), "
        "levels (a few flat plateaus), objects (particles and cells raised as domes), content (what the picture "
        "shows: every member of a population raised alike, line networks as raised lines), auto (content where it "
        "finds a population or lines, else chosen from the picture), reference (brightness = height, as the published workflow)",
        choices=RELIEF_STYLES,
    )
    detail_mm: float | None = _f(
        None, "finest shape read as shape; finer detail becomes texture (default: 2 mm, or the grid pitch if coarser)", "mm", 0.05, 50.0
    )
    texture_mm: float = _f(0.3, "height of the fine texture kept on the shapes (0 = none)", "mm", 0.0, 2.0)
    level_count: int = _f(3, "plateaus of the levels style", "", 2, 5)

    # --- channels ---
    channel: str = _f("luminance", "luminance, or a channel: a number from 0 or red/green/blue/alpha")
    channels: str | None = _f(None, "how a picture of several channels prints: auto (the default: a multi-channel file, an RGB "
                              "fluorescence composite or a stained H&E/IHC slide prints each channel or stain as its own texture "
                              "with a braille key), off (brightness as one picture, as before), or NAME=ENCODING pairs "
                              "such as DAPI=domes,GFP=ridges (encodings: domes, ridges, dots, plateau)")
    key_labels: str | None = _f(None, "labels of the channel key, as NAME=LABEL pairs such as DAPI=nuclei,GFP=actin (default: from the channel names)")

    # --- what is read ---
    page: int | None = _f(None, "TIFF page or series to read (default: the first, or the data page beside a preview)", "", 0, 100000)
    z_slice: int | None = _f(None, "z-stack slice to use (default: maximum-intensity projection)", "", 0, 100000)
    time: int | None = _f(None, "time point of a time series to use, from 0 (default: the first)", "", 0, 1000000)
    scene: int | str | None = _f(None, "scene, series, image or position of a multi-scene file (CZI, LIF, ND2, EMD, ...): a number from 0, or a LIF series name (default: the first)", "", 0, 100000)
    pixel_size: str | float | None = _f(None, "physical pixel size, overriding the file's: a length such as 4.2nm, 0.5um, 3 micron, 0.01mm, or a number in metres (4.2e-9)")

    # --- annotations ---
    keep_annotations: bool = _f(False, "keep burned-in scale bars, labels and data bands (default: remove them)")
    save_masks: bool = _f(False, "write NAME.annotations.png showing what was removed")

    # --- limits on what is read ---
    max_megapixels: float = _f(100.0, "refuse larger images (decompression-bomb guard; 100 Mpx fits `max_memory_gb`)", "Mpx", 0.0, 1e6, lo_open=True)
    max_decoded_gb: float = _f(2.0, "refuse images whose decoded pixels would take more memory (checked before decoding)", "GB", 0.0, 1024.0, lo_open=True)
    max_memory_gb: float = _f(4.0, "refuse images whose conversion would need more memory in all: pixels, tiles, copies, working arrays (checked before decoding)", "GB", 0.0, 4096.0, lo_open=True)

    # --- tactile furniture ---
    caption: str | None = _f(None, "braille caption along the bottom margin (text, or Unicode braille as is)")
    subject: str | None = _f(None, "what the picture shows, for the description read aloud (e.g. 'FePt nanoparticles on carbon')")
    braille_table: str = _f(DEFAULT_TABLE, "liblouis table for braille (en-ueb-g1.ctb for grade 1, or any other)")
    scale_bar: str | float = _f("auto", "auto (when the pixel size is known), off, or a length such as 5um (a number: metres)")
    orientation_corner: str = _f("cut", "orientation mark: cut (top right corner cut off, as on braille cards) or none", choices=("cut", "none"))
    frame_mm: float = _f(0.0, "width of a raised frame around the relief (0 = none)", "mm", 0.0, 10.0)
    dot_diameter_mm: float = _f(1.5, "braille dot base diameter", "mm", *BrailleSpec.RANGES["dot_diameter_mm"])
    dot_height_mm: float = _f(0.7, "braille dot height", "mm", *BrailleSpec.RANGES["dot_height_mm"])
    dot_spacing_mm: float = _f(2.5, "braille dot spacing within a cell", "mm", *BrailleSpec.RANGES["dot_spacing_mm"])
    cell_spacing_mm: float = _f(6.0, "braille cell to cell spacing", "mm", *BrailleSpec.RANGES["cell_spacing_mm"])
    line_spacing_mm: float = _f(10.0, "braille line to line spacing", "mm", *BrailleSpec.RANGES["line_spacing_mm"])

    # --- parts and tiles ---
    multicolour: bool = _f(False, "two-colour print: the braille, scale bar and frame as a second part (a 3MF with two coloured parts; with STL, NAME.base.stl and NAME.raised.stl)")
    bed_mm: str | float | None = _f(None, "printer bed size in mm, e.g. 120 or 120x200 (a number: a square bed): a larger plate is split into tiles that fit, with pegs and sockets, written as NAME.tile-R-C.*")

    # --- mesh ---
    mesher: str = _f("adaptive", "adaptive: fewest triangles within `max_error_mm`; grid: every pixel a vertex", choices=MESHERS)
    max_error_mm: float | None = _f(None, "largest height error of the adaptive mesh (default: half the layer height; 0 = exact grid)", "mm", 0.0, 5.0)

    # --- slicing and estimates ---
    gcode: bool = _f(False, "also slice with PrusaSlicer to NAME.gcode and report print time, grams and cost")
    material: str = _f("PLA", "filament or resin for slicing and estimates: PLA, PETG, ABS, rPLA and rPETG (recycled), resin or "
                       "plant-resin (PLA, the default, on a resin printer means resin)",
                       choices=("PLA", "PETG", "ABS", "rPLA", "rPETG", "resin", "plant-resin"))
    filament_price_per_kg: float | None = _f(None, "filament price per kg, in your currency (default: 25, an assumed price)", "", 0.0, 1000.0, lo_open=True)
    resin_price_per_kg: float | None = _f(None, "resin price per kg, in your currency (default: 35, an assumed price)", "", 0.0, 1000.0, lo_open=True)
    slice_timeout_s: float = _f(600.0, "stop PrusaSlicer after this long", "s", 0.0, 86400.0, lo_open=True)

    # --- outputs ---
    formats: tuple[str, ...] = _f(("stl",), "output formats (pdf and svg: a 2-D tactile graphic for swell paper or an embosser)", choices=FORMATS)

    # --- figures and paper pages ---
    panels: str = _f("auto", "multi-panel figures: auto (find the panels; print each on its own plus an overview), off (print the figure whole), or a grid of rows x columns such as 2x3")
    panel: str | None = _f(None, "print only these panels of a figure, by letter or number, e.g. b,c")
    panel_boxes: str | None = _f(None, "the panels' boxes in source pixels, label=x,y,w,h;… (the recipe records them, so a rebuild is identical)")
    page_size: str = _f("plate", "page of the pdf and svg graphics: plate (its own size), a4 or letter (centred)", choices=("plate", "a4", "letter"))

    # --- volumes ---
    volume: bool = _f(False, "make a 3-D model of a z-stack or density map (a watertight solid on a base with the braille caption, scale bar and cut corner) instead of a relief")
    size_mm: float | None = _f(None, "longest side of a `volume` model (default: the printer's print width, 100 mm)", "mm", 5.0, 1000.0)
    z_step: str | float | None = _f(None, "z step of a `volume` stack, overriding the file's: a length such as 0.5um, or a number in metres")
    iso_level: float | None = _f(None, "isosurface level of a `volume` model, in the stack's own values (default: Otsu's threshold of the stack)", "", -1e38, 1e38)
    max_triangles: int = _f(200_000, "most triangles of a `volume` model (simplified within 0.1 mm of the full surface); at most "
                            "2,000,000 (a 100 MB STL), more than a slicer or a 0.4 mm nozzle can use", "", 1000, 2_000_000)
    min_wall_mm: float | None = _f(None, "thinnest wall of a `volume` model: thinner walls are thickened (default: 1.0 mm, 0.6 mm for a resin printer)", "mm", 0.1, 10.0)
    sections: int | None = _f(None, "print a z-stack as this many evenly spaced slices, each its own relief plate labelled in braille with its place", "", 2, 100)
    volume_stand: str = _f("plate", "what a `volume` model stands on: plate (a base with the furniture, fused) or none (the bare model)", choices=("plate", "none"))

    def __post_init__(self):
        for f in dataclasses.fields(self):
            _check_field(f, getattr(self, f.name))
        if self.blur_px is not None and self.blur_mm is not None:
            raise ParameterError(
                f"`blur_px` and `blur_mm`: give one of them, not both (got `blur_px`={self.blur_px}, `blur_mm`={self.blur_mm})."
            )
        if self.stretch_low_pct >= self.stretch_high_pct:
            raise ParameterError(
                f"`stretch_low_pct` must be below `stretch_high_pct`; got {self.stretch_low_pct} and {self.stretch_high_pct}."
            )
        self.pixel_size_m, self.scale_bar_m, self.bed_size_mm, self.z_step_m  # noqa: B018  each parsed (and so checked) here, once
        self.braille_spec()  # checks the dot sizes against each other
        if self.volume and self.sections:
            raise ParameterError("`volume` makes one 3-D model and `sections` a series of plates; give one of them.")
        if self.bed_mm is not None:
            if self.multicolour:
                raise ParameterError("`multicolour` and `bed_mm`: tiled two-colour prints are not made yet; choose one of them.")
        if self.panels not in ("auto", "off"):
            parse_grid(self.panels)
        if self.panel_boxes is not None:
            parse_boxes(self.panel_boxes)
        if not self.formats:
            raise ParameterError(f"`formats`: choose at least one of {', '.join(FORMATS)}.")

    @property
    def pixel_size_m(self) -> float | None:
        """`pixel_size` in metres (None: use the file's)."""
        return _length_m(self.pixel_size, "pixel_size", PIXEL_SIZE_RANGE_M)

    @property
    def z_step_m(self) -> float | None:
        """`z_step` in metres (None: use the file's)."""
        return _length_m(self.z_step, "z_step", PIXEL_SIZE_RANGE_M)

    @property
    def scale_bar_m(self) -> float | None:
        """The scale bar's length in metres when one is given; None for auto and off."""
        return None if self.scale_bar in ("auto", "off") else _length_m(self.scale_bar, "scale_bar", None, ("auto", "off"))

    @property
    def bed_size_mm(self) -> tuple[float, float] | None:
        """`bed_mm` as (width, depth) in mm, or None (no tiling)."""
        return None if self.bed_mm is None else parse_bed_mm(self.bed_mm)

    def section(self, title: str) -> dict[str, Any]:
        """One stage's parameters (a title of SECTIONS) and their values, as keyword arguments.

        >>> LithoParams(relief_mm=2.0).section("mesh")
        {'mesher': 'adaptive', 'max_error_mm': None}
        """
        names = dict(SECTIONS).get(title)
        if names is None:
            raise ParameterError(f"no section {title!r}; the sections are {', '.join(t for t, _ in SECTIONS)}.")
        return {name: getattr(self, name) for name in names}

    def read_options(self, **overrides) -> dict[str, Any]:
        """What `read.read_image` is asked for, from these parameters: the page, plane, time point, scene
        and channel, and the limits (the one place they are passed on); `overrides` replace some (a
        z-stack's model reads its first plane to learn the stack's size)."""
        options = {"page": self.page, "z_slice": self.z_slice, "time": self.time, "scene": self.scene,
                   "channel": self.channel, "max_megapixels": self.max_megapixels,
                   "max_decoded_gb": self.max_decoded_gb, "max_memory_gb": self.max_memory_gb}
        return {**options, **overrides}

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


# The parameters by stage, in field order: the command line's help groups its options so, and
# `LithoParams.section` gives one stage's values (a test keeps every field in exactly one section).
SECTIONS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ('printer and size', ('preset', 'printer', 'nozzle_mm', 'layer_mm', 'width_mm', 'depth_mm', 'fit', 'resolution_px')),
    ('heights and contrast', ('base_mm', 'relief_mm', 'blur_px', 'blur_mm', 'invert', 'flip_x', 'stretch_low_pct', 'stretch_high_pct', 'quantize')),
    ('relief style', ('relief_style', 'detail_mm', 'texture_mm', 'level_count')),
    ('channels', ('channel', 'channels', 'key_labels')),
    ('what is read', ('page', 'z_slice', 'time', 'scene', 'pixel_size')),
    ('annotations', ('keep_annotations', 'save_masks')),
    ('limits on what is read', ('max_megapixels', 'max_decoded_gb', 'max_memory_gb')),
    ('tactile furniture', ('caption', 'subject', 'braille_table', 'scale_bar', 'orientation_corner', 'frame_mm', 'dot_diameter_mm', 'dot_height_mm', 'dot_spacing_mm', 'cell_spacing_mm', 'line_spacing_mm')),
    ('parts and tiles', ('multicolour', 'bed_mm')),
    ('mesh', ('mesher', 'max_error_mm')),
    ('slicing and estimates', ('gcode', 'material', 'filament_price_per_kg', 'resin_price_per_kg', 'slice_timeout_s')),
    ('outputs', ('formats',)),
    ('figures and paper pages', ('panels', 'panel', 'panel_boxes', 'page_size')),
    ('volumes', ('volume', 'size_mm', 'z_step', 'iso_level', 'max_triangles', 'min_wall_mm', 'sections', 'volume_stand')),
)


BARE_NUMBER = re.compile(r"\s*[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?\s*")  # 4.2e-9, 0.5, 1e-9


def _length_m(value, name: str, range_m, words: tuple[str, ...] = ()) -> float | None:
    """A length parameter given as text with a unit ('4.2nm') or as a number of metres (4.2e-9);
    `words` are its other allowed values, named when a text is neither."""
    if value is None:
        return None
    given = value
    if isinstance(value, str) and len(value) <= MAX_LENGTH_TEXT and BARE_NUMBER.fullmatch(value):
        value = float(value)  # a number in metres, as the help says, given as text (the command line, a CSV cell)
    if isinstance(value, str):
        return parse_length_m(value, name, range_m, words=words)
    lo, hi = range_m or (0.0, math.inf)
    allowed = f"a length from {format_length(lo)} to {format_length(hi)}" if range_m else "a length greater than 0"
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or not (lo <= value <= hi) or value <= 0:
        got = f"{given!r} (metres)" if isinstance(given, str) else repr(given)
        raise ParameterError(
            f"`{name}`: must be {allowed}, as text with a unit (4.2nm) or a number of metres (4.2e-9); got {got}.",
            parameter=name, value=given, allowed=allowed, hint="A number without a unit is in metres; add the unit, such as 4.2nm.",
        )
    return float(value)


@functools.lru_cache(maxsize=1)
def parameter_names() -> frozenset[str]:
    """Every parameter's name (the fields of LithoParams), as messages may name them."""
    return frozenset(f.name for f in dataclasses.fields(LithoParams))


def field_table() -> str:
    """Every parameter with its unit, allowed range, default and meaning, one per line (for help())."""
    lines = []
    for f in dataclasses.fields(LithoParams):
        m = f.metadata
        unit = f" [{m['unit']}]" if m["unit"] else ""
        default = "derived" if f.default is None else repr(f.default)
        lines.append(f"    {f.name}{unit}: {render(m['help'])}. Allowed: {describe_range(f)}; default {default}.")
    return "\n".join(lines)



# Earlier names of parameters, still accepted (older recipes, scripts): old -> new.
RENAMED = {"height_mm": "depth_mm"}


def _renamed(changes: dict) -> dict:
    for old, new in RENAMED.items():
        if old in changes:
            if new in changes:
                raise ParameterError(f"{old} and `{new}`: {old} is the old name of `{new}`; give one of them.", parameter=new)
            changes[new] = changes.pop(old)
    return changes


def _check_known(names) -> None:
    known = parameter_names()
    unknown = sorted(set(names) - known, key=str)
    if unknown:
        raise ParameterError(
            f"unknown parameter(s) {', '.join(map(str, unknown))}; known: {', '.join(sorted(known))}.",
            value=unknown[0], allowed="a parameter name",
        )


# Text fields that also take a number (in the unit their help names).
NUMBER_OR_TEXT = ("pixel_size", "scale_bar", "bed_mm", "z_step")
NUMBER_OR_NAME = ("scene",)  # a whole number in its range, or a name the reader looks up (a LIF series)


def _field(name: str) -> dataclasses.Field:
    return next(f for f in dataclasses.fields(LithoParams) if f.name == name)


def _refuse(f: dataclasses.Field, value: Any, allowed: str, hint: str | None = None, shown: str | None = None) -> ParameterError:
    """The one shape of a parameter error: `name`: must be ALLOWED; got VALUE."""
    got = shown if shown is not None else repr(value)
    return ParameterError(f"`{f.name}`: must be {allowed}; got {got}." + (f" {hint}" if hint else ""),
                          parameter=f.name, value=value, allowed=allowed, hint=hint)


def parse_field(name: str, text: str):
    """A field's value from text (a CSV cell, a form field, a sweep value), typed by the field.

    Raises ParameterError naming the field, what it takes and the text received. Range checks
    happen when the LithoParams is built.
    """
    _check_known([name])
    f, text = _field(name), text.strip()
    m = f.metadata
    if isinstance(f.default, bool):
        if text.lower() not in ("true", "false", "yes", "no", "1", "0", "on", "off"):
            raise _refuse(f, text, "true or false")
        return text.lower() in ("true", "yes", "1", "on")
    if name == "formats":
        return tuple(v.strip().lower().lstrip(".") for v in text.split(",") if v.strip())
    if m["lo"] is None or m["choices"]:
        return text
    if name in NUMBER_OR_NAME and text and not text.lstrip("+-").isdigit():
        return text
    whole = isinstance(m["lo"], int) and isinstance(m["hi"], int)
    try:
        return int(text) if whole else float(text)
    except ValueError:
        raise _refuse(f, text, f"a {'whole ' if whole else ''}number ({describe_range(f)})") from None


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
        raise ParameterError(f"`{f.name}`: a value is required ({describe_range(f)}).", parameter=f.name, value=None,
                             allowed=describe_range(f))
    if f.name == "formats":
        if isinstance(value, str):
            raise _refuse(f, value, f"each one of {', '.join(FORMATS)}")
        bad = [v for v in value if v not in FORMATS]
        if bad:  # the item that is wrong, and the list as the user wrote it (not a Python tuple)
            allowed = f"each one of {', '.join(FORMATS)}"
            named = ", ".join(map(repr, bad))
            raise ParameterError(f"`formats`: {named} {'is not a format' if len(bad) == 1 else 'are not formats'} TAMP-OS "
                                 f"writes; give {allowed}; got {','.join(map(str, value))}.",
                                 parameter=f.name, value=value, allowed=allowed)
        return
    if m["choices"]:
        if value not in m["choices"]:
            raise _refuse(f, value, describe_range(f))
        return
    if isinstance(f.default, bool):
        if not isinstance(value, bool):
            raise _refuse(f, value, "true or false")
        return
    if m["lo"] is None:
        is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
        if f.name in NUMBER_OR_TEXT and is_number:
            return  # checked by its parser (pixel_size_m, scale_bar_m, bed_size_mm)
        if not isinstance(value, str) or not value.strip():
            raise _refuse(f, value, "a length or a number" if f.name in NUMBER_OR_TEXT else "text")
        return
    if f.name in NUMBER_OR_NAME and isinstance(value, str):
        if not value.strip():
            raise _refuse(f, value, f"a number {describe_range(f)} or a name")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _refuse(f, value, f"a number {describe_range(f)}")
    if isinstance(m["lo"], int) and isinstance(m["hi"], int) and value != int(value):
        raise _refuse(f, value, f"a whole number {describe_range(f)}")
    too_low = value <= m["lo"] if m["lo_open"] else value < m["lo"]
    if too_low or value > m["hi"]:
        raise _refuse(f, value, describe_range(f), shown=f"{value}{(' ' + m['unit']) if m['unit'] else ''}")


# Every field with its unit, range, default and meaning, in the class's own docstring (help()).
LithoParams.__doc__ = LithoParams.__doc__.replace(
    "    Examples\n    --------",
    "    Parameters\n    ----------\n    (name [unit]: meaning. Allowed values; default)\n" + field_table() + "\n\n    Examples\n    --------",
)
register_parameter_names(f.name for f in dataclasses.fields(LithoParams))
