"""Numbers from the tactile standards that parameters are checked against: braille dot sizes and
spacings, and the default braille table. A foundation module (no stage imports), so that the
parameters can check themselves without importing the tactile stage."""

from __future__ import annotations

from dataclasses import dataclass

from .errors import ParameterError

DEFAULT_TABLE = "en-ueb-g2.ctb"


@dataclass(frozen=True)
class BrailleSpec:
    """Dot and spacing sizes in mm; defaults follow Marburg Medium / printed-dome practice."""

    dot_diameter_mm: float = 1.5
    dot_height_mm: float = 0.7
    dot_spacing_mm: float = 2.5
    cell_spacing_mm: float = 6.0
    line_spacing_mm: float = 10.0

    RANGES = {
        "dot_diameter_mm": (1.2, 2.0),
        "dot_height_mm": (0.4, 1.2),
        "dot_spacing_mm": (2.0, 3.0),
        "cell_spacing_mm": (5.0, 8.0),
        "line_spacing_mm": (8.0, 15.0),
    }

    def __post_init__(self):
        for name, (lo, hi) in self.RANGES.items():
            value = getattr(self, name)
            if not lo <= value <= hi:
                raise ParameterError(
                    f"braille `{name}`: must be {lo}–{hi} mm (tactile standards: NLS Spec 800, ADA 703.3, "
                    f"Marburg Medium); got {value}."
                )
        if self.dot_diameter_mm > self.dot_spacing_mm - 0.4:
            raise ParameterError(
                f"braille `dot_diameter_mm` {self.dot_diameter_mm} must be at least 0.4 mm smaller than "
                f"`dot_spacing_mm` {self.dot_spacing_mm}, or neighbouring dots merge."
            )

    @property
    def cell_height_mm(self) -> float:
        return 2 * self.dot_spacing_mm + self.dot_diameter_mm
