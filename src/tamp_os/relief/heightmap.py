"""Normalized image (0..1) -> heights in millimetres: base + relief × value."""

from __future__ import annotations

import numpy as np


def heights_mm(image: np.ndarray, *, base_mm: float, relief_mm: float, layer_mm: float | None = None) -> np.ndarray:
    """Heights of each grid point. With layer_mm, the relief is rounded to whole layers."""
    relief = image.astype(np.float64) * relief_mm
    if layer_mm:
        relief = np.minimum(np.round(relief / layer_mm) * layer_mm, relief_mm)
    return base_mm + relief
