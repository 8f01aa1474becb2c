"""Slice with the real PrusaSlicer command line, and estimate mass and cost without slicing.

PrusaSlicer runs headless: we create its configuration with `--save` from the printer profile
(nozzle, layer height, 15 % gyroid infill, no supports, as the reference recommends) and the
material (density, price per kg), slice to G-code beside the mesh, and read the figures it
writes as G-code comments. A missing slicer, a slicer error or a timeout raise SlicerError with a
clear message; the mesh is never touched.

When the printer profile names a PrusaSlicer system preset (a real printer such as an Original
Prusa MINI), the G-code gets that printer's bed, firmware flavour, start G-code and the vendor's
filament temperatures (prusa_presets.py resolves the vendor bundle); our print settings (layer,
infill, perimeters) go on top. Otherwise the printer is a generic 300 × 300 mm machine and the
G-code is for estimates only: the result, its sentence and a comment at the top of the file say so.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
import dataclasses
import zipfile
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import MissingDependencyError, ParameterError, TampError
# The print settings the reliefs are designed for, the same as in the 3MF's settings.
from .print_settings import BOTTOM_LAYERS, FIRST_LAYER_MM, INFILL, PERIMETERS, TOP_LAYERS, first_layer_mm

from .printers import PrinterProfile

GENERIC_NOTE = "generic printer profile: the G-code is for estimates only, not for sending to a printer"


def estimates_note(printer: PrinterProfile) -> str:
    """Why the G-code is for estimates only: a generic profile, or a known printer whose PrusaSlicer
    system preset the installed PrusaSlicer lacks (then the 3MF is what to print from)."""
    if printer.bed_mm is None:
        return GENERIC_NOTE
    return (f"no PrusaSlicer preset for the {printer.name} here: G-code for estimates only; print from the 3MF, "
            f"which carries the {printer.layer_mm:g} mm settings")


class SlicerError(TampError):
    """PrusaSlicer failed or ran too long; the mesh is kept."""


# Cradle-to-gate greenhouse-gas factors (kg CO₂e per kg of material) and where each comes from. They are
# approximate: a print's footprint also has the printer's electricity, failed prints and waste, left out here.
_INGEO = ("Vink & Davies 2015, Industrial Biotechnology 11(3):167-180, NatureWorks' 2014 Ingeo PLA eco-profile, "
          "cradle to gate with the plants' CO2 uptake (value not re-read here)")
_RPET = ("denkstatt for ALPLA 2017 (ISO 14044): virgin PET 2.15, recycled PET 0.45 kg CO2e/kg, "
         "https://www.plasticsnewseurope.com/article/20170809/PNE/170809890/")
_RESIN = ("uncertain: no published factor for printing resin was found; a (meth)acrylate polymer's, "
          "PlasticsEurope's PMMA eco-profile (2015), is the stand-in, its value not re-read here")


@dataclass(frozen=True)
class Material:
    name: str
    density_g_cm3: float  # g/cm³, which is g/mL
    price_per_kg: float
    kind: str = "filament"  # filament (a nozzle printer) or resin
    co2e_kg_per_kg: float | None = None  # cradle-to-gate greenhouse gases, approximate
    co2e_source: str = "no factor found"
    filament_type: str = ""  # PrusaSlicer's filament_type for its presets: PLA for recycled PLA
    price_assumed: bool = True  # the table's price (said as an assumption), not one the user gave

    @property
    def is_resin(self) -> bool:
        return self.kind == "resin"

    def co2e_kg(self, grams: float) -> float | None:
        """Approximate kg CO₂e of `grams` of this material, or None without a factor."""
        return None if self.co2e_kg_per_kg is None else grams / 1000 * self.co2e_kg_per_kg


# Prices per kg in the user's currency, assumed when not given: a 1 kg spool of filament, and a bottle of
# standard or plant-based printing resin, which costs more per kg (a filament's price applied to resin
# understated its cost); no price list was checked, so each cost line says the price is assumed.
FILAMENT_PRICE_PER_KG = 25.0
RESIN_PRICE_PER_KG = 35.0
MATERIALS = {m.name.upper(): m for m in (
    Material("PLA", 1.24, FILAMENT_PRICE_PER_KG, co2e_kg_per_kg=0.62, co2e_source=_INGEO),
    Material("PETG", 1.27, FILAMENT_PRICE_PER_KG, co2e_kg_per_kg=2.15, co2e_source=f"virgin PET's as PETG's stand-in: {_RPET}"),
    Material("ABS", 1.04, FILAMENT_PRICE_PER_KG),
    Material("rPLA", 1.24, FILAMENT_PRICE_PER_KG, co2e_kg_per_kg=0.13, filament_type="PLA",
             co2e_source=f"assumed: PLA's 0.62 less the 79 % that recycling saves for PET (no recycled-PLA study found); {_INGEO}"),
    Material("rPETG", 1.27, FILAMENT_PRICE_PER_KG, co2e_kg_per_kg=0.45, filament_type="PETG", co2e_source=f"recycled PET's as a stand-in: {_RPET}"),
    Material("resin", 1.1, RESIN_PRICE_PER_KG, kind="resin", co2e_kg_per_kg=4.0, co2e_source=_RESIN),
    Material("plant-resin", 1.1, RESIN_PRICE_PER_KG, kind="resin", co2e_kg_per_kg=2.0,
             co2e_source="assumed: half the standard resin's for a resin about half plant-based (Voet et al. 2018, "
                         "ACS Omega 3:1403, made SLA resins 34-67 % bio-based); no study of such a resin's footprint found; uncertain"),
)}
FILAMENTS = tuple(m.name for m in MATERIALS.values() if not m.is_resin)
RESINS = tuple(m.name for m in MATERIALS.values() if m.is_resin)


def material(name: str, filament_price_per_kg: float | None = None, resin_price_per_kg: float | None = None) -> Material:
    """The material called `name`, at the price the user gave for its kind (filament or resin), else
    at the table's assumed price."""
    key = name.upper()
    if key not in MATERIALS:
        raise ParameterError(f"`material`: must be one of {', '.join(m.name for m in MATERIALS.values())}; got {name!r}.")
    base = MATERIALS[key]
    price, parameter = ((resin_price_per_kg, "resin_price_per_kg") if base.is_resin
                        else (filament_price_per_kg, "filament_price_per_kg"))
    if price is None:
        return base
    if not 0 < price < 1000:
        raise ParameterError(f"`{parameter}`: must be above 0 and below 1000 per kg; got {price}.", parameter=parameter, value=price)
    return dataclasses.replace(base, price_per_kg=price, price_assumed=False)


