"""Which outputs suit a printer, in words a front end shows beside its printer choice (issues 33.2
and 38): a printer whose slicer reads the 3MF's print settings is printed from the 3MF, a resin
printer from the STL or 3MF laid flat, a generic profile from the STL.
"""

from __future__ import annotations

from dataclasses import dataclass

from .printer_table import find_printer, sla_preset


@dataclass(frozen=True)
class Suited:
    formats: tuple[str, ...]  # the outputs to tick by default for this printer
    words: str  # one plain sentence: what to print from, and why


def suited_outputs(printer: str, layer_mm: float) -> Suited:
    """The default outputs for `printer` (a profile name or a printer of the table) and why, at the
    profile's `layer_mm`; the words name the web app's controls."""
    model = find_printer(printer)
    if model is None:
        return Suited(("stl",), "A generic profile: the STL suits any slicer; set the layer height there "
                                f"({layer_mm:g} mm).")
    if model.is_resin:
        sliced = (f" \"Also slice with PrusaSlicer\" writes the {model.model}'s own print file (.sl1s)."
                  if sla_preset(model) else "")
        return Suited(("stl",), f"A resin printer: print the STL (or 3MF) flat on the platform, with no supports, at "
                                f"{layer_mm:g} mm layers in the vendor's slicer.{sliced}")
    # print_settings.py: PrusaSlicer and OrcaSlicer apply the 3MF's settings; Bambu Studio opens its
    # geometry only (it trusts settings from its own 3MFs), so its user picks the layer by hand
    slicer = "PrusaSlicer" if model.prusa_presets else "OrcaSlicer"
    bambu = f" In Bambu Studio, choose the {layer_mm:g} mm process by hand." if model.bambu_model else ""
    return Suited(("3mf",), f"Print from the 3MF: {slicer} opens it with its print settings ({layer_mm:g} mm layers, "
                            f"no supports); the STL carries none.{bambu}")
