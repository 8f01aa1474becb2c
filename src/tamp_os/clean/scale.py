"""Physical pixel size from vendor metadata, or given by the user, with where it came from.

Each reader returns a length in metres or None; a value that is missing, unparsable, zero,
negative or absurd is skipped with a warning, and the next source is tried. Plain TIFF
resolution (72 or 96 dpi from SEM vendors) is never taken as a physical size. The data band
(rows that are not picture) is found elsewhere: clean/band.py.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import Decision, Text
from ..units import format_length, unit_factor_m
from ..read.xmltext import parse_xml
from .vendor import number, sidecar_keys, sidecar_text, tescan_main

PLAUSIBLE_M = (1e-13, 1e-2)  # 0.1 pm to 1 cm per pixel
USER_GIVEN = Text("given by the user (`pixel_size`)")


@dataclass(frozen=True)
class PixelSize:
    """The physical size of one source pixel.

    metres : the pixel size in m, or None when no source gave one.
    provenance : where the value came from ("FEI [Scan] PixelWidth", USER_GIVEN, ...), or "none".
    warnings : sources that were present but unusable, and overrides, in plain sentences.
    """

    metres: float | None = None
    provenance: str = "none"
    warnings: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Inputs:
    metadata: dict
    tiff_tags: dict
    path: Path | None
    width_px: int


# A reader returns None when its source is absent, else (metres or None, provenance).
Found = tuple[float | None, str] | None


def _fei(inp: _Inputs, warnings: list[str]) -> Found:
    width = (inp.metadata.get("fei_metadata") or {}).get("Scan", {}).get("PixelWidth")
    return None if width is None else (number(width), "FEI [Scan] PixelWidth")


def _zeiss(inp: _Inputs, warnings: list[str]) -> Found:
    sem = inp.metadata.get("sem_metadata")
    if not sem or "ap_width" not in sem:
        return None
    entry = sem["ap_width"]  # ('Width', 2.677, 'mm')
    try:
        value, unit = number(entry[1]), unit_factor_m(str(entry[2]))
    except (IndexError, TypeError):
        value, unit = None, None
    size = value * unit / inp.width_px if value is not None and unit else None
    return size, "Zeiss SmartSEM ap_width ÷ image width"


def _sis(inp: _Inputs, warnings: list[str]) -> Found:
    """Olympus SIS (tag 33560): tifffile gives `pixelsizex` already in metres."""
    sis = inp.metadata.get("sis_metadata")
    if not sis or "pixelsizex" not in sis:
        return None
    return number(sis["pixelsizex"]), "Olympus SIS pixelsizex"


def _vendor(inp: _Inputs, warnings: list[str]) -> Found:
    """Vendor formats (CZI, LIF, ND2, OME-Zarr, MRC, TIA, EMD...): what their reader found, with its key."""
    facts = inp.metadata.get("vendor")
    if not facts or not facts.get("pixel_size_m"):
        return None
    return number(facts["pixel_size_m"][0]), f"{facts['format']} {facts['pixel_size_key']} (read by {facts['reader']})"


def _tvips(inp: _Inputs, warnings: list[str]) -> Found:
    """TVIPS EM-MENU (tag 37706): PixelSizeX in nm."""
    tvips = inp.metadata.get("tvips_metadata")
    if not tvips or "PixelSizeX" not in tvips:
        return None
    nm = number(tvips["PixelSizeX"])
    return (nm * 1e-9 if nm is not None else None), "TVIPS tag 37706 PixelSizeX (nm)"


def _svs(inp: _Inputs, warnings: list[str]) -> Found:
    """Aperio SVS: MPP (µm per pixel of level 0) in the ImageDescription, times the level's downsampling."""
    svs = inp.metadata.get("svs_metadata")
    if not svs or "MPP" not in svs:
        return None
    mpp = number(svs["MPP"])
    down = float(inp.metadata.get("pyramid_downsample", 1.0))
    where = "Aperio SVS MPP" + (f" × {down:.3g} (pyramid level {inp.metadata.get('pyramid_level')})" if down != 1.0 else "")
    return (mpp * 1e-6 * down if mpp is not None else None), where


DM_SCALE_TAGS = (65009, 65010)  # DigitalMicrograph's TIFF: scale per pixel along x, then y
DM_UNIT_TAGS = (65003, 65012)  # ... and the length unit, where versions put it


