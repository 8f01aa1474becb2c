"""Physical pixel size and info-band rows from vendor metadata, with where each came from.

Each reader returns a length in metres or None; a value that is missing, unparsable, zero,
negative or absurd is skipped with a warning, and the next source is tried. Plain TIFF
resolution (72 or 96 dpi from SEM vendors) is never taken as a physical size.
"""

from __future__ import annotations

import configparser
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from ..units import format_length, unit_factor_m

PLAUSIBLE_M = (1e-13, 1e-2)  # 0.1 pm to 1 cm per pixel


@dataclass
class Scale:
    pixel_size_m: float | None = None
    source: str = "none"
    crop_top: int = 0
    crop_bottom: int = 0
    crop_source: str = ""
    warnings: list[str] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {
            "pixel_size_m": self.pixel_size_m,
            "pixel_size_source": self.source,
            "crop": {"top_rows": self.crop_top, "bottom_rows": self.crop_bottom, "left_columns": 0, "right_columns": 0,
                     "source": self.crop_source or None},
        }


def _number(value) -> float | None:
    try:
        number = float(str(value).strip().split()[0]) if isinstance(value, str) else float(value)
    except (TypeError, ValueError, IndexError):
        return None
    return number if math.isfinite(number) else None


def _accept(value_m, source: str, scale: Scale) -> bool:
    """Take `value_m` if it is a sane pixel size; otherwise say why and keep looking."""
    if value_m is None:
        scale.warnings.append(f"{source}: present but not a number; ignored.")
        return False
    if not PLAUSIBLE_M[0] <= value_m <= PLAUSIBLE_M[1]:
        scale.warnings.append(f"{source}: pixel size {value_m:g} m is zero, negative or implausible; ignored.")
        return False
    scale.pixel_size_m, scale.source = float(value_m), source
    return True


def _fei(meta, scale: Scale, height: int) -> bool:
    fei = meta.get("fei_metadata")
    if not fei:
        return False
    rows = _number(fei.get("Image", {}).get("ResolutionY"))
    if rows and 0 < rows < height:
        scale.crop_bottom, scale.crop_source = height - int(rows), "FEI [Image] ResolutionY"
    width = fei.get("Scan", {}).get("PixelWidth")
    return width is not None and _accept(_number(width), "FEI [Scan] PixelWidth", scale)


def _zeiss(meta, scale: Scale, width_px: int) -> bool:
    sem = meta.get("sem_metadata")
    if not sem or "ap_width" not in sem:
        return False
    entry = sem["ap_width"]  # ('Width', 2.677, 'mm')
    try:
        value, unit = _number(entry[1]), unit_factor_m(str(entry[2]))
    except (IndexError, TypeError):
        value, unit = None, None
    size = value * unit / width_px if value is not None and unit else None
    return _accept(size, "Zeiss SmartSEM ap_width ÷ image width", scale)


def _ini_sections(text: str) -> dict:
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str
    try:
        parser.read_string(text)
    except configparser.Error:
        return {}
    return {s: dict(parser[s]) for s in parser.sections()}


def _tescan(meta, path: Path | None, scale: Scale) -> bool:
    text = meta.get("_tiff_tags", {}).get(50431)
    where = "TESCAN tag 50431"
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    if not (isinstance(text, str) and "[MAIN]" in text) and path is not None:
        sidecar = path.with_suffix(".hdr")
        if sidecar.is_file():
            text, where = sidecar.read_text(encoding="utf-8", errors="replace"), f"TESCAN sidecar {sidecar.name}"
    if not (isinstance(text, str) and "[MAIN]" in text):
        return False
    main = _ini_sections(text).get("MAIN", {})
    strip = _number(main.get("ImageStripSize"))
    if strip and strip > 0:
        scale.crop_bottom, scale.crop_source = int(strip), f"{where} ImageStripSize"
    return _accept(_number(main.get("PixelSizeX")), f"{where} [MAIN] PixelSizeX", scale)