def material_for(printer: PrinterProfile, name: str, *, filament_price_per_kg: float | None = None,
                 resin_price_per_kg: float | None = None) -> Material:
    """The material a printer prints: PLA (the default) on a resin printer means standard resin; a
    filament on a resin printer, or a resin on a nozzle printer, is refused with what to choose."""
    if printer.is_resin and name.upper() == "PLA":
        name = "resin"
    chosen = material(name, filament_price_per_kg, resin_price_per_kg)
    if chosen.is_resin != printer.is_resin:
        fits = RESINS if printer.is_resin else FILAMENTS
        what = "a resin printer" if printer.is_resin else "a nozzle printer"
        raise ParameterError(f"`material`: the printer {printer.name!r} is {what}; choose one of {', '.join(fits)} "
                             f"(or another `printer`); got {name!r}.", parameter="material", value=name,
                             allowed=", ".join(fits))
    return chosen


@dataclass
class SliceResult:
    gcode: str
    print_time_s: float
    filament_mm: float
    filament_cm3: float
    filament_g: float
    cost: float
    layer_mm: float
    layers: int
    material: str
    price_per_kg: float
    printer: str = "generic"
    for_estimates_only: bool = True
    price_assumed: bool = False
    note: str = GENERIC_NOTE  # why the G-code is for estimates only (slicer.estimates_note)

    def as_dict(self) -> dict:
        return asdict(self)

    def sentence(self) -> str:
        return (
            f"{_duration(self.print_time_s)} to print, {self.filament_g:.1f} g of {self.material} "
            f"({self.filament_mm / 1000:.2f} m of filament), costing {self.cost:.2f} at {price_words(self.price_per_kg, self.price_assumed)}"
            + _co2e_words(self.material, self.filament_g)
            + (f" ({self.note})" if self.for_estimates_only else f", sliced for {self.printer}")
        )


