"""Today's printers: bed, nozzle and layer-height range of printers found in classrooms, each with
where those facts were checked, and their names as people type them.

A row is a fact table, not a slicer profile: it sizes the print (width to fit the bed), decides
tiling (bed), fills the print settings inside the 3MF, and names the PrusaSlicer system preset
the installed PrusaSlicer has for it (Debian's PrusaSlicer 2.5 predates the MK4, CORE One and
XL, so only printers whose preset is really installed get G-code; see `installed_preset`).

Every number was read from the vendor's own slicer profile for the stock 0.4 mm nozzle (the
machine has no web access, so the vendors' product pages were not read): the bed is the
profile's printable area (`bed_shape` / `printable_area`), the height its `max_print_height` /
`printable_height`, the layer range its `min_layer_height`..`max_layer_height`. A slicer's
printable height can be a few mm below the height a product page advertises (Bambu Lab's P1S and
X1 Carbon profiles say 250 mm); the slicer's number is the one a print must respect. A row whose
facts could not be checked says "not checked" in its source.

Resin printers (technology "MSLA": an LCD mask, or "SLA": a laser) have no nozzle: their row gives the
build volume, the XY pixel pitch (or laser spot) and the layer range, each from the vendor's
specification page (URL in the source; where the page could not be read here the source says
NOT_CHECKED and what the number rests on) or, for the SL1S, from the PrusaSlicer bundle that slices it.
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass

NOT_CHECKED = "not checked"

# Where the facts were read (repository, path, and the version read).
_PRUSA_INI = ("github.com/prusa3d/PrusaSlicer resources/profiles/PrusaResearch.ini "
              "(config_version 2.2.3, commit 31f9044e)")
_ORCA = "github.com/SoftFever/OrcaSlicer resources/profiles/"
_BBL_COMMON = (f"{_ORCA}BBL/machine/fdm_bbl_3dp_001_common.json (printable_area 256x256, printable_height 250, "
               "layers 0.08-0.28; the same in github.com/bambulab/BambuStudio's copy of that file)")


@dataclass(frozen=True)
class PrinterModel:
    """One printer as its vendor's slicer profile describes it (stock 0.4 mm nozzle)."""

    vendor: str
    model: str  # the vendor's name for it
    short_names: tuple[str, ...]  # what people type: 'mk4', 'a1 mini'
    bed_mm: tuple[float, float, float]  # printable volume: width (x), depth (y), height (z)
    layers_mm: tuple[float, float]  # (thinnest, thickest) layer the vendor's printer profile allows
    source: str  # where bed, nozzle and layers were checked (repository path or URL), or NOT_CHECKED
    nozzle_mm: float = 0.4
    prusa_presets: tuple[str, ...] = ()  # PrusaSlicer system preset names for it, the current one first
    bambu_model: str | None = None  # printer_model in Bambu Studio / OrcaSlicer project settings
    technology: str = "FDM"  # FDM (a nozzle), MSLA (an LCD mask) or SLA (a laser)
    xy_mm: float | None = None  # a resin printer's XY pixel pitch or laser spot

    @property
    def name(self) -> str:
        return self.model

    @property
    def is_resin(self) -> bool:
        return self.technology in RESIN_TECHNOLOGIES

    def width_mm(self, default_mm: float = 100.0) -> float:
        """A default print width that fits the bed with 10 mm to spare on each side (at most `default_mm`)."""
        return min(default_mm, min(self.bed_mm[:2]) - 20.0)

    def line(self) -> str:
        w, d, h = self.bed_mm
        layers = f"{min(self.layers_mm):g}–{max(self.layers_mm):g}"
        if self.is_resin:
            spot = "laser spot" if self.technology == "SLA" else "pixel"
            return (f"{self.model} ({self.vendor}, {self.technology} resin): build {w:g} × {d:g} × {h:g} mm, {spot} {self.xy_mm:g} mm, "
                    f"layers {layers} mm")
        return f"{self.model} ({self.vendor}): bed {w:g} × {d:g} × {h:g} mm, nozzle {self.nozzle_mm:g} mm, layers {layers} mm"


