"""Small readers of microscope vendors' metadata blocks shared by the scale and band steps.

Vendor blocks arrive as tifffile decodes them (nested dicts, tuples, INI text); these helpers
turn their loosely typed values into numbers and sections, and never raise on bad input.
"""

from __future__ import annotations

import configparser
import math
from pathlib import Path


def number(value) -> float | None:
    """A finite float from a number or from the first word of a string, else None."""
    try:
        value_f = float(str(value).strip().split()[0]) if isinstance(value, str) else float(value)
    except (TypeError, ValueError, IndexError):
        return None
    return value_f if math.isfinite(value_f) else None


def ini_sections(text: str) -> dict[str, dict[str, str]]:
    """Sections of an INI text (case kept); {} when it does not parse."""
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str
    try:
        parser.read_string(text)
    except configparser.Error:
        return {}
    return {s: dict(parser[s]) for s in parser.sections()}


def tescan_main(tiff_tags: dict, path: Path | None) -> tuple[dict[str, str], str] | None:
    """TESCAN's [MAIN] section from TIFF tag 50431 or a `.hdr` sidecar, with where it was found."""
    text = tiff_tags.get(50431)
    where = "TESCAN tag 50431"
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    if not (isinstance(text, str) and "[MAIN]" in text) and path is not None:
        sidecar = path.with_suffix(".hdr")
        if sidecar.is_file():
            text, where = sidecar.read_text(encoding="utf-8", errors="replace"), f"TESCAN sidecar {sidecar.name}"
    if not (isinstance(text, str) and "[MAIN]" in text):
        return None
    return ini_sections(text).get("MAIN", {}), where
