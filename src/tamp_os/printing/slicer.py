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


@dataclass(frozen=True)
class Material:
    name: str
    density_g_cm3: float
    price_per_kg: float


MATERIALS = {m.name: m for m in (Material("PLA", 1.24, 25.0), Material("PETG", 1.27, 25.0), Material("ABS", 1.04, 25.0))}


def material(name: str, price_per_kg: float | None = None) -> Material:
    key = name.upper()
    if key not in MATERIALS:
        raise ParameterError(f"`material`: must be one of {', '.join(MATERIALS)}; got {name!r}.")
    base = MATERIALS[key]
    if price_per_kg is None:
        return base
    if not 0 < price_per_kg < 1000:
        raise ParameterError(f"filament price: must be above 0 and below 1000 per kg; got {price_per_kg}.")
    return Material(base.name, base.density_g_cm3, price_per_kg)


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
    note: str = GENERIC_NOTE  # why the G-code is for estimates only (slicer.estimates_note)

    def as_dict(self) -> dict:
        return asdict(self)

    def sentence(self) -> str:
        return (
            f"{_duration(self.print_time_s)} to print, {self.filament_g:.1f} g of {self.material} "
            f"({self.filament_mm / 1000:.2f} m of filament), costing {self.cost:.2f} at {self.price_per_kg:g} per kg"
            + (f" ({self.note})" if self.for_estimates_only else f", sliced for {self.printer}")
        )


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


def config_args(printer: PrinterProfile, mat: Material, layer_mm: float | None = None, nozzle_mm: float | None = None) -> list[str]:
    """The generic printer: our print settings on a 300 × 300 mm bed with a 1.75 mm filament."""
    layer = layer_mm or printer.layer_mm
    nozzle = nozzle_mm or printer.nozzle_mm
    return [*print_args(layer, nozzle, mat), "--nozzle-diameter", f"{nozzle:g}", "--filament-diameter", "1.75",
            "--bed-shape", "0x0,300x0,300x300,0x300"]


def _preset_config(folder: Path, printer: PrinterProfile, mat: Material, layer_mm, nozzle_mm) -> tuple[Path, list[str]]:
    """config.ini from the system preset, and our print settings to give on the command line (they win)."""
    from .prusa_presets import preset_config

    resolved = preset_config(printer.prusa_preset, mat.name)
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
               layer_mm: float | None = None, nozzle_mm: float | None = None) -> SliceResult:
    """Slice `mesh_path` to G-code beside it (same name, .gcode) and read back the figures."""
    mesh_path = Path(mesh_path)
    exe = prusa_slicer()
    gcode = mesh_path.with_suffix(".gcode")
    with tempfile.TemporaryDirectory(prefix="tamp-slice-") as tmp:
        if printer.prusa_preset:
            config, extra = _preset_config(Path(tmp), printer, mat, layer_mm, nozzle_mm)
        else:
            config, extra = Path(tmp) / "config.ini", []
            saved = _run([exe, "--save", str(config), *config_args(printer, mat, layer_mm, nozzle_mm)], 60, str(mesh_path))
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


def estimate(volume_mm3: float, vertices: np.ndarray, faces: np.ndarray, printer: PrinterProfile, mat: Material,
             layer_mm: float | None = None, nozzle_mm: float | None = None) -> dict:
    """Mass and cost without slicing, from the solid and the same print settings.

    Assumptions (stated in the result): walls of PERIMETERS lines 1.125 × nozzle wide on the
    sides, TOP_LAYERS / BOTTOM_LAYERS solid layers under every up- and down-facing surface,
    INFILL of the rest. Within about 25 % of PrusaSlicer's figure on our examples.
    """
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
        "assumptions": (
            f"{PERIMETERS} perimeters of {1.125 * nozzle:.2f} mm, {TOP_LAYERS} top and {BOTTOM_LAYERS} bottom solid layers "
            f"of {layer:g} mm, {INFILL:.0%} gyroid infill, {mat.name} at {mat.density_g_cm3:g} g/cm³ and {mat.price_per_kg:g} per kg"
        ),
    }