def price_words(price_per_kg: float, assumed: bool) -> str:
    """'35 per kg' for a price the user gave; '35 per kg (an assumed price, in your currency)' for the table's."""
    return f"{price_per_kg:g} per kg" + (" (an assumed price, in your currency)" if assumed else "")


def _co2e_words(material_name: str, grams: float) -> str:
    """', about 0.01 kg CO₂e' for a material with a factor (its source is in the materials table and the docs)."""
    kg = MATERIALS[material_name.upper()].co2e_kg(grams)
    return "" if kg is None else f", about {kg:.3f} kg CO₂e"


@dataclass
class ResinSliceResult:
    """What PrusaSlicer's SLA export wrote: its archive's print time and resin volume, and what they cost."""

    print_file: str
    print_time_s: float
    resin_ml: float
    resin_g: float
    cost: float
    layer_mm: float
    layers: int
    material: str
    price_per_kg: float
    printer: str
    for_estimates_only: bool = False
    note: str = ""
    price_assumed: bool = False

    @property
    def gcode(self) -> str:
        """The print file (an .sl1s archive): the name the report's printing facts use for any print file."""
        return self.print_file

    def as_dict(self) -> dict:
        return asdict(self)

    def sentence(self) -> str:
        return (f"{_duration(self.print_time_s)} to print, {self.resin_ml:.1f} mL of {self.material} ({self.resin_g:.1f} g), "
                f"costing {self.cost:.2f} at {price_words(self.price_per_kg, self.price_assumed)}{_co2e_words(self.material, self.resin_g)}, "
                f"sliced for {self.printer}")


def read_sla_archive(path, mat: Material) -> ResinSliceResult:
    """Print time, resin volume and layers from an .sl1/.sl1s archive's config.ini, as PrusaSlicer wrote them."""
    try:
        with zipfile.ZipFile(path) as archive:
            text = archive.read("config.ini").decode("utf-8", errors="replace")
    except (OSError, KeyError, zipfile.BadZipFile) as exc:
        raise SlicerError(f"{path}: not an SLA print archive with a config.ini ({exc}).") from None
    values = dict(line.split(" = ", 1) for line in text.splitlines() if " = " in line)
    try:
        ml = float(values["usedMaterial"])
        grams = ml * mat.density_g_cm3
        return ResinSliceResult(
            print_file=str(path), print_time_s=float(values["printTime"]), resin_ml=ml, resin_g=round(grams, 3),
            cost=round(grams / 1000 * mat.price_per_kg, 3), layer_mm=float(values["layerHeight"]),
            layers=int(values["numFast"]) + int(values["numSlow"]), material=mat.name, price_per_kg=mat.price_per_kg,
            printer=values.get("printerModel", ""), price_assumed=mat.price_assumed)
    except (KeyError, ValueError) as exc:
        raise SlicerError(f"{path}: its config.ini lacks {exc}; is this PrusaSlicer's SLA output?") from None