PRINTERS: tuple[PrinterModel, ...] = (
    PrinterModel("Prusa Research", "Original Prusa MK4S", ("mk4s", "prusa mk4s"), (250, 210, 220), (0.07, 0.30),
                 f"{_PRUSA_INI}: [printer:Original Prusa MK4S 0.4 nozzle], via MK4 Input Shaper 0.4 nozzle "
                 "(max_layer_height 0.30) from *commonMK4* (bed_shape 0x0,250x0,250x210,0x210, max_print_height 220, "
                 "min_layer_height 0.07, nozzle_diameter 0.4)",
                 prusa_presets=("Original Prusa MK4S 0.4 nozzle",)),
    PrinterModel("Prusa Research", "Original Prusa MK4", ("mk4", "prusa mk4"), (250, 210, 220), (0.07, 0.30),
                 f"{_PRUSA_INI}: [printer:Original Prusa MK4 Input Shaper 0.4 nozzle] (max_print_height 220, "
                 "max_layer_height 0.30) from *commonMK4* (bed_shape 0x0,250x0,250x210,0x210, min_layer_height 0.07)",
                 prusa_presets=("Original Prusa MK4 Input Shaper 0.4 nozzle", "Original Prusa MK4 0.4 nozzle")),
    PrinterModel("Prusa Research", "Original Prusa MK3.9", ("mk3.9", "mk3.9s", "prusa mk3.9"), (250, 210, 220), (0.07, 0.30),
                 f"{_PRUSA_INI}: [printer:Original Prusa MK3.9 0.4 nozzle] (max_print_height 220, max_layer_height 0.30) "
                 "from *commonMK4* (bed_shape 0x0,250x0,250x210,0x210, min_layer_height 0.07)",
                 prusa_presets=("Original Prusa MK3.9 0.4 nozzle",)),
    PrinterModel("Prusa Research", "Prusa CORE One", ("core one", "coreone", "prusa core one"), (250, 220, 270), (0.07, 0.30),
                 f"{_PRUSA_INI}: [printer:Prusa CORE One 0.4 nozzle] from [printer:Prusa CORE One HF0.4 nozzle] "
                 "(bed_shape 0x0,250x0,250x220,0x220, max_print_height 270, min_layer_height 0.07, max_layer_height 0.3)",
                 prusa_presets=("Prusa CORE One 0.4 nozzle",)),
    PrinterModel("Prusa Research", "Original Prusa MINI+", ("mini", "mini+", "prusa mini", "prusa mini+"), (180, 180, 180),
                 (0.07, 0.25),
                 f"{_PRUSA_INI}: [printer:Original Prusa MINI & MINI+] (bed_shape 0x0,180x0,180x180,0x180, "
                 "max_print_height 180, min_layer_height 0.07, max_layer_height 0.25) and its Input Shaper child; the same "
                 "in Debian's PrusaSlicer 2.5 bundle (/usr/share/PrusaSlicer/profiles/PrusaResearch.ini, config_version 1.5.1)",
                 prusa_presets=("Original Prusa MINI & MINI+ Input Shaper", "Original Prusa MINI & MINI+")),
    PrinterModel("Prusa Research", "Original Prusa XL", ("xl", "prusa xl"), (360, 360, 360), (0.07, 0.30),
                 f"{_PRUSA_INI}: [printer:Original Prusa XL Input Shaper 0.4 nozzle] (max_layer_height 0.30) from "
                 "*commonXLIS* and *commonXL* (bed_shape 0x0,360x0,360x360,0x360, max_print_height 360, min_layer_height 0.07)",
                 prusa_presets=("Original Prusa XL Input Shaper 0.4 nozzle",)),
    PrinterModel("Bambu Lab", "Bambu Lab A1", ("a1", "bambu a1"), (256, 256, 256), (0.08, 0.28),
                 f"{_ORCA}BBL/machine/Bambu Lab A1 0.4 nozzle.json (printer_model, nozzle 0.4, printable_height 256) "
                 f"on {_BBL_COMMON}", bambu_model="Bambu Lab A1"),
    PrinterModel("Bambu Lab", "Bambu Lab A1 mini", ("a1 mini", "a1mini", "bambu a1 mini"), (180, 180, 180), (0.08, 0.28),
                 f"{_ORCA}BBL/machine/Bambu Lab A1 mini 0.4 nozzle.json (printer_model, nozzle 0.4, printable_area 180x180, "
                 f"printable_height 180) on {_BBL_COMMON}", bambu_model="Bambu Lab A1 mini"),
    PrinterModel("Bambu Lab", "Bambu Lab P1S", ("p1s", "bambu p1s"), (256, 256, 250), (0.08, 0.28),
                 f"{_ORCA}BBL/machine/Bambu Lab P1S 0.4 nozzle.json (printer_model, nozzle 0.4) on {_BBL_COMMON}",
                 bambu_model="Bambu Lab P1S"),
    PrinterModel("Bambu Lab", "Bambu Lab X1 Carbon", ("x1c", "x1 carbon", "bambu x1c", "bambu lab x1c"), (256, 256, 250),
                 (0.08, 0.28),
                 f"{_ORCA}BBL/machine/Bambu Lab X1 Carbon 0.4 nozzle.json (printer_model, nozzle 0.4) on {_BBL_COMMON}",
                 bambu_model="Bambu Lab X1 Carbon"),
    PrinterModel("Creality", "Creality Ender-3 V3 SE", ("ender-3 v3 se", "ender 3 v3 se"), (220, 220, 250), (0.08, 0.36),
                 f"{_ORCA}Creality/machine/Creality Ender-3 V3 SE 0.4 nozzle.json (printable_area 220x220, "
                 "printable_height 250, nozzle 0.4, min_layer_height 0.08, max_layer_height 0.36)"),
    PrinterModel("Creality", "Creality K1C", ("k1c", "creality k1c"), (220, 220, 250), (0.08, 0.30),
                 f"{_ORCA}Creality/machine/Creality K1C 0.4 nozzle.json (printable_area 220x220, printable_height 250, "
                 "nozzle 0.4, min_layer_height 0.08, max_layer_height 0.3)"),
    # The PrusaSlicer bundle's bed (its preset slices the G-code) is 210 mm wide, 10 mm less than OrcaSlicer's
    # 220 x 220 (resources/profiles/Creality/machine/Creality Ender-3 V2 0.4 nozzle.json): the smaller one fits both.
    PrinterModel("Creality", "Creality Ender-3 V2", ("ender-3 v2", "ender 3 v2"), (210, 220, 250), (0.08, 0.32),
                 "PrusaSlicer's Creality bundle as Debian's prusa-slicer 2.5 installs it (/usr/share/PrusaSlicer/profiles/"
                 "Creality.ini, config_version 0.2.1): [printer:Creality Ender-3 V2 (0.4 mm nozzle)] (bed_shape "
                 "5x0,215x0,215x220,5x220, that is 210x220 printable, max_print_height 250, min_layer_height 0.08, max_layer_height 0.32, nozzle 0.4)",
                 prusa_presets=("Creality Ender-3 V2 (0.4 mm nozzle)",)),
    PrinterModel("Elegoo", "Elegoo Neptune 4 Pro", ("neptune 4 pro", "elegoo neptune 4 pro"), (230, 230, 265), (0.08, 0.28),
                 f"{_ORCA}Elegoo/machine/EN4SERIES/Elegoo Neptune 4 Pro 0.4 nozzle.json (printable_area 230x230, "
                 "printable_height 265, nozzle 0.4) on Elegoo Neptune 4 0.4 nozzle.json (min_layer_height 0.08, "
                 "max_layer_height 0.28)"),
)

