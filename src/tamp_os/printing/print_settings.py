"""The print settings a lithograph is designed for, written into its 3MF in the two slicer dialects
that read settings from a 3MF:

- PrusaSlicer: Metadata/Slic3r_PE.config, its own config as G-code-style comment lines
  (`; layer_height = 0.12`). PrusaSlicer (GUI and command line) applies it when it opens the
  3MF; checked with the real PrusaSlicer in tests/test_print_settings.py.
- Bambu Studio and OrcaSlicer: Metadata/project_settings.config, one JSON object with the header
  keys "name", "from" and "version" and every option as text (lists as lists of text), in their
  own option names (wall_loops, sparse_infill_density, initial_layer_print_height, ...), as their
  ConfigBase::save_to_json writes it (read from their source, not run: neither installs here).
  OrcaSlicer loads it from any 3MF it reads with its own importer; Bambu Studio loads project
  settings only from a 3MF whose Application metadata says Bambu Studio wrote it, which ours do
  not claim, so Bambu Studio opens the geometry and the user picks the 0.12 mm process by hand
  (the description says so).

Both are plain bytes computed from the settings only, so the 3MF stays byte-reproducible.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

# The print the reliefs are designed for (the reference's advice): 15 % gyroid, 2 perimeters,
# 3 top and 3 bottom solid layers, a 0.2 mm first layer, no supports.
INFILL = 0.15
INFILL_PATTERN = "gyroid"
PERIMETERS = 2
TOP_LAYERS = 3
BOTTOM_LAYERS = 3
FIRST_LAYER_MM = 0.2

PRUSA_CONFIG = "/Metadata/Slic3r_PE.config"
BAMBU_PROJECT_SETTINGS = "/Metadata/project_settings.config"
BAMBU_SETTINGS_VERSION = "01.00.00.00"  # our own layout version of the file, not a slicer version


def first_layer_mm(layer_mm: float, nozzle_mm: float) -> float:
    """The first layer: 0.2 mm, but never thinner than a layer nor thicker than 3/4 of the nozzle."""
    return max(layer_mm, min(FIRST_LAYER_MM, 0.75 * nozzle_mm))


def _num(value: float) -> str:
    return f"{value:g}"


@dataclass(frozen=True)
class PrintSettings:
    """Everything the slicer needs to print the relief as designed. Lengths in mm."""

    layer_mm: float
    nozzle_mm: float
    printer: str  # the profile's name, for the comment line
    bed_mm: tuple[float, float] | None = None  # the printer's bed, when known
    bambu_model: str | None = None  # Bambu Studio's printer_model, for a Bambu Lab printer
    prusa_options: dict[str, str] = field(default_factory=dict)  # a PrusaSlicer system preset, resolved

    @property
    def first_layer_mm(self) -> float:
        return first_layer_mm(self.layer_mm, self.nozzle_mm)

    def prusa_options_all(self) -> dict[str, str]:
        """PrusaSlicer's option values: the system preset's (when the printer has one installed), ours on top."""
        ours = {
            "layer_height": _num(self.layer_mm),
            "first_layer_height": _num(self.first_layer_mm),
            "perimeters": str(PERIMETERS),
            "top_solid_layers": str(TOP_LAYERS),
            "bottom_solid_layers": str(BOTTOM_LAYERS),
            "fill_density": f"{INFILL * 100:g}%",
            "fill_pattern": INFILL_PATTERN,
            "support_material": "0",
            "nozzle_diameter": _num(self.nozzle_mm),
        }
        if self.bed_mm and "bed_shape" not in self.prusa_options:
            w, d = self.bed_mm
            ours["bed_shape"] = f"0x0,{_num(w)}x0,{_num(w)}x{_num(d)},0x{_num(d)}"
        return {**self.prusa_options, **ours}

    def prusa_config(self) -> bytes:
        """Metadata/Slic3r_PE.config: a comment line, then `; key = value` lines in key order."""
        lines = [f"; print settings for {self.printer}, written by TAMP-OS", ""]
        lines += [f"; {key} = {value}" for key, value in sorted(self.prusa_options_all().items())]
        return ("\n".join(lines) + "\n").encode("utf-8")

    def bambu_options(self) -> dict[str, object]:
        """Bambu Studio / OrcaSlicer option values (text, per-extruder options as lists of text)."""
        options: dict[str, object] = {
            "layer_height": _num(self.layer_mm),
            "initial_layer_print_height": _num(self.first_layer_mm),
            "wall_loops": str(PERIMETERS),
            "top_shell_layers": str(TOP_LAYERS),
            "bottom_shell_layers": str(BOTTOM_LAYERS),
            "sparse_infill_density": f"{INFILL * 100:g}%",
            "sparse_infill_pattern": INFILL_PATTERN,
            "enable_support": "0",
            "nozzle_diameter": [_num(self.nozzle_mm)],
        }
        if self.bed_mm:
            w, d = (_num(v) for v in self.bed_mm)
            options["printable_area"] = ["0x0", f"{w}x0", f"{w}x{d}", f"0x{d}"]
        if self.bambu_model:
            options["printer_model"] = self.bambu_model
        return options

    def bambu_project_settings(self) -> bytes:
        """Metadata/project_settings.config: the header keys, then the options, keys sorted."""
        data = {"from": "project", "name": "project_settings", "version": BAMBU_SETTINGS_VERSION, **self.bambu_options()}
        return (json.dumps(data, indent=4, sort_keys=True, ensure_ascii=False) + "\n").encode("utf-8")

    def sentence(self, in_3mf: bool = True) -> str:
        """How to print it: what the 3MF carries and who reads it, or the settings to choose by hand."""
        settings = (f"{self.layer_mm:g} mm layers, a {self.first_layer_mm:g} mm first layer, {PERIMETERS} perimeters, "
                    f"{INFILL:.0%} infill and no supports")
        if not in_3mf:
            return f"Print it with {settings}."
        return (f"The 3MF file carries its print settings: {settings}; PrusaSlicer and OrcaSlicer apply them when they "
                f"open it, in Bambu Studio choose the {self.layer_mm:g} mm layer height yourself.")


def settings_for(profile, material: str = "PLA") -> PrintSettings:
    """The print settings for a printers.PrinterProfile (with the user's nozzle and layer applied): its
    bed and Bambu model from the printer table, and, when it names a PrusaSlicer system preset that is
    installed, that preset's printer, print and `material` filament options under ours."""
    from ..errors import ParameterError

    options: dict[str, str] = {}
    bed = getattr(profile, "bed_mm", None)
    if profile.prusa_preset:
        from .prusa_presets import preset_config

        try:
            resolved = preset_config(profile.prusa_preset, material)
        except ParameterError:  # PrusaSlicer (or this preset) not installed here: our settings alone
            resolved = None
        if resolved is not None and abs(resolved.printer.nozzle_mm - profile.nozzle_mm) < 1e-6:
            options = dict(resolved.options)
            bed = bed or resolved.printer.bed_mm
    return PrintSettings(layer_mm=profile.layer_mm, nozzle_mm=profile.nozzle_mm, printer=profile.name,
                         bed_mm=tuple(bed) if bed else None, bambu_model=getattr(profile, "bambu_model", None),
                         prusa_options=options)


def resin_sentence(profile, relief_mm: float) -> str:
    """How to print the relief on a resin printer: its layer, flat on the platform, no supports."""
    levels = int(relief_mm / profile.layer_mm + 1e-9)
    return (f"Print it on a resin printer with {profile.layer_mm:g} mm layers ({levels} height levels in the relief), "
            "flat on the build platform with its base down, without supports, pad or hollowing; wash and cure it as the "
            "resin's maker says before it is handled.")