def slice_sla(mesh_path, printer: PrinterProfile, mat: Material, *, timeout_s: float = 600.0) -> ResinSliceResult:
    """Slice `mesh_path` with PrusaSlicer's SLA export for the printer's system preset, beside the mesh
    (same name, the preset's .sl1s or .sl1), and read the time and resin volume from the archive."""
    from .printer_table import find_printer, sla_preset
    from .prusa_presets import sla_config

    mesh_path = Path(mesh_path)
    model = find_printer(printer.name)
    preset = sla_preset(model) if model else None
    if preset is None:
        raise SlicerError(f"{mesh_path}: no PrusaSlicer preset for the {printer.name} here; print the STL or 3MF from its "
                          "vendor's slicer (the description gives the settings).")
    config = sla_config(preset, printer.layer_mm)
    suffix = Path(config.options.get("output_filename_format", ".sl1")).suffix or ".sl1"
    exe = prusa_slicer()
    target = mesh_path.with_suffix(suffix)
    partial = target.with_name(f".{target.stem}.part{suffix}")
    with tempfile.TemporaryDirectory(prefix="tamp-slice-") as tmp:
        ini = config.write(Path(tmp) / "config.ini")
        try:
            done = _run([exe, "--export-sla", "--load", str(ini), "--output", str(partial), str(mesh_path)], timeout_s, str(mesh_path))
            if done.returncode != 0 or not partial.is_file():
                raise SlicerError(f"{mesh_path}: PrusaSlicer failed ({_last_error(done)}); the mesh is kept.")
            result = read_sla_archive(partial, mat)
            os.replace(partial, target)
        finally:
            partial.unlink(missing_ok=True)
    result.print_file, result.printer = str(target), preset
    return result


def _duration(seconds: float) -> str:
    h, rest = divmod(int(round(seconds)), 3600)
    return f"{h} h {rest // 60} min" if h else f"{rest // 60} min {rest % 60} s"


def prusa_slicer() -> str:
    exe = shutil.which("prusa-slicer") or shutil.which("prusa-slicer-console")
    if exe is None:
        raise MissingDependencyError(
            "slicing needs PrusaSlicer: on Debian or Ubuntu run 'sudo apt-get install prusa-slicer' (make setup does "
            "this). The mesh was written; slice it in any slicer."
        )
    return exe


def print_args(layer: float, nozzle: float, mat: Material) -> list[str]:
    """Our print settings (the reference's: 15 % gyroid, no supports) and the material's density and price."""
    return [
        "--layer-height", f"{layer:g}",
        "--first-layer-height", f"{first_layer_mm(layer, nozzle):g}",
        "--fill-density", f"{INFILL * 100:g}%",
        "--fill-pattern", "gyroid",
        "--perimeters", str(PERIMETERS),
        "--top-solid-layers", str(TOP_LAYERS),
        "--bottom-solid-layers", str(BOTTOM_LAYERS),
        "--filament-density", f"{mat.density_g_cm3:g}",
        "--filament-cost", f"{mat.price_per_kg:g}",
        "--skirts", "1",
    ]


def config_args(printer: PrinterProfile, mat: Material, layer_mm: float | None = None, *, nozzle_mm: float | None = None) -> list[str]:
    """The generic printer: our print settings on a 300 × 300 mm bed with a 1.75 mm filament."""
    layer = layer_mm or printer.layer_mm
    nozzle = nozzle_mm or printer.nozzle_mm
    return [*print_args(layer, nozzle, mat), "--nozzle-diameter", f"{nozzle:g}", "--filament-diameter", "1.75",
            "--bed-shape", "0x0,300x0,300x300,0x300"]


def _preset_config(folder: Path, printer: PrinterProfile, mat: Material, layer_mm, nozzle_mm) -> tuple[Path, list[str]]:
    """config.ini from the system preset, and our print settings to give on the command line (they win)."""
    from .prusa_presets import preset_config

    resolved = preset_config(printer.prusa_preset, mat.filament_type or mat.name)
    nozzle = resolved.printer.nozzle_mm
    if nozzle_mm and abs(nozzle_mm - nozzle) > 1e-6:
        raise ParameterError(
            f"`nozzle_mm`: the printer preset {printer.prusa_preset!r} has a {nozzle:g} mm nozzle; got {nozzle_mm:g}. "
            f"Choose the preset for your nozzle (list them with the printers command) or leave `nozzle_mm` unset."
        )
    return resolved.write(folder / "config.ini"), print_args(layer_mm or printer.layer_mm, nozzle, mat)


