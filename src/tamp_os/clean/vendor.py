"""Small readers of microscope vendors' metadata blocks shared by the scale and band steps.

Vendor blocks arrive as tifffile decodes them (nested dicts, tuples, INI text); these helpers
turn their loosely typed values into numbers and sections, and never raise on bad input.
"""

from __future__ import annotations

import math
from pathlib import Path

SIDECAR_MAX_BYTES = 1_000_000  # JEOL, Hitachi and TESCAN sidecars are a few kB; more is not a sidecar
SIDECAR_MAX_LINE = 4096  # characters kept of one line (a line this long holds no key we read)


def sidecar_text(path: Path, warnings: list[str] | None = None) -> str | None:
    """The text of a sidecar beside an image, read once and size-capped; None (with a warning)
    when it cannot be read, is not a regular file or is larger than a sidecar can be."""
    try:
        size = path.stat().st_size
        if size > SIDECAR_MAX_BYTES:
            if warnings is not None:
                warnings.append(f"{path.name}: {size:,} bytes is too large for a microscope sidecar (at most "
                                f"{SIDECAR_MAX_BYTES:,}); it was ignored.")
            return None
        with path.open("rb") as fh:
            data = fh.read(SIDECAR_MAX_BYTES + 1)[:SIDECAR_MAX_BYTES]
    except OSError as exc:
        if warnings is not None:
            warnings.append(f"{path.name}: the sidecar cannot be read ({exc.strerror or exc}); it was ignored. "
                            "Check its permissions.")
        return None
    return data.decode("utf-8", errors="replace")


def sidecar_keys(text: str, keys: tuple[str, ...]) -> dict[str, str]:
    """The first value of each key in a line-based sidecar, read line by line (linear time).

    A line is `KEY=VALUE` (Hitachi) or `KEY VALUE...` (JEOL's `$$SM_MICRON_BAR 120`, `$CM_...`);
    leading `$` signs and blanks are ignored. Values are the rest of the line, stripped.
    """
    wanted, found = set(keys), {}
    for line in text.splitlines():
        line = line[:SIDECAR_MAX_LINE].strip().lstrip("$")
        if not line:
            continue
        key, sep, value = line.partition("=")
        if not sep or " " in key.strip():
            key, _, value = line.partition(" ")
            key = key.rstrip("=")
        key = key.strip()
        if key in wanted and key not in found:
            found[key] = value.strip().lstrip("=").strip()
    return found


def number(value) -> float | None:
    """A finite float from a number or from the first word of a string, else None."""
    try:
        value_f = float(str(value).strip().split()[0]) if isinstance(value, str) else float(value)
    except (TypeError, ValueError, IndexError):
        return None
    return value_f if math.isfinite(value_f) else None


def ini_sections(text: str) -> dict[str, dict[str, str]]:
    """Sections of an INI text (case kept; later keys win); {} when it has none.

    Read line by line in one pass: configparser takes 3 µs a line, so a hostile 1 MB sidecar of
    blank lines took seconds. Lines starting with ';' or '#' are comments; keys and values are
    split at the first '=' (or ':') and stripped; lines outside a section are ignored.
    """
    sections: dict[str, dict[str, str]] = {}
    current: dict[str, str] | None = None
    for raw in text.splitlines():
        line = raw[:SIDECAR_MAX_LINE].strip()
        if not line or line[0] in ";#":
            continue
        if line[0] == "[" and line.endswith("]"):
            current = sections.setdefault(line[1:-1].strip(), {})
            continue
        if current is None:
            continue
        key, sep, value = line.partition("=")
        if not sep or ":" in key:
            key, sep, value = line.partition(":") if ":" in line else (key, sep, value)
        if sep and key:
            current[key.strip()] = value.strip()
    return sections


def tescan_main(tiff_tags: dict, path: Path | None) -> tuple[dict[str, str], str] | None:
    """TESCAN's [MAIN] section from TIFF tag 50431 or a `.hdr` sidecar, with where it was found."""
    text = tiff_tags.get(50431)
    where = "TESCAN tag 50431"
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    if not (isinstance(text, str) and "[MAIN]" in text) and path is not None:
        sidecar = path.with_suffix(".hdr")
        if sidecar.is_file():
            text, where = sidecar_text(sidecar), f"TESCAN sidecar {sidecar.name}"
    if not (isinstance(text, str) and "[MAIN]" in text):
        return None
    return ini_sections(text).get("MAIN", {}), where
