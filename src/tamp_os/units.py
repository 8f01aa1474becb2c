"""Length strings with units ("4.2nm", "0.5 µm") to metres, and metres to readable text."""

from __future__ import annotations

import re

from .errors import ParameterError

_FACTORS_M = {
    "pm": 1e-12,
    "å": 1e-10,  # Ångström (TEM work); the Angstrom sign U+212B is folded into U+00C5 below
    "angstrom": 1e-10,
    "nm": 1e-9,
    "um": 1e-6,
    "µm": 1e-6,
    "μm": 1e-6,  # Greek mu as well as the micro sign
    "micron": 1e-6,
    "microns": 1e-6,
    "mm": 1e-3,
    "cm": 1e-2,
    "m": 1.0,
}
# Spelled-out names, as microscope software writes them (DigitalMicrograph: "micrometer").
for _prefix, _factor in (("pico", 1e-12), ("nano", 1e-9), ("micro", 1e-6), ("milli", 1e-3), ("centi", 1e-2), ("", 1.0)):
    for _ending in ("meter", "metre", "meters", "metres"):
        _FACTORS_M[_prefix + _ending] = _factor


def unit_factor_m(unit: str) -> float | None:
    """Metres per `unit`, or None when the unit is not a length we know."""
    return _FACTORS_M.get(unit.strip().replace("\u212b", "\u00c5").lower().replace("\u00b5", "µ"))


PIXEL_SIZE_RANGE_M = (1e-12, 1.0)  # 1 pm to 1 m per pixel: anything else is a typo
MIN_BED_MM = 60.0  # smaller beds leave no room for the tiles' pegs, sockets and labels


MAX_LENGTH_TEXT = 64  # characters of a length such as '4.2 nm'


def parse_length_m(text: str, name: str = "pixel_size", range_m: tuple[float, float] | None = None,
                   *, words: tuple[str, ...] = ()) -> float:
    """'4.2nm' -> 4.2e-9. Raises ParameterError naming `name` when it cannot be read.

    range_m : the allowed (lowest, highest) value in metres; PIXEL_SIZE_RANGE_M for `pixel_size`.
    words : the parameter's other allowed values ("auto", "off"), said beside a length when the text is neither.
    """
    if range_m is None and name == "pixel_size":
        range_m = PIXEL_SIZE_RANGE_M
    text_s = str(text)
    # A length is a few characters; a long text (a recipe or CSV is a file) would make the
    # pattern's [0-9]*\.?[0-9]+ backtrack quadratically, so it is refused before matching.
    match = None if len(text_s) > MAX_LENGTH_TEXT else re.fullmatch(
        r"\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-zA-Zµμ\u00c5\u212b]+)\s*", text_s)
    factor = unit_factor_m(match.group(2)) if match else None
    if not match or factor is None:
        choice = f"{', '.join(words)} or " if words else ""
        raise ParameterError(
            f"`{name}`: cannot read {text_s[:40]!r}{'…' if len(text_s) > 40 else ''} as a length; give {choice}a number and a unit.",
            parameter=name, value=text, allowed=f"{choice}a number and a unit",
            hint="For example 4.2nm, 0.5um, 3 micron, 12Å or 0.01mm (units: pm, Å, nm, µm, um, micron, mm, cm, m).",
        )
    value = float(match.group(1)) * factor
    if value <= 0:
        bounds = f" (between {format_length(range_m[0])} and {format_length(range_m[1])})" if range_m else ""
        raise ParameterError(f"`{name}`: must be a length greater than 0{bounds}; got {text!r}.", parameter=name, value=text,
                             allowed=f"a length greater than 0{bounds}")
    if range_m and not range_m[0] <= value <= range_m[1]:
        allowed = f"between {format_length(range_m[0])} and {format_length(range_m[1])}"
        raise ParameterError(f"`{name}`: must be {allowed}; got {text!r} ({value:g} m). Check the unit.",
                             parameter=name, value=text, allowed=allowed, hint="Check the unit.")
    return value


def format_length(metres: float) -> str:
    """A length in the unit that keeps the number between 1 and 1000: 2.6e-6 -> '2.6 µm'."""
    for unit, factor in (("m", 1.0), ("mm", 1e-3), ("µm", 1e-6), ("nm", 1e-9), ("pm", 1e-12)):
        if abs(metres) >= factor or unit == "pm":
            return f"{metres / factor:.4g} {unit}"
    raise AssertionError("unreachable")


def parse_bed_mm(text: "str | float") -> tuple[float, float]:
    """'120' or '120x200' (mm), or a number of mm (a square bed), as (width, depth); ParameterError
    with the allowed form otherwise."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        text = f"{float(text)!r}"
    match = re.fullmatch(r"\s*(\d+(?:\.\d*)?)\s*(?:[x×*]\s*(\d+(?:\.\d*)?)\s*)?(?:mm)?\s*", str(text))
    if not match:
        raise ParameterError(f"`bed_mm`: give the bed as a size in mm, such as 120 or 120x200; got {text!r}.")
    width = float(match.group(1))
    depth = float(match.group(2)) if match.group(2) else width
    if min(width, depth) < MIN_BED_MM or max(width, depth) > 2000:
        raise ParameterError(f"`bed_mm`: each side must be {MIN_BED_MM:g} to 2000 mm (pegs and labels need room); got {text!r}.")
    return width, depth
