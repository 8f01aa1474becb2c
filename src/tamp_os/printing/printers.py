"""Printer profiles and the Low/Medium/High presets derived from them.

A preset fixes the output grid from the nozzle: Low = one pixel per 2 nozzle widths, Medium =
one per nozzle width (the default), High = one per half nozzle width. Unlike the reference we do
not round to powers of two or cap at 512 px; adaptive meshing keeps large grids printable.

A resin printer has no nozzle: its profile's `nozzle_mm` holds its feature width instead (4 of its
pixels or laser spots, at least 0.2 mm: printer_table.feature_mm), and the same rule applies to it, so
its grid follows its XY resolution down to 0.1 mm a grid point at High, where a finger stops telling
the difference.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import ParameterError


@dataclass(frozen=True)
class PrinterProfile:
    name: str
    nozzle_mm: float
    layer_mm: float
    width_mm: float
    description: str = ""
    prusa_preset: str | None = None  # a PrusaSlicer system printer preset: slice with its bed and firmware
    bed_mm: tuple[float, float] | None = None  # the bed (width, depth), when known: print width and tiles fit it
    bambu_model: str | None = None  # Bambu Studio's printer_model, for the 3MF's project settings
    technology: str = "FDM"  # FDM, or a resin printer's MSLA / SLA (then nozzle_mm is its feature width)
    layers_mm: tuple[float, float] | None = None  # the thinnest and thickest layer it makes, when known

    @property
    def is_resin(self) -> bool:
        return self.technology != "FDM"

    def with_overrides(self, nozzle_mm: float | None = None, layer_mm: float | None = None) -> "PrinterProfile":
        """This profile with the user's nozzle and layer, where given: the numbers a print uses."""
        return dataclasses.replace(self, nozzle_mm=nozzle_mm or self.nozzle_mm, layer_mm=layer_mm or self.layer_mm)

    def as_dict(self) -> dict:
        """The profile's fields; the resin ones only for a resin printer (a nozzle printer's recipe stays as it was)."""
        data = dataclasses.asdict(self)
        if not self.is_resin:
            del data["technology"], data["layers_mm"]
        return data

    @classmethod
    def from_dict(cls, data: dict) -> "PrinterProfile":
        """A profile stored in a recipe; checked like a user profile."""
        return _profile_from_table(str(data.get("name", "recipe")), data, "the recipe")


BUILTIN_PRINTERS: dict[str, PrinterProfile] = {
    p.name: p
    for p in (
        PrinterProfile("standard", 0.4, 0.12, 100.0, "standard FDM, 0.4 mm nozzle"),
        PrinterProfile("fine", 0.2, 0.08, 80.0, "fine FDM, 0.2 mm nozzle"),
        PrinterProfile("large", 0.6, 0.20, 120.0, "large-nozzle FDM, 0.6 mm nozzle"),
    )
}

# Pixels per nozzle width, and the reference's blur in output pixels, per preset.
PRESETS: dict[str, tuple[float, float]] = {"low": (0.5, 2.0), "medium": (1.0, 1.2), "high": (2.0, 0.8)}


def user_profiles_path() -> Path:
    """Where user printer profiles live: $TAMP_PRINTERS, else ~/.config/tamp-os/printers.toml."""
    env = os.environ.get("TAMP_PRINTERS")
    if env:
        return Path(env)
    config = Path(os.environ.get("XDG_CONFIG_HOME", Path.home() / ".config"))
    return config / "tamp-os" / "printers.toml"


def load_user_profiles(path: Path | None = None) -> dict[str, PrinterProfile]:
    """Profiles from a TOML file with one table per printer:

        [my-prusa]
        nozzle_mm = 0.4
        layer_mm = 0.15
        width_mm = 120
    """
    path = path or user_profiles_path()
    if not path.is_file():
        return {}
    import tomllib

    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ParameterError(f"{path}: cannot read printer profiles ({exc}); fix or remove the file.") from exc
    return {name: _profile_from_table(name, table, path) for name, table in data.items()}


