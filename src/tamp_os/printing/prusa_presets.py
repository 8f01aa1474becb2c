"""PrusaSlicer's system printer presets (the vendor bundles it ships), resolved into one config.

A vendor bundle (/usr/share/PrusaSlicer/profiles/VENDOR.ini on Debian) holds `[printer:NAME]`,
`[print:NAME]` and `[filament:NAME]` presets; each may `inherit` from others (several, separated
by ';', later ones winning; names in *asterisks* are abstract). PrusaSlicer's command line cannot
select a system preset by name, so we resolve the inheritance ourselves and write a plain
config.ini with the printer's own bed, firmware flavour, nozzle and start G-code, its default print
settings, and a filament of the requested material with the vendor's temperatures.
"""

from __future__ import annotations

import configparser
import difflib
import functools
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import ParameterError

PROFILE_DIRS = ("/usr/share/PrusaSlicer/profiles", "/usr/local/share/PrusaSlicer/profiles")
# Preset bookkeeping that is not a slicing option; PrusaSlicer's --load would reject or misuse it.
NOT_OPTIONS = {"inherits", "renamed_from", "alias", "compatible_printers", "compatible_printers_condition",
               "compatible_prints", "compatible_prints_condition"}


def profile_dirs() -> list[Path]:
    """Where vendor bundles are looked for: $TAMP_PRUSA_PROFILES, else PrusaSlicer's install folders."""
    env = os.environ.get("TAMP_PRUSA_PROFILES")
    return [Path(env)] if env else [Path(p) for p in PROFILE_DIRS]


@functools.lru_cache(maxsize=64)
def read_bundle(path: Path) -> dict[str, dict[str, str]]:
    """Sections of one vendor bundle: {'printer:NAME': {key: value}, ...}; keys keep their case."""
    parser = configparser.RawConfigParser(strict=False, interpolation=None, comment_prefixes=("#",), delimiters=("=",))
    parser.optionxform = str
    parser.read_string(path.read_text(encoding="utf-8", errors="replace"), source=str(path))
    return {name: dict(parser.items(name)) for name in parser.sections()}


def bundles() -> dict[str, Path]:
    """Vendor bundle files by vendor id (file stem), from every profile folder."""
    found = {}
    for folder in profile_dirs():
        if folder.is_dir():
            for path in sorted(folder.glob("*.ini")):
                found.setdefault(path.stem, path)
    return found


def resolve(sections: dict[str, dict[str, str]], kind: str, name: str, *, _seen: tuple = ()) -> dict[str, str]:
    """The options of preset `kind:name` with everything it inherits (parents first, own values last)."""
    key = f"{kind}:{name}"
    if key not in sections or key in _seen:
        raise ParameterError(f"PrusaSlicer preset {key!r}: not found in its vendor bundle (or inherits itself).")
    own = sections[key]
    merged: dict[str, str] = {}
    for parent in filter(None, (p.strip() for p in own.get("inherits", "").split(";"))):
        merged.update(resolve(sections, kind, parent, _seen=(*_seen, key)))
    merged.update(own)
    return merged


def bed_size_mm(bed_shape: str) -> tuple[float, float]:
    """Width and depth of a PrusaSlicer bed_shape ('0x0,250x0,250x210,0x210' -> (250, 210))."""
    points = [tuple(float(v) for v in corner.split("x")) for corner in bed_shape.split(",") if "x" in corner]
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    return max(xs) - min(xs), max(ys) - min(ys)


def _first(value: str) -> float:
    """The first extruder's value of a per-extruder option ('0.4,0.4' -> 0.4)."""
    return float(value.split(",")[0])


@dataclass(frozen=True)
class SystemPrinter:
    """One concrete FFF printer preset of a vendor bundle."""

    name: str
    vendor: str
    bed_mm: tuple[float, float]
    nozzle_mm: float
    gcode_flavor: str
    bundle: Path

    def line(self) -> str:
        return f"{self.name} ({self.vendor}): bed {self.bed_mm[0]:g} × {self.bed_mm[1]:g} mm, nozzle {self.nozzle_mm:g} mm, {self.gcode_flavor}"


@functools.lru_cache(maxsize=1)
def system_printers() -> tuple[SystemPrinter, ...]:
    """Every concrete FFF printer preset in the installed vendor bundles (SLA printers left out)."""
    printers = []
    for vendor, path in bundles().items():
        sections = read_bundle(path)
        for key in sections:
            kind, _, name = key.partition(":")
            if kind != "printer" or name.startswith("*"):
                continue
            options = resolve(sections, "printer", name)
            if options.get("printer_technology", "FFF") != "FFF" or "bed_shape" not in options:
                continue
            printers.append(SystemPrinter(name, vendor, bed_size_mm(options["bed_shape"]), _first(options.get("nozzle_diameter", "0.4")),
                                          options.get("gcode_flavor", "reprap"), path))
    return tuple(sorted(printers, key=lambda p: (p.vendor.lower(), p.name.lower())))