def _tag_text(value) -> str:
    """A tag's text, whatever tifffile made of it (str, bytes in UTF-8 or Latin-1, a 1-tuple)."""
    if isinstance(value, (tuple, list)) and len(value) == 1:
        value = value[0]
    if isinstance(value, bytes):
        try:
            value = value.decode("utf-8")
        except UnicodeDecodeError:
            value = value.decode("latin-1")  # DM writes µ as the single byte 0xB5
    return str(value).strip("\x00 \t")


def _dm_tiff_tags(inp: _Inputs, warnings: list[str]) -> Found:
    """DigitalMicrograph's private TIFF tags: scale in 65009 (x), unit in 65003 or 65012."""
    scale = next((inp.tiff_tags[t] for t in DM_SCALE_TAGS if t in inp.tiff_tags), None)
    if scale is None:
        return None
    units = [_tag_text(inp.tiff_tags[t]) for t in DM_UNIT_TAGS if t in inp.tiff_tags]
    factor = next((f for f in map(unit_factor_m, units) if f), None)
    if factor is None:
        warnings.append(f"DigitalMicrograph TIFF tags: unit {units[0] if units else 'missing'!r} is not a length; no scale.")
        return None
    value = number(_tag_text(scale) if isinstance(scale, (bytes, str)) else scale[0] if isinstance(scale, (tuple, list)) else scale)
    return (value * factor if value is not None else None), "DigitalMicrograph TIFF tags"


def _tescan(inp: _Inputs, warnings: list[str]) -> Found:
    found = tescan_main(inp.tiff_tags, inp.path)
    if found is None:
        return None
    main, where = found
    return number(main.get("PixelSizeX")), f"{where} [MAIN] PixelSizeX"


def _sidecar_txt(inp: _Inputs, warnings: list[str]) -> Found:
    """JEOL SEM ($$SM_MICRON_BAR / $$SM_MICRON_MARKER) and Hitachi (PixelSize= in nm) sidecars,
    read line by line and size-capped (clean/vendor.py): no regex runs over the file's text."""
    if inp.path is None or not inp.path.with_suffix(".txt").is_file():
        return None
    sidecar = inp.path.with_suffix(".txt")
    text = sidecar_text(sidecar, warnings)
    if text is None:
        return None
    keys = sidecar_keys(text, ("PixelSize", "SM_MICRON_BAR", "SM_MICRON_MARKER"))
    if "PixelSize" in keys:
        nm = number(keys["PixelSize"])
        return (None if nm is None else nm * 1e-9), f"Hitachi sidecar {sidecar.name} PixelSize (nm)"
    if "SM_MICRON_BAR" not in keys or "SM_MICRON_MARKER" not in keys:
        return None
    pixels, (length, unit_word) = number(keys["SM_MICRON_BAR"]), _number_and_unit(keys["SM_MICRON_MARKER"])
    unit = unit_factor_m(unit_word) if unit_word else None
    size = length * unit / pixels if pixels and length and unit else None
    return size, f"JEOL sidecar {sidecar.name} SM_MICRON_MARKER ÷ SM_MICRON_BAR"


def _number_and_unit(text: str) -> tuple[float | None, str]:
    """'10um' or '10 um' -> (10.0, 'um'); (None, '') when it does not start with a number."""
    text = text.strip()
    digits = len(text) - len(text.lstrip("0123456789."))
    rest = text[digits:].lstrip()
    letters = len(rest) - len(rest.lstrip("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZµμ"))
    return (number(text[:digits]) if digits else None), rest[:letters]


def _imagej(inp: _Inputs, warnings: list[str]) -> Found:
    ij = inp.metadata.get("imagej_metadata")
    if not ij or "unit" not in ij:
        return None
    unit_text = str(ij["unit"]).replace("\\u00B5", "µ")  # ImageJ writes µ as a \u00B5 escape
    unit = unit_factor_m(unit_text)
    res = inp.tiff_tags.get(282)  # XResolution: pixels per unit
    if unit is None or res is None:
        return None
    try:
        per_unit = res[0] / res[1] if isinstance(res, tuple) else float(res)
    except (TypeError, ZeroDivisionError, IndexError):
        per_unit = 0
    return (unit / per_unit if per_unit and per_unit > 0 else None), f"ImageJ resolution ({unit_text})"