def _sidecar_txt(path: Path | None, scale: Scale) -> bool:
    """JEOL SEM ($$SM_MICRON_BAR / $$SM_MICRON_MARKER) and Hitachi (PixelSize= in nm) sidecars."""
    if path is None:
        return False
    sidecar = path.with_suffix(".txt")
    if not sidecar.is_file():
        return False
    text = sidecar.read_text(encoding="utf-8", errors="replace")
    hitachi = re.search(r"^\s*PixelSize\s*=\s*(\S+)", text, re.M)
    if hitachi:
        nm = _number(hitachi.group(1))
        return _accept(None if nm is None else nm * 1e-9, f"Hitachi sidecar {sidecar.name} PixelSize (nm)", scale)
    bar = re.search(r"^\s*\$+SM_MICRON_BAR\s+(\S+)", text, re.M)
    marker = re.search(r"^\s*\$+SM_MICRON_MARKER\s+([0-9.]+)\s*([a-zA-Zµμ]+)", text, re.M)
    if bar and marker:
        pixels, length = _number(bar.group(1)), _number(marker.group(1))
        unit = unit_factor_m(marker.group(2))
        size = length * unit / pixels if pixels and length and unit else None
        return _accept(size, f"JEOL sidecar {sidecar.name} SM_MICRON_MARKER ÷ SM_MICRON_BAR", scale)
    return False


def _imagej(meta, scale: Scale) -> bool:
    ij = meta.get("imagej_metadata")
    if not ij or "unit" not in ij:
        return False
    unit = unit_factor_m(str(ij["unit"]).replace("\\u00B5", "µ"))
    res = meta.get("_tiff_tags", {}).get(282)  # XResolution: pixels per unit
    if unit is None or res is None:
        return False
    try:
        per_unit = res[0] / res[1] if isinstance(res, tuple) else float(res)
    except (TypeError, ZeroDivisionError, IndexError):
        per_unit = 0
    size = unit / per_unit if per_unit and per_unit > 0 else None
    return _accept(size, f"ImageJ resolution ({ij['unit']})", scale)


def _ome(meta, scale: Scale) -> bool:
    xml = meta.get("ome_metadata")
    if not xml:
        return False
    try:
        root = ET.fromstring(xml)
    except ET.ParseError:
        scale.warnings.append("OME-XML: cannot be parsed; ignored.")
        return False
    pixels = next((el for el in root.iter() if el.tag.endswith("}Pixels") or el.tag == "Pixels"), None)
    if pixels is None or "PhysicalSizeX" not in pixels.attrib:
        return False
    unit = unit_factor_m(pixels.attrib.get("PhysicalSizeXUnit", "µm"))
    value = _number(pixels.attrib["PhysicalSizeX"])
    return _accept(value * unit if value is not None and unit else None, "OME PhysicalSizeX", scale)


def _dm(meta, scale: Scale) -> bool:
    axes = meta.get("dm_axes")
    if not axes:
        return False
    x = axes[-1]
    unit = unit_factor_m(str(x.get("units", "")))
    value = _number(x.get("scale"))
    if unit is None:
        scale.warnings.append(f"DigitalMicrograph: axis unit {x.get('units')!r} is not a length; no scale.")
        return False
    return _accept(value * unit if value is not None else None, "DigitalMicrograph calibration", scale)


def read_scale(metadata: dict, path: str | None, width_px: int, height_px: int, override_m: float | None = None) -> Scale:
    """The pixel size and info-band crop recorded by the microscope, or given by the user."""
    scale = Scale()
    p = Path(path) if path else None
    _fei(metadata, scale, height_px) or _zeiss(metadata, scale, width_px) or _tescan(metadata, p, scale) or _sidecar_txt(
        p, scale
    ) or _imagej(metadata, scale) or _ome(metadata, scale) or _dm(metadata, scale)
    if override_m is not None:
        if scale.pixel_size_m and abs(scale.pixel_size_m / override_m - 1) > 0.01:
            scale.warnings.append(
                f"--pixel-size {format_length(override_m)} overrides {format_length(scale.pixel_size_m)} from {scale.source}."
            )
        scale.pixel_size_m, scale.source = override_m, "--pixel-size"
    has_dpi = "dpi_not_physical" in metadata or 282 in metadata.get("_tiff_tags", {})
    if scale.pixel_size_m is None and has_dpi:
        scale.warnings.append("the file's dpi/resolution tag is not a physical pixel size and was ignored.")
    return scale


def scale_sentence(pixel_size_m: float, source_px_per_print_mm: float) -> str:
    """'1 mm on the print = 0.42 µm in the sample (magnification 2,380×)'."""
    sample_per_mm = pixel_size_m * source_px_per_print_mm
    magnification = 1e-3 / sample_per_mm
    mag = f"{magnification:,.0f}" if magnification >= 100 else f"{magnification:.3g}"
    return f"1 mm on the print = {format_length(sample_per_mm)} in the sample (magnification {mag}×)"
