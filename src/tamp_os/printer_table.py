"""Today's printers: bed, nozzle and usual layer heights of printers found in classrooms, each with
the vendor's specification page it comes from, and their names as people type them.

A row is a fact table, not a slicer profile: it sizes the print (width to fit the bed), decides
tiling (bed), fills the print settings inside the 3MF, and names the PrusaSlicer system preset
the installed PrusaSlicer has for it (Debian's PrusaSlicer 2.5 predates the MK4, CORE One and
XL, so only printers whose preset is really installed get G-code; see `installed_preset`).
The layer heights are the vendor's own slicer profiles for the stock 0.4 mm nozzle.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass

PRUSA_LAYERS_MM = (0.05, 0.07, 0.10, 0.15, 0.20, 0.25, 0.30)  # PrusaSlicer's MK4/MK4S/CORE One/XL print profiles
PRUSA_MINI_LAYERS_MM = (0.05, 0.07, 0.10, 0.15, 0.20, 0.25)  # PrusaSlicer's MINI print profiles
MK3_LAYERS_MM = (0.05, 0.07, 0.10, 0.15, 0.20, 0.30)  # PrusaSlicer's MK3S/MK3.9 print profiles
BAMBU_LAYERS_MM = (0.08, 0.12, 0.16, 0.20, 0.24, 0.28)  # Bambu Studio's process profiles, 0.4 mm nozzle
CREALITY_LAYERS_MM = (0.12, 0.16, 0.20, 0.24, 0.28)  # Creality Print's profiles, 0.4 mm nozzle


@dataclass(frozen=True)
class PrinterModel:
    """One printer as its vendor specifies it (stock 0.4 mm nozzle)."""

    vendor: str
    model: str  # the vendor's name for it
    short_names: tuple[str, ...]  # what people type: 'mk4', 'a1 mini'
    bed_mm: tuple[float, float, float]  # build volume: width (x), depth (y), height (z)
    layers_mm: tuple[float, ...]  # the usual layer heights (the vendor slicer's profiles)
    source: str  # the vendor's specification page for bed and nozzle
    nozzle_mm: float = 0.4
    prusa_presets: tuple[str, ...] = ()  # PrusaSlicer system preset names for it, newest bundle first
    bambu_model: str | None = None  # printer_model in Bambu Studio / OrcaSlicer project settings

    @property
    def name(self) -> str:
        return self.model

    def width_mm(self, default_mm: float = 100.0) -> float:
        """A default print width that fits the bed with 10 mm to spare on each side (at most `default_mm`)."""
        return min(default_mm, min(self.bed_mm[:2]) - 20.0)

    def line(self) -> str:
        w, d, h = self.bed_mm
        layers = f"{min(self.layers_mm):g}–{max(self.layers_mm):g}"
        return f"{self.model} ({self.vendor}): bed {w:g} × {d:g} × {h:g} mm, nozzle {self.nozzle_mm:g} mm, layers {layers} mm"


PRINTERS: tuple[PrinterModel, ...] = (
    PrinterModel("Prusa Research", "Original Prusa MK4S", ("mk4s", "prusa mk4s"), (250, 210, 220), PRUSA_LAYERS_MM,
                 "https://www.prusa3d.com/product/original-prusa-mk4s-3d-printer-5/",
                 prusa_presets=("Original Prusa MK4S", "Original Prusa MK4S 0.4 nozzle")),
    PrinterModel("Prusa Research", "Original Prusa MK4", ("mk4", "prusa mk4"), (250, 210, 220), PRUSA_LAYERS_MM,
                 "https://www.prusa3d.com/product/original-prusa-mk4-2/",
                 prusa_presets=("Original Prusa MK4", "Original Prusa MK4 0.4 nozzle", "Original Prusa MK4 Input Shaper 0.4 nozzle")),
    PrinterModel("Prusa Research", "Original Prusa MK3.9", ("mk3.9", "mk3.9s", "prusa mk3.9"), (250, 210, 210), MK3_LAYERS_MM,
                 "https://www.prusa3d.com/product/original-prusa-mk3s-to-mk3-9-upgrade-kit/",
                 prusa_presets=("Original Prusa MK3.9", "Original Prusa MK3.9 0.4 nozzle")),
    PrinterModel("Prusa Research", "Prusa CORE One", ("core one", "coreone", "prusa core one"), (250, 220, 270), PRUSA_LAYERS_MM,
                 "https://www.prusa3d.com/product/prusa-core-one/",
                 prusa_presets=("Prusa CORE One", "Prusa CORE One 0.4 nozzle")),
    PrinterModel("Prusa Research", "Original Prusa MINI+", ("mini", "mini+", "prusa mini", "prusa mini+"), (180, 180, 180),
                 PRUSA_MINI_LAYERS_MM, "https://www.prusa3d.com/product/original-prusa-mini-semi-assembled-3d-printer-4/",
                 prusa_presets=("Original Prusa MINI & MINI+",)),
    PrinterModel("Prusa Research", "Original Prusa XL", ("xl", "prusa xl"), (360, 360, 360), PRUSA_LAYERS_MM,
                 "https://www.prusa3d.com/product/original-prusa-xl-2/",
                 prusa_presets=("Original Prusa XL", "Original Prusa XL 0.4 nozzle")),
    PrinterModel("Bambu Lab", "Bambu Lab A1", ("a1", "bambu a1"), (256, 256, 256), BAMBU_LAYERS_MM,
                 "https://bambulab.com/en/a1/tech-specs", bambu_model="Bambu Lab A1"),
    PrinterModel("Bambu Lab", "Bambu Lab A1 mini", ("a1 mini", "a1mini", "bambu a1 mini"), (180, 180, 180), BAMBU_LAYERS_MM,
                 "https://bambulab.com/en/a1-mini/tech-specs", bambu_model="Bambu Lab A1 mini"),
    PrinterModel("Bambu Lab", "Bambu Lab P1S", ("p1s", "bambu p1s"), (256, 256, 256), BAMBU_LAYERS_MM,
                 "https://bambulab.com/en/p1/tech-specs", bambu_model="Bambu Lab P1S"),
    PrinterModel("Bambu Lab", "Bambu Lab X1 Carbon", ("x1c", "x1 carbon", "bambu x1c", "bambu lab x1c"), (256, 256, 256),
                 BAMBU_LAYERS_MM, "https://bambulab.com/en/x1/tech-specs", bambu_model="Bambu Lab X1 Carbon"),
    PrinterModel("Creality", "Creality Ender-3 V3 SE", ("ender-3 v3 se", "ender 3 v3 se"), (220, 220, 250), CREALITY_LAYERS_MM,
                 "https://www.creality.com/products/ender-3-v3-se"),
    PrinterModel("Creality", "Creality K1C", ("k1c", "creality k1c"), (220, 220, 250), CREALITY_LAYERS_MM,
                 "https://www.creality.com/products/creality-k1c"),
    PrinterModel("Creality", "Creality Ender-3 V2", ("ender-3 v2", "ender 3 v2"), (220, 220, 250), CREALITY_LAYERS_MM,
                 "https://www.creality.com/products/ender-3-v2-3d-printer-csco",
                 prusa_presets=("Creality Ender-3 V2 (0.4 mm nozzle)",)),
    PrinterModel("Elegoo", "Elegoo Neptune 4 Pro", ("neptune 4 pro", "elegoo neptune 4 pro"), (225, 225, 265), CREALITY_LAYERS_MM,
                 "https://www.elegoo.com/products/elegoo-neptune-4-pro-fdm-3d-printer"),
)

# Vendor names as people type them ("prusa"), and PrusaSlicer's bundle ids.
VENDOR_ALIASES = {
    "prusa": "Prusa Research", "prusaresearch": "Prusa Research", "prusa research": "Prusa Research",
    "bambu": "Bambu Lab", "bambulab": "Bambu Lab", "bambu lab": "Bambu Lab", "bbl": "Bambu Lab",
    "creality": "Creality", "elegoo": "Elegoo",
}


def _key(text: str) -> str:
    """A name folded for matching: lower case, 'original'/'the' dropped, runs of spaces and dashes as one space."""
    text = re.sub(r"[\s_\-]+", " ", text.strip().lower())
    text = re.sub(r"^(original |the )", "", text)
    return text.replace("bambu lab ", "bambu ").replace("prusa research ", "prusa ")


def _names(p: PrinterModel) -> set[str]:
    """Every name the printer answers to: its model, its short forms and its PrusaSlicer preset names."""
    return {_key(p.model), *(_key(s) for s in p.short_names), *(_key(s) for s in p.prusa_presets)}


def find_printer(name: str) -> PrinterModel | None:
    """The table's printer called `name` (case-insensitive, short forms such as 'mk4' or 'a1 mini'), or None."""
    key = _key(name)
    for p in PRINTERS:
        if key in _names(p):
            return p
    return None