def _ome(inp: _Inputs, warnings: list[str]) -> Found:
    xml = inp.metadata.get("ome_metadata")
    if not xml:
        return None
    root = parse_xml(xml) if isinstance(xml, str) else None
    if root is None:
        warnings.append("OME-XML: cannot be parsed; ignored.")
        return None
    pixels = next((el for el in root.iter() if el.tag.endswith("}Pixels") or el.tag == "Pixels"), None)
    if pixels is None or "PhysicalSizeX" not in pixels.attrib:
        return None
    unit = unit_factor_m(pixels.attrib.get("PhysicalSizeXUnit", "µm"))
    value = number(pixels.attrib["PhysicalSizeX"])
    down = float(inp.metadata.get("pyramid_downsample", 1.0))  # PhysicalSizeX is level 0's
    where = "OME PhysicalSizeX" + (f" × {down:.3g} (pyramid level {inp.metadata.get('pyramid_level')})" if down != 1.0 else "")
    return (value * unit * down if value is not None and unit else None), where


def _dm(inp: _Inputs, warnings: list[str]) -> Found:
    axes = inp.metadata.get("dm_axes")
    if not axes:
        return None
    x = axes[-1]
    unit = unit_factor_m(str(x.get("units", "")))
    value = number(x.get("scale"))
    if unit is None:
        warnings.append(f"DigitalMicrograph: axis unit {x.get('units')!r} is not a length; no scale.")
        return None
    return (value * unit if value is not None else None), "DigitalMicrograph calibration"


READERS = (_vendor, _fei, _zeiss, _sis, _tvips, _svs, _dm_tiff_tags, _tescan, _sidecar_txt, _imagej, _ome, _dm)  # most specific first


def _plausible(value_m: float | None, provenance: str, warnings: list[str]) -> bool:
    """Whether `value_m` is a sane pixel size; otherwise say why, so the next source is tried."""
    if value_m is None:
        warnings.append(f"{provenance}: present but not a number; ignored.")
        return False
    if not PLAUSIBLE_M[0] <= value_m <= PLAUSIBLE_M[1]:
        warnings.append(f"{provenance}: pixel size {value_m:g} m is zero, negative or implausible; ignored.")
        return False
    return True


def read_pixel_size(
    metadata: dict, tiff_tags: dict, path: str | None, *, width_px: int, pixel_size_m: float | None = None
) -> PixelSize:
    """The pixel size the microscope recorded, or `pixel_size_m` when the user gives one.

    Parameters
    ----------
    metadata, tiff_tags : ImageFile.metadata and ImageFile.tiff_tags of the input.
    path : the input file, for sidecars (.hdr, .txt) beside it; None for arrays.
    width_px : the image width in pixels (Zeiss records the field width, not the pixel size).
    pixel_size_m : the user's value in metres; it wins over the file's, with a warning if they differ.
    """
    inp = _Inputs(metadata, tiff_tags, Path(path) if path else None, width_px)
    warnings: list[str] = []
    metres, provenance = None, "none"
    for reader in READERS:
        found = reader(inp, warnings)
        if found is not None and _plausible(found[0], found[1], warnings):
            metres, provenance = float(found[0]), found[1]
            break
    if pixel_size_m is not None:
        if metres and abs(metres / pixel_size_m - 1) > 0.01:
            warnings.append(Text(
                f"`pixel_size` {format_length(pixel_size_m)} (given by the user) overrides {format_length(metres)} from {provenance}."
            ))
        metres, provenance = pixel_size_m, USER_GIVEN
    if metres is None and ("dpi_not_physical" in metadata or 282 in tiff_tags):
        warnings.append(Decision("the file's dpi/resolution tag is not a physical pixel size and was ignored."))
    return PixelSize(metres, provenance, tuple(warnings))


def scale_sentence(pixel_size_m: float, source_px_per_print_mm: float) -> str:
    """'1 mm on the print = 0.42 µm in the sample (magnification 2,380×)'."""
    sample_per_mm = pixel_size_m * source_px_per_print_mm
    magnification = 1e-3 / sample_per_mm
    mag = f"{magnification:,.0f}" if magnification >= 100 else f"{magnification:.3g}"
    return f"1 mm on the print = {format_length(sample_per_mm)} in the sample (magnification {mag}×)"