def find_system_printer(name: str) -> SystemPrinter:
    """The preset called `name` (case-insensitive); a ParameterError with close names otherwise."""
    printers = system_printers()
    by_name = {p.name.lower(): p for p in printers}
    if name.lower() in by_name:
        return by_name[name.lower()]
    close = difflib.get_close_matches(name, [p.name for p in printers], n=3, cutoff=0.5)
    hint = f" Did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    where = ", ".join(str(d) for d in profile_dirs())
    raise ParameterError(
        f"`printer`: unknown profile {name!r}: neither a profile (standard, fine, large or yours) nor a PrusaSlicer system printer "
        f"preset in {where}.{hint} List them all with the printers command."
    )


@dataclass(frozen=True)
class PresetConfig:
    """A system printer preset resolved with its default print settings and a filament."""

    printer: SystemPrinter
    print_preset: str | None
    filament_preset: str | None
    layer_mm: float
    options: dict[str, str]

    def write(self, path: Path) -> Path:
        """A PrusaSlicer config.ini (key = value lines) that `--load` reads."""
        lines = [f"# {self.printer.name} ({self.printer.vendor}), print {self.print_preset}, filament {self.filament_preset}"]
        lines += [f"{key} = {value}" for key, value in sorted(self.options.items())]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path


def _unquote(value: str | None) -> str:
    return (value or "").strip().strip('"')


def _choose_filament(sections: dict, printer_options: dict, printer_name: str, material: str) -> str | None:
    """A filament preset of `material` for this printer: the printer's default filament when it is
    that material, else a ('Generic') preset of that material that names this printer or its model,
    else the default filament (its temperatures are for another material: PrusaSlicer's choice)."""
    def kind_of(name: str) -> str:
        return _unquote(resolve(sections, "filament", name).get("filament_type")).upper()

    names = [key.partition(":")[2] for key in sections if key.startswith("filament:") and not key.startswith("filament:*")]
    default = _unquote(printer_options.get("default_filament_profile"))
    if f"filament:{default}" in sections and kind_of(default) == material:
        return default
    of_kind = [n for n in names if kind_of(n) == material]
    generic = [n for n in of_kind if n.upper().startswith(f"GENERIC {material}")] or of_kind
    model = _unquote(printer_options.get("printer_model"))

    def score(name: str) -> int:
        options = resolve(sections, "filament", name)
        listed = [_unquote(p) for p in options.get("compatible_printers", "").split(";")]
        return (printer_name in listed) * 4 + (bool(model) and model in options.get("compatible_printers_condition", "")) * 2 + (name.upper() == f"GENERIC {material}")

    if generic:
        return max(generic, key=score)
    return default if f"filament:{default}" in sections else None


def preset_config(name: str, material: str = "PLA") -> PresetConfig:
    """Resolve printer preset `name` with its default print preset and a `material` filament preset."""
    printer = find_system_printer(name)
    sections = read_bundle(printer.bundle)
    printer_options = resolve(sections, "printer", printer.name)
    print_name = _unquote(printer_options.get("default_print_profile")) or None
    print_options = resolve(sections, "print", print_name) if f"print:{print_name}" in sections else {}
    filament = _choose_filament(sections, printer_options, printer.name, material.upper())
    filament_options = resolve(sections, "filament", filament) if filament else {}
    options = {k: v for k, v in {**print_options, **filament_options, **printer_options}.items() if k not in NOT_OPTIONS}
    # The names PrusaSlicer writes into the G-code's settings comments, so a reader sees what it was made for.
    options.update(printer_settings_id=printer.name, print_settings_id=print_name or "", filament_settings_id=filament or "")
    layer = float(print_options.get("layer_height", printer.nozzle_mm / 2))
    return PresetConfig(printer, print_name if print_options else None, filament, layer, options)


def system_printer_profile(name: str) -> tuple:
    """The numbers of a PrinterProfile for a system preset, in the profile's field order: its name,
    nozzle, its default print's layer height, a default print width of 100 mm or less to fit its
    bed, a description, the preset and the bed (printers.py makes the profile: this module never
    imports it, so the two do not depend on each other)."""
    printer = find_system_printer(name)
    sections = read_bundle(printer.bundle)
    print_name = _unquote(resolve(sections, "printer", printer.name).get("default_print_profile"))
    print_options = resolve(sections, "print", print_name) if f"print:{print_name}" in sections else {}
    layer = float(print_options.get("layer_height", printer.nozzle_mm / 2))
    width = min(100.0, max(10.0, min(printer.bed_mm) - 20.0))
    return (printer.name, printer.nozzle_mm, layer, width, f"PrusaSlicer system preset ({printer.vendor})", printer.name,
            printer.bed_mm)


