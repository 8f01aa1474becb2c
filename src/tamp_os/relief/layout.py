"""Print size and output grid from the image's aspect ratio, the printer and the preset."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import ParameterError, Text
from ..printing.printers import preset_blur_px, preset_resolution_px

# The coarsest grid a relief is drawn on: the largest `detail_mm` (its shapes are at least one
# grid step). Coarser, the detail check named a range whose low end was above its high end.
MAX_PITCH_MM = 50.0


@dataclass(frozen=True)
class Layout:
    width_mm: float
    depth_mm: float  # along y: the image's height on the print
    cols: int
    rows: int
    target_aspect: float  # depth / width the image is fitted to
    fit: str  # pad, crop or stretch (how the image meets that aspect)
    blur_px: float  # Gaussian blur sigma in grid pixels (from blur_px, blur_mm or the preset)
    warnings: tuple[str, ...] = ()

    @property
    def mm_per_px(self) -> float:
        return self.width_mm / (self.cols - 1)


def plan_layout(
    image_w_px: int,
    image_h_px: int,
    *,
    width_mm: float | None,
    depth_mm: float | None,
    default_width_mm: float,
    fit: str | None,
    preset: str,
    nozzle_mm: float,
    resolution_px: int | None,
    blur_px: float | None,
    blur_mm: float | None,
) -> Layout:
    aspect = image_h_px / image_w_px
    warnings: list[str] = []
    if width_mm is None and depth_mm is None:
        width_mm = default_width_mm
    if depth_mm is None:
        depth_mm = width_mm * aspect
    elif width_mm is None:
        width_mm = depth_mm / aspect
    elif abs(depth_mm / width_mm - aspect) > 0.01 * aspect and fit is None:
        suggested = width_mm * aspect
        warnings.append(Text(
            f"width {width_mm:g} mm and depth {depth_mm:g} mm do not match the image's aspect ratio; "
            f"the image was padded at base level to fit. For no padding set `depth_mm` to {suggested:.1f} "
            f"(or set fit to crop, or to stretch to distort it)."
        ))
    if fit is None:
        fit = "pad"
    cols = resolution_px or preset_resolution_px(preset, nozzle_mm, width_mm)
    rows = max(2, round((cols - 1) * depth_mm / width_mm) + 1)
    mm_per_px = width_mm / (cols - 1)
    if mm_per_px > MAX_PITCH_MM:
        least = math.ceil(width_mm / MAX_PITCH_MM) + 1
        raise ParameterError(f"`resolution_px`: {cols} grid points across {width_mm:g} mm are {mm_per_px:.3g} mm apart; a "
                             f"relief needs at most {MAX_PITCH_MM:g} mm, so at least {least} points. Give `resolution_px` "
                             f"{least} or more, or a preset.", parameter="resolution_px", value=cols,
                             allowed=f"{least} to 16384 across {width_mm:g} mm")
    if blur_mm is not None:
        blur = blur_mm / mm_per_px
    elif blur_px is not None:
        blur = blur_px
    else:
        blur = preset_blur_px(preset)
    return Layout(
        width_mm=float(width_mm),
        depth_mm=float(depth_mm),
        cols=int(cols),
        rows=int(rows),
        target_aspect=float(depth_mm / width_mm),
        fit=fit,
        blur_px=float(blur),
        warnings=tuple(warnings),
    )
