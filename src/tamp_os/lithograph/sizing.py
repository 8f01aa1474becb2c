"""The printer and the print's size and grid that a set of parameters gives an image: what the
pipeline, the figure's panel words and the presets table all decide from."""

from __future__ import annotations

from ..params import LithoParams
from ..printing.printers import PrinterProfile, get_printer
from ..relief.layout import Layout, plan_layout


def resolve_printer(params: LithoParams, printer: PrinterProfile | None = None) -> PrinterProfile:
    """The printer numbers a print uses: the named (or given) profile with the user's nozzle and layer."""
    from ..printing.slicer import material_for

    chosen = printer or get_printer(params.printer)
    if chosen.is_resin:
        check_resin(params, chosen)
    else:  # a resin on a nozzle printer: refused here as `estimate` refuses it, not written into a recipe
        material_for(chosen, params.material)
    return chosen.with_overrides(params.nozzle_mm, params.layer_mm)


def check_up_front(params: LithoParams) -> PrinterProfile:
    """What a run refuses before any work, as a usage error (ParameterError): the printer, a resin
    printer's limits and a braille table liblouis does not have. Returns the printer."""
    from ..tactile.braille import check_table_name

    check_table_name(params.braille_table)
    return resolve_printer(params)


def check_resin(params: LithoParams, printer: PrinterProfile) -> None:
    """One clear error for what a resin printer cannot do: two colours, a nozzle, a layer outside its range
    (or, to slice with PrusaSlicer, one its presets lack), a filament."""
    from ..errors import ParameterError
    from ..printing.slicer import material_for

    if params.multicolour:
        raise ParameterError(f"`multicolour`: the {printer.name} is a resin printer and prints one resin at a time; "
                             "leave `multicolour` off (the braille and scale bar are raised in the same resin).")
    if params.nozzle_mm is not None:
        raise ParameterError(f"`nozzle_mm`: the {printer.name} is a resin printer and has no nozzle; got {params.nozzle_mm:g} mm. "
                             f"Leave `nozzle_mm` unset (the presets follow its {printer.nozzle_mm:g} mm feature width).")
    layer = params.layer_mm
    if layer is not None and printer.layers_mm and not printer.layers_mm[0] - 1e-9 <= layer <= printer.layers_mm[1] + 1e-9:
        low, high = printer.layers_mm
        raise ParameterError(f"`layer_mm`: the {printer.name} makes layers of {low:g} to {high:g} mm; got {layer:g} mm. "
                             f"Choose a layer height in that range, or leave `layer_mm` unset for {printer.layer_mm:g} mm.")
    if params.gcode and layer is not None:
        _check_sla_layer(printer, layer)
    material_for(printer, params.material)


def _check_sla_layer(printer: PrinterProfile, layer_mm: float) -> None:
    """To slice for a PrusaSlicer SLA preset, the layer must be one of its print presets' layers."""
    from ..errors import ParameterError
    from ..printing.printer_table import find_printer, sla_preset
    from ..printing.prusa_presets import sla_layers_mm

    model = find_printer(printer.name)
    preset = sla_preset(model) if model else None
    if preset is None:
        return
    made = sla_layers_mm(preset)
    if not any(abs(layer_mm - v) < 1e-9 for v in made):
        raise ParameterError(f"`layer_mm`: PrusaSlicer slices the {printer.name} at layers of "
                             f"{', '.join(f'{v:g}' for v in made)} mm; got {layer_mm:g} mm. Choose one of them for `gcode`.")


def layout_for(params: LithoParams, printer: PrinterProfile, image_w_px: int, *, image_h_px: int, preset: str | None = None) -> Layout:
    """Print size and grid for an image of this size under these parameters (and preset)."""
    return plan_layout(
        image_w_px, image_h_px, width_mm=params.width_mm, depth_mm=params.depth_mm, default_width_mm=printer.width_mm,
        fit=params.fit, preset=preset or params.preset, nozzle_mm=printer.nozzle_mm, resolution_px=params.resolution_px,
        blur_px=params.blur_px, blur_mm=params.blur_mm,
    )