RESIN_TECHNOLOGIES = ("MSLA", "SLA")
_SL1S_INI = ("PrusaSlicer's bundle as Debian's prusa-slicer 2.5 installs it (/usr/share/PrusaSlicer/profiles/PrusaResearch.ini, "
             "config_version 1.5.1)")

# Resin printers. Only the SL1S could be checked here (the PrusaSlicer bundle that slices it); the others give
# the vendor's specification page and say NOT_CHECKED: the machine has no web access and no stored copy of those
# pages was found, so their numbers are the vendors' published figures as known to us, to be checked there.
RESIN_PRINTERS: tuple[PrinterModel, ...] = (
    PrinterModel("Prusa Research", "Original Prusa SL1S SPEED", ("sl1s", "sl1s speed", "prusa sl1s"), (127, 80, 150),
                 (0.025, 0.1),
                 f"{_SL1S_INI}: [printer:Original Prusa SL1S SPEED] (bed_shape 0.5x0.5,127.5x0.5,127.5x80.5,0.5x80.5, "
                 "max_print_height 150, display_width 128 over display_pixels_x 2560, that is 0.05 mm pixels) and its print "
                 "presets 0.025 UltraDetail, 0.05 Normal and 0.1 Fast @SL1S (the layer range); product page "
                 "https://www.prusa3d.com/product/original-prusa-sl1s-speed-3d-printer/",
                 prusa_presets=("Original Prusa SL1S SPEED",), technology="MSLA", xy_mm=0.05),
    PrinterModel("Formlabs", "Formlabs Form 4", ("form 4", "form4", "formlabs form 4"), (200, 125, 210), (0.025, 0.2),
                 f"https://formlabs.com/3d-printers/form-4/tech-specs/ ({NOT_CHECKED} there: the build volume 200 × 125 × 210 mm, "
                 "50 µm pixels and 25–200 µm layers are as the VT Discovery Lab's printer page quotes the vendor, "
                 "github.com/VT-DISCO-LAB/Getting-Started-in-the-Discovery-Lab/wiki/SLA-Printing-%7C-Formlabs-Form-4; "
                 "its other page says 25–300 µm: the thickest layer is uncertain)",
                 technology="MSLA", xy_mm=0.05),
    PrinterModel("Formlabs", "Formlabs Form 3+", ("form 3+", "form 3", "form3", "formlabs form 3+"), (145, 145, 185),
                 (0.025, 0.3),
                 f"https://formlabs.com/3d-printers/form-3/tech-specs/ ({NOT_CHECKED}: build 145 × 145 × 185 mm, 85 µm laser "
                 "spot, 25–300 µm layers as the vendor publishes them)",
                 technology="SLA", xy_mm=0.085),
    PrinterModel("Elegoo", "Elegoo Saturn 4 Ultra", ("saturn 4 ultra", "elegoo saturn 4 ultra"), (218.88, 122.88, 220),
                 (0.01, 0.15),
                 f"https://www.elegoo.com/products/elegoo-saturn-4-ultra-resin-3d-printer ({NOT_CHECKED}: 12K LCD, build "
                 "218.88 × 122.88 × 220 mm, 19 × 24 µm pixels (the coarser 24 µm used), 0.01–0.15 mm layers)",
                 technology="MSLA", xy_mm=0.024),
    PrinterModel("Elegoo", "Elegoo Mars 5", ("mars 5", "elegoo mars 5"), (143.43, 89.6, 150), (0.01, 0.2),
                 f"https://www.elegoo.com/products/elegoo-mars-5-resin-3d-printer ({NOT_CHECKED}: 4K LCD of 4098 × 2560 "
                 "pixels of 35 µm, that is 143.43 × 89.6 mm, 150 mm high, 0.01–0.2 mm layers; the height and thickest layer "
                 "are uncertain)",
                 technology="MSLA", xy_mm=0.035),
    PrinterModel("Anycubic", "Anycubic Photon Mono M7", ("photon mono m7", "mono m7", "anycubic photon mono m7"),
                 (223, 126, 230), (0.01, 0.15),
                 f"https://www.anycubic.com/products/photon-mono-m7 ({NOT_CHECKED}: 10.1-inch 14K LCD, build 223 × 126 × 230 mm, "
                 "16.8 × 24.8 µm pixels (the coarser 24.8 µm used), 0.01–0.15 mm layers; uncertain, the M7 and M7 Pro "
                 "share most figures)",
                 technology="MSLA", xy_mm=0.0248),
)
ALL_PRINTERS: tuple[PrinterModel, ...] = PRINTERS + RESIN_PRINTERS  # nozzle printers first, then resin