def _run(args: list[str], timeout_s: float, what: str) -> subprocess.CompletedProcess:
    try:
        return subprocess.run(args, capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise SlicerError(f"{what}: PrusaSlicer ran longer than the timeout of {timeout_s:g} s and was stopped; the mesh is kept. "
                          f"Raise `slice_timeout_s`, or use a coarser mesh (a larger `max_error_mm` or a lower preset).") from None


def slice_mesh(mesh_path, printer: PrinterProfile, mat: Material, *, timeout_s: float = 600.0,
               layer_mm: float | None = None, nozzle_mm: float | None = None) -> SliceResult | ResinSliceResult:
    """Slice `mesh_path` to G-code beside it (same name, .gcode) and read back the figures; a resin
    printer's mesh to its SLA archive (slice_sla)."""
    if printer.is_resin:
        return slice_sla(mesh_path, printer.with_overrides(layer_mm=layer_mm), mat, timeout_s=timeout_s)
    mesh_path = Path(mesh_path)
    exe = prusa_slicer()
    gcode = mesh_path.with_suffix(".gcode")
    with tempfile.TemporaryDirectory(prefix="tamp-slice-") as tmp:
        if printer.prusa_preset:
            config, extra = _preset_config(Path(tmp), printer, mat, layer_mm, nozzle_mm)
        else:
            config, extra = Path(tmp) / "config.ini", []
            saved = _run([exe, "--save", str(config), *config_args(printer, mat, layer_mm, nozzle_mm=nozzle_mm)], 60, str(mesh_path))
            if saved.returncode != 0 or not config.is_file():
                raise SlicerError(f"{mesh_path}: PrusaSlicer could not create its configuration ({_last_error(saved)}).")
        partial = gcode.with_name(f".{gcode.name}.part")
        try:
            done = _run([exe, "--export-gcode", "--load", str(config), *extra, "--output", str(partial), str(mesh_path)], timeout_s, str(mesh_path))
            if done.returncode != 0 or not partial.is_file():
                raise SlicerError(f"{mesh_path}: PrusaSlicer failed ({_last_error(done)}); the mesh is kept.")
            text = partial.read_text(encoding="utf-8", errors="replace")
            result = parse_gcode(text, mat)
            if not printer.prusa_preset:  # say it in the file too, where a printer's user will look
                partial.write_text(f"; TAMP-OS: {estimates_note(printer)}.\n{text}", encoding="utf-8")
            os.replace(partial, gcode)
        finally:
            partial.unlink(missing_ok=True)
    result.gcode = str(gcode)
    result.printer = printer.prusa_preset or "generic"
    result.for_estimates_only = not printer.prusa_preset
    result.note = estimates_note(printer)
    return result


def _last_error(done: subprocess.CompletedProcess) -> str:
    lines = [line for line in (done.stderr + done.stdout).splitlines() if "error" in line.lower() and "[trace]" not in line]
    return (lines[-1].strip() if lines else f"exit status {done.returncode}")[:300]


def parse_gcode(text: str, mat: Material) -> SliceResult:
    def value(pattern: str) -> float:
        match = re.search(pattern, text, re.M)
        if not match:
            raise SlicerError(f"the G-code has no '{pattern}' comment; is this PrusaSlicer output?")
        return float(match.group(1))

    time_text = re.search(r"^; estimated printing time \(normal mode\) = (.+)$", text, re.M)
    seconds = 0.0
    if time_text:
        for amount, unit in re.findall(r"(\d+)([dhms])", time_text.group(1)):
            seconds += int(amount) * {"d": 86400, "h": 3600, "m": 60, "s": 1}[unit]
    zs = [float(z) for z in re.findall(r"^;Z:([0-9.]+)", text, re.M)]
    layer = float(np.median(np.diff(zs))) if len(zs) > 2 else 0.0
    return SliceResult(
        gcode="",
        print_time_s=seconds,
        filament_mm=value(r"^; filament used \[mm\] = ([0-9.]+)"),
        filament_cm3=value(r"^; filament used \[cm3\] = ([0-9.]+)"),
        filament_g=value(r"^; filament used \[g\] = ([0-9.]+)"),
        cost=value(r"^; (?:total )?filament cost = ([0-9.]+)"),
        layer_mm=round(layer, 4),
        layers=len(zs),
        material=mat.name,
        price_per_kg=mat.price_per_kg,
        price_assumed=mat.price_assumed,
    )


def mesh_info(mesh_path) -> dict:
    """PrusaSlicer's own check of a mesh (`--info`): manifold, open edges, volume."""
    done = _run([prusa_slicer(), "--info", str(mesh_path)], 120, str(mesh_path))
    info = {}
    for line in done.stdout.splitlines():
        key, sep, value = line.partition("=")
        if sep:
            info[key.strip()] = value.strip()
    return info


def estimate(volume_mm3: float, vertices: np.ndarray, faces: np.ndarray, *, printer: PrinterProfile, mat: Material,
             layer_mm: float | None = None, nozzle_mm: float | None = None) -> dict:
    """Mass and cost without slicing, from the solid and the same print settings.

    Assumptions (stated in the result): walls of PERIMETERS lines 1.125 × nozzle wide on the
    sides, TOP_LAYERS / BOTTOM_LAYERS solid layers under every up- and down-facing surface,
    INFILL of the rest. Within about 25 % of PrusaSlicer's figure on our examples. A resin
    prints solid: its volume is the mesh's (resin_estimate).
    """
    if mat.is_resin:
        return resin_estimate(volume_mm3, mat)
    layer = layer_mm or printer.layer_mm
    nozzle = nozzle_mm or printer.nozzle_mm
    tri = vertices[faces]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(cross, axis=1) / 2
    nz = np.divide(cross[:, 2], 2 * area, out=np.zeros_like(area), where=area > 0)
    # Each face needs solid layers under its horizontal projection and perimeters along its
    # vertical projection (a sloping relief is a staircase of layer contours, each with walls).
    flat = area * np.abs(nz)
    upright = area * np.sqrt(np.clip(1 - nz * nz, 0, 1))
    up, down = flat[nz > 0].sum(), flat[nz < 0].sum()
    shell = up * TOP_LAYERS * layer + down * (FIRST_LAYER_MM + (BOTTOM_LAYERS - 1) * layer) + upright.sum() * PERIMETERS * 1.125 * nozzle
    shell = min(shell, volume_mm3)
    plastic_cm3 = (shell + INFILL * (volume_mm3 - shell)) / 1000
    grams = plastic_cm3 * mat.density_g_cm3
    return {
        "filament_cm3": round(plastic_cm3, 3),
        "filament_g": round(grams, 2),
        "cost": round(grams / 1000 * mat.price_per_kg, 3),
        "material": mat.name,
        "price_per_kg": mat.price_per_kg,
        "price_assumed": mat.price_assumed,
        "co2e_kg": mat.co2e_kg(grams),
        "co2e_source": mat.co2e_source,
        "assumptions": (
            f"{PERIMETERS} perimeters of {1.125 * nozzle:.2f} mm, {TOP_LAYERS} top and {BOTTOM_LAYERS} bottom solid layers "
            f"of {layer:g} mm, {INFILL:.0%} gyroid infill, {mat.name} at {mat.density_g_cm3:g} g/cm³ and {price_words(mat.price_per_kg, mat.price_assumed)}"
        ),
    }


def resin_estimate(volume_mm3: float, mat: Material) -> dict:
    """Resin for a solid print of the mesh: its volume, printed flat on the platform without supports or hollowing."""
    ml = volume_mm3 / 1000
    grams = ml * mat.density_g_cm3
    return {
        "resin_ml": round(ml, 3),
        "filament_g": round(grams, 2),
        "cost": round(grams / 1000 * mat.price_per_kg, 3),
        "material": mat.name,
        "price_per_kg": mat.price_per_kg,
        "price_assumed": mat.price_assumed,
        "co2e_kg": mat.co2e_kg(grams),
        "co2e_source": mat.co2e_source,
        "assumptions": (f"a solid print of the mesh's volume, flat on the platform with no supports, pad or hollowing "
                        f"(resin left in the vat and on the part is not counted), {mat.name} at {mat.density_g_cm3:g} g/mL "
                        f"and {price_words(mat.price_per_kg, mat.price_assumed)}"),
    }