def close_names(name: str, n: int = 3) -> list[str]:
    """Model names of the table close to `name`, for an error message."""
    every = {s: p.model for p in PRINTERS for s in _names(p)}
    return list(dict.fromkeys(every[c] for c in difflib.get_close_matches(_key(name), list(every), n=n, cutoff=0.6)))


def vendor_name(text: str) -> str:
    """The table's vendor for what the user typed ('prusa' -> 'Prusa Research'); the text itself otherwise."""
    return VENDOR_ALIASES.get(_key(text), text)


def printers_of(vendor: str | None) -> list[PrinterModel]:
    """The table's printers of `vendor` (any spelling VENDOR_ALIASES knows, case-insensitive), or all."""
    if not vendor:
        return list(PRINTERS)
    wanted = vendor_name(vendor).lower()
    return [p for p in PRINTERS if p.vendor.lower() == wanted or p.vendor.lower().startswith(_key(vendor))]


def installed_preset(printer: PrinterModel) -> str | None:
    """The first of the printer's PrusaSlicer system presets that the installed PrusaSlicer bundles hold."""
    if not printer.prusa_presets:
        return None
    from .prusa_presets import system_printers

    have = {p.name.lower(): p.name for p in system_printers()}
    return next((have[n.lower()] for n in printer.prusa_presets if n.lower() in have), None)


def design_layer_mm(printer: PrinterModel, wanted_mm: float = 0.12) -> float:
    """The layer height to design for: `wanted_mm` (0.12 mm gives 25 levels in a 3 mm relief) when it lies
    within the printer's usual range, else the usual height closest to it."""
    if min(printer.layers_mm) <= wanted_mm <= max(printer.layers_mm):
        return wanted_mm
    return min(printer.layers_mm, key=lambda v: (abs(v - wanted_mm), v))