# Vendor names as people type them ("prusa"), and PrusaSlicer's bundle ids.
VENDOR_ALIASES = {
    "prusa": "Prusa Research", "prusaresearch": "Prusa Research", "prusa research": "Prusa Research",
    "bambu": "Bambu Lab", "bambulab": "Bambu Lab", "bambu lab": "Bambu Lab", "bbl": "Bambu Lab",
    "creality": "Creality", "elegoo": "Elegoo", "formlabs": "Formlabs", "anycubic": "Anycubic",
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
    for p in ALL_PRINTERS:
        if key in _names(p):
            return p
    return None


def close_names(name: str, n: int = 3) -> list[str]:
    """Model names of the table close to `name`, for an error message."""
    every = {s: p.model for p in ALL_PRINTERS for s in _names(p)}
    return list(dict.fromkeys(every[c] for c in difflib.get_close_matches(_key(name), list(every), n=n, cutoff=0.6)))


def vendor_name(text: str) -> str:
    """The table's vendor for what the user typed ('prusa' -> 'Prusa Research'); the text itself otherwise."""
    return VENDOR_ALIASES.get(_key(text), text)


def printers_of(vendor: str | None) -> list[PrinterModel]:
    """The table's printers of `vendor` (any spelling VENDOR_ALIASES knows, case-insensitive), or all."""
    if not vendor:
        return list(ALL_PRINTERS)
    wanted = vendor_name(vendor).lower()
    return [p for p in ALL_PRINTERS if p.vendor.lower() == wanted or p.vendor.lower().startswith(_key(vendor))]


def installed_preset(printer: PrinterModel) -> str | None:
    """The first of the printer's PrusaSlicer system presets that the installed PrusaSlicer bundles hold."""
    if not printer.prusa_presets:
        return None
    from .prusa_presets import system_printers

    have = {p.name.lower(): p.name for p in system_printers()}
    return next((have[n.lower()] for n in printer.prusa_presets if n.lower() in have), None)


# A resin printer's feature width, its stand-in for the nozzle: 4 pixels (or laser spots), the narrowest line
# an MSLA/SLA print holds with its edges intact, and never under 0.2 mm, so that High (half a feature per grid
# point) stops at 0.1 mm: a tenth of the ~1 mm a fingertip resolves, finer than any step a finger can feel.
RESIN_FEATURE_PIXELS = 4
TOUCH_FEATURE_MM = 0.2
RESIN_LAYER_MM = 0.05  # the usual resin layer (PrusaSlicer's "0.05 Normal"): 60 levels in a 3 mm relief


def feature_mm(printer: PrinterModel) -> float:
    """The smallest feature the presets scale from: the nozzle, or for resin 4 pixels, at least 0.2 mm."""
    if not printer.is_resin:
        return printer.nozzle_mm
    return round(max(RESIN_FEATURE_PIXELS * float(printer.xy_mm), TOUCH_FEATURE_MM), 4)


def sla_preset(printer: PrinterModel) -> str | None:
    """The resin printer's PrusaSlicer SLA printer preset, when the installed PrusaSlicer bundles hold it."""
    if not printer.is_resin or not printer.prusa_presets:
        return None
    from .prusa_presets import sla_printers

    have = sla_printers()
    return next((have[n.lower()][0] for n in printer.prusa_presets if n.lower() in have), None)


def design_layer_mm(printer: PrinterModel, wanted_mm: float | None = None) -> float:
    """The layer height to design for: `wanted_mm` (0.12 mm for a nozzle, giving 25 levels in a 3 mm relief;
    0.05 mm for resin) when it lies within the printer's usual range, else the usual height closest to it."""
    if wanted_mm is None:
        wanted_mm = RESIN_LAYER_MM if printer.is_resin else 0.12
    if min(printer.layers_mm) <= wanted_mm <= max(printer.layers_mm):
        return wanted_mm
    return min(printer.layers_mm, key=lambda v: (abs(v - wanted_mm), v))
