"""Key labels short enough to read in braille: the dye kept, filter and detector words dropped.

A channel's name in a microscope file often carries its acquisition ("HyD 1 Leica/FITC", "FITC BP",
"EGFP 525/50 nm"): the reader needs the dye, not the filter. Each key entry offers the forms its
braille may take, from the fullest to the shortest; the key (relief/key3d.py) writes the fullest
that fits its line. The full label ("spots (FITC BP)") stays in the description and the report.
"""

from __future__ import annotations

import re

# acquisition words: filters and their bands, detectors, vendors, wavelengths
_DROP = re.compile(
    r"^(?:bp|lp|sp|dm|em|ex|filter|cube|hyd|pmt|gaasp|apd|spad|detector|camera|cam|ch|channel|leica|zeiss|nikon|"
    r"olympus|evident|andor|hamamatsu|\d{1,2}|\d{3}(?:\.\d)?(?:nm)?|\d{3}[-/]\d{2,3}(?:nm)?|nm)$",
    re.IGNORECASE,
)


def short_channel_name(name: str) -> str:
    """The dye in a channel's name: "FITC BP" -> "FITC", "HyD 1 Leica/FITC" -> "FITC"; the name
    itself when nothing is left or nothing is dropped. A lone wavelength ("Alexa 488") is kept
    when the name has no filter band: it names the dye."""
    band = _BAND.search(name) is not None
    text = _BAND.sub(" ", name.strip())
    tokens = [t for t in re.split(r"[\s/_,;]+", text) if t]
    numbers = [t for t in tokens if re.fullmatch(r"\d{3}", t)]  # "488nm" or "488 nm" is a wavelength, dropped
    keep_number = len(numbers) == 1 and len(tokens) > 1 and not band and "nm" not in (t.lower() for t in tokens)
    kept = [t for t in tokens if not _DROP.match(t) or (keep_number and t in numbers)]
    if not kept or (len(kept) == len(tokens) and not band):
        return name.strip()
    return " ".join(kept)


_BAND = re.compile(r"\b\d{3}\s*[-/]\s*\d{2,3}(?:\s*nm)?\b|\b(?:bp|lp|sp)\b", re.IGNORECASE)


def compact_dye(short: str) -> str:
    """The dye's usual short writing: "Alexa Fluor 647" and "Alexa 647" -> "AF647"; others as they are."""
    return re.sub(r"^alexa(?:\s*fluor)?[\s-]*(\d{3})$", r"AF\1", short.strip(), flags=re.IGNORECASE)


def label_forms(role: str, name: str, role_known: bool = False) -> tuple[str, ...]:
    """The forms a key line may write for "role (name)", fullest first, without repeats; the dye
    alone (compact_dye) is last. Acquisition words are never written: "spots (FITC)" is the
    fullest for "FITC BP". `role_known`: the role says what the channel shows (a dye's, a
    wavelength's or the file name's "microtubules", not a shape's "spots"); then the role alone
    comes before the dye alone, since "microtubules" tells a reader more than "ChA-T1"."""
    short = short_channel_name(name)
    out: list[str] = []
    alone = (role, compact_dye(short)) if role_known else (compact_dye(short),)
    for f in (f"{role} ({short})", f"{role} {short}", f"{role} {compact_dye(short)}", *alone):
        if f not in out:
            out.append(f)
    return tuple(out)