@functools.lru_cache(maxsize=1)
def sla_printers() -> dict[str, tuple[str, Path]]:
    """Concrete SLA printer presets of the installed bundles: {lower-case name: (name, bundle)}."""
    found = {}
    for path in bundles().values():
        sections = read_bundle(path)
        for key in sections:
            kind, _, name = key.partition(":")
            if kind == "printer" and not name.startswith("*") and resolve(sections, "printer", name).get("printer_technology") == "SLA":
                found[name.lower()] = (name, path)
    return found


def _compatible(options: dict[str, str], model: str, layer_mm: float | None = None) -> bool:
    """Whether a sla_print / sla_material preset's conditions admit this printer model (and layer)."""
    printers = options.get("compatible_printers_condition", "")
    prints = options.get("compatible_prints_condition", "")
    layer_ok = layer_mm is None or not prints or f"layer_height == {layer_mm:g}" in prints
    return f'printer_model=="{model}"' in printers.replace(" ", "") and layer_ok


@dataclass(frozen=True)
class SlaConfig:
    """An SLA printer preset resolved with the print preset of the wanted layer and a material of it."""

    printer: str
    print_preset: str
    material_preset: str
    options: dict[str, str]

    def write(self, path: Path) -> Path:
        lines = [f"# {self.printer}, print {self.print_preset}, material {self.material_preset}"]
        lines += [f"{key} = {value}" for key, value in sorted(self.options.items())]
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return path


def sla_layers_mm(name: str) -> tuple[float, ...]:
    """The layer heights the SLA printer preset `name`'s own print presets make, thinnest first."""
    printer, path = sla_printers()[name.lower()]
    sections = read_bundle(path)
    model = _unquote(resolve(sections, "printer", printer).get("printer_model"))
    layers = set()
    for key in sections:
        kind, _, print_name = key.partition(":")
        if kind == "sla_print" and not print_name.startswith("*"):
            options = resolve(sections, "sla_print", print_name)
            if _compatible(options, model):
                layers.add(float(options["layer_height"]))
    return tuple(sorted(layers))


def sla_config(name: str, layer_mm: float) -> SlaConfig:
    """The SLA printer preset `name` with its print preset of `layer_mm` and the material its default
    material names at that layer, printed flat on the platform: no supports, no pad (a plate has a flat base)."""
    if name.lower() not in sla_printers():
        raise ParameterError(f"`printer`: {name!r} is not a PrusaSlicer SLA printer preset installed here.")
    printer, path = sla_printers()[name.lower()]
    sections = read_bundle(path)
    printer_options = resolve(sections, "printer", printer)
    model = _unquote(printer_options.get("printer_model"))
    prints = [key.partition(":")[2] for key in sections if key.startswith("sla_print:") and not key.startswith("sla_print:*")]
    fitting = [n for n in prints if _compatible(resolve(sections, "sla_print", n), model)
               and abs(float(resolve(sections, "sla_print", n)["layer_height"]) - layer_mm) < 1e-9]
    if not fitting:
        made = ", ".join(f"{v:g}" for v in sla_layers_mm(name))
        raise ParameterError(f"`layer_mm`: PrusaSlicer's {printer} presets print layers of {made} mm; got {layer_mm:g} mm. "
                             f"Choose one of them.")
    default = _unquote(printer_options.get("default_sla_material_profile"))
    base = default.split(" @")[0]
    materials = [key.partition(":")[2] for key in sections if key.startswith("sla_material:") and not key.startswith("sla_material:*")]
    usable = [n for n in materials if _compatible(resolve(sections, "sla_material", n), model, layer_mm)]
    if not usable:
        raise ParameterError(f"PrusaSlicer's bundle has no {printer} material for {layer_mm:g} mm layers.")
    material = next((n for n in usable if n.split(" @")[0] == base), usable[0])
    options = {**resolve(sections, "sla_material", material), **resolve(sections, "sla_print", fitting[0]), **printer_options}
    options = {k: v for k, v in options.items() if k not in NOT_OPTIONS}
    options.update(supports_enable="0", pad_enable="0", printer_settings_id=printer, sla_print_settings_id=fitting[0],
                   sla_material_settings_id=material)
    return SlaConfig(printer, fitting[0], material, options)
