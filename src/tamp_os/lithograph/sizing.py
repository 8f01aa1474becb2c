"""The printer and the print's size and grid that a set of parameters gives an image: what the
pipeline, the figure's panel words and the presets table all decide from."""

from __future__ import annotations

from ..params import LithoParams
from ..printing.printers import PrinterProfile, get_printer
from ..relief.layout import Layout, plan_layout


def resolve_printer(params: LithoParams, printer: PrinterProfile | None = None) -> PrinterProfile:
    """The printer numbers a print uses: the named (or given) profile with the user's nozzle and layer."""
    return (printer or get_printer(params.printer)).with_overrides(params.nozzle_mm, params.layer_mm)


def layout_for(params: LithoParams, printer: PrinterProfile, image_w_px: int, image_h_px: int, preset: str | None = None) -> Layout:
    """Print size and grid for an image of this size under these parameters (and preset)."""
    return plan_layout(
        image_w_px, image_h_px, width_mm=params.width_mm, depth_mm=params.depth_mm, default_width_mm=printer.width_mm,
        fit=params.fit, preset=preset or params.preset, nozzle_mm=printer.nozzle_mm, resolution_px=params.resolution_px,
        blur_px=params.blur_px, blur_mm=params.blur_mm,
    )