def _profile_from_table(name: str, table, where) -> PrinterProfile:
    if not isinstance(table, dict):
        raise ParameterError(f"{where}: [{name}] must be a table with 'nozzle_mm', 'layer_mm' and 'width_mm'.")
    try:
        profile = PrinterProfile(
            name=name,
            nozzle_mm=float(table["nozzle_mm"]),
            layer_mm=float(table["layer_mm"]),
            width_mm=float(table.get("width_mm", 100.0)),
            description=str(table.get("description", "user profile")),
            prusa_preset=str(table["prusa_preset"]) if table.get("prusa_preset") else None,
            bed_mm=_bed(table.get("bed_mm")),
            bambu_model=str(table["bambu_model"]) if table.get("bambu_model") else None,
            technology=_technology(table.get("technology", "FDM")),
            layers_mm=_layers(table.get("layers_mm")),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ParameterError(
            f"{where}: [{name}] needs numbers 'nozzle_mm' and 'layer_mm' (and optionally 'width_mm'); problem: {exc}."
        ) from None
    if not (0.05 <= profile.nozzle_mm <= 2.0 and 0.005 <= profile.layer_mm <= 1.0 and 0 < profile.width_mm <= 1000):
        raise ParameterError(
            f"{where}: [{name}] 'nozzle_mm' must be 0.05–2.0, 'layer_mm' 0.005–1.0 and 'width_mm' 0–1000; "
            f"got {profile.nozzle_mm}, {profile.layer_mm}, {profile.width_mm}."
        )
    return profile


def _technology(value) -> str:
    """FDM, MSLA or SLA from a profile table or recipe (ValueError otherwise: reported by the caller)."""
    text = str(value).upper()
    if text not in ("FDM", "MSLA", "SLA"):
        raise ValueError(f"technology must be FDM, MSLA or SLA; got {value!r}")
    return text


def _layers(value) -> tuple[float, float] | None:
    """layers_mm from a profile table or recipe: [thinnest, thickest] in mm, or absent."""
    if value is None:
        return None
    low, high = (float(v) for v in value)
    if not 0.005 <= low <= high <= 1.0:
        raise ValueError(f"layers_mm must be two layer heights of 0.005–1.0 mm, thinnest first; got {value!r}")
    return low, high


def _bed(value) -> tuple[float, float] | None:
    """bed_mm from a profile table or recipe: [width, depth] in mm, or absent."""
    if value is None:
        return None
    width, depth = (float(v) for v in value)  # TypeError/ValueError: reported by the caller
    if not (0 < width <= 2000 and 0 < depth <= 2000):
        raise ValueError(f"bed_mm must be two sizes of 0–2000 mm; got {value!r}")
    return width, depth


def table_profile(name: str) -> PrinterProfile | None:
    """A profile for a printer of the printer table (printer_table.py), by any of its names, or None.

    Its layer is the one the reliefs are designed for (0.12 mm) where the printer's usual range holds
    it; its print width fits the bed; its PrusaSlicer preset is set only when the installed
    PrusaSlicer has one (then G-code is for that printer)."""
    from .printer_table import design_layer_mm, feature_mm, find_printer, installed_preset

    model = find_printer(name)
    if model is None:
        return None
    if model.is_resin:
        return _resin_profile(model, design_layer_mm(model), feature_mm(model))
    preset = installed_preset(model)
    where = f"PrusaSlicer system preset {preset!r}" if preset else "no PrusaSlicer preset installed here: G-code for estimates only"
    return PrinterProfile(model.model, model.nozzle_mm, design_layer_mm(model), model.width_mm(),
                          f"{model.vendor}, bed {model.bed_mm[0]:g} × {model.bed_mm[1]:g} mm ({where})", preset,
                          (float(model.bed_mm[0]), float(model.bed_mm[1])), model.bambu_model)


def _resin_profile(model, layer_mm: float, feature_mm: float) -> PrinterProfile:
    """A resin printer of the table as a profile: its feature width in `nozzle_mm`, its build area as the bed."""
    from .printer_table import sla_preset

    spot = "laser spot" if model.technology == "SLA" else "pixels"
    outputs = (f"slicing writes a .sl1s print file with PrusaSlicer's {sla_preset(model)!r}" if sla_preset(model)
               else "no slicer here: print the STL or 3MF from the vendor's own slicer")
    return PrinterProfile(model.model, feature_mm, layer_mm, model.width_mm(),
                          f"{model.vendor}, {model.technology} resin, build {model.bed_mm[0]:g} × {model.bed_mm[1]:g} mm, "
                          f"{spot} {model.xy_mm:g} mm, feature {feature_mm:g} mm ({outputs})", None,
                          (float(model.bed_mm[0]), float(model.bed_mm[1])), None, model.technology,
                          (float(model.layers_mm[0]), float(model.layers_mm[1])))


def all_printers() -> dict[str, PrinterProfile]:
    """The built-in profiles and the user's (read once per version of the user's file)."""
    path = user_profiles_path()
    try:
        stamp = path.stat().st_mtime_ns
    except OSError:
        stamp = None
    return {**BUILTIN_PRINTERS, **_user_profiles_cached(path, stamp)}


@functools.lru_cache(maxsize=4)
def _user_profiles_cached(path: Path, stamp: int | None) -> dict[str, PrinterProfile]:
    return load_user_profiles(path) if stamp is not None else {}


def get_printer(name: str) -> PrinterProfile:
    printers = all_printers()
    if name not in printers:
        from .printer_table import close_names
        from .prusa_presets import bundles, system_printer_profile

        table = table_profile(name)
        if table is not None:
            return table
        close = close_names(name)
        if bundles():  # a PrusaSlicer system preset; its error lists close names unless the table has some
            try:
                return PrinterProfile(*system_printer_profile(name))
            except ParameterError:
                if not close:
                    raise
        hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
        raise ParameterError(
            f"`printer`: unknown printer {name!r}.{hint} Choose one of {', '.join(sorted(printers))} or a printer of the "
            f"printers command, or add yours to {user_profiles_path()}."
        )
    return printers[name]


def preset_resolution_px(preset: str, nozzle_mm: float, width_mm: float) -> int:
    """Grid columns for a preset: width divided by the preset's pixel pitch, at least 2."""
    per_nozzle, _ = PRESETS[preset]
    return max(2, round(width_mm * per_nozzle / nozzle_mm))


def preset_blur_px(preset: str) -> float:
    return PRESETS[preset][1]


def height_levels(relief_mm: float, layer_mm: float) -> int:
    """Distinct heights a printer can make in the relief: relief / layer height (3.0 / 0.12 = 25)."""
    return int(math.floor(relief_mm / layer_mm + 1e-9))


def grid_triangles(nx: int, ny: int) -> int:
    """Triangles of the full-grid solid: top grid, four walls, bottom fan over the outline."""
    perimeter_edges = 2 * ((nx - 1) + (ny - 1))
    return 2 * (nx - 1) * (ny - 1) + 2 * perimeter_edges + perimeter_edges


# Typical adaptive/grid triangle ratio for micrographs at half a layer of error (see
# benchmarks/bench_adaptive.py); used only when no image is given to measure it.
ADAPTIVE_RATIO = 1 / 15


def estimate_file_bytes(fmt: str, triangles: int, vertices: int) -> int | None:
    """Rough output size of a format (formats.py's table); None for 2-D graphics (not estimated)."""
    from ..formats import estimate_bytes

    return estimate_bytes(fmt, triangles, vertices)
