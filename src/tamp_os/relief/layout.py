"""Print size and output grid from the image's aspect ratio, the printer and the preset."""

from __future__ import annotations

from dataclasses import dataclass

from ..printers import preset_blur_px, preset_resolution_px


@dataclass(frozen=True)
class Layout:
    width_mm: float
    depth_mm: float  # along y: the image's height on the print
    cols: int
    rows: int
    target_aspect: float  # depth / width the image is fitted to
    fit: str  # pad, crop or stretch (how the image meets that aspect)
    sigma_px: float
    warnings: tuple[str, ...] = ()

    @property
    def mm_per_px(self) -> float:
        return self.width_mm / (self.cols - 1)


def plan_layout(
    image_w_px: int,
    image_h_px: int,
    *,
    width_mm: float | None,
    height_mm: float | None,
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
    if width_mm is None and height_mm is None:
        width_mm = default_width_mm
    if height_mm is None:
        height_mm = width_mm * aspect
    elif width_mm is None:
        width_mm = height_mm / aspect
    elif abs(height_mm / width_mm - aspect) > 0.01 * aspect and fit is None:
        suggested = width_mm * aspect
        warnings.append(
            f"width {width_mm:g} mm and height {height_mm:g} mm do not match the image's aspect ratio; "
            f"the image was padded at base level to fit. For no padding set height_mm to {suggested:.1f} "
            f"(or set fit to crop, or to stretch to distort it)."
        )
    if fit is None:
        fit = "pad"
    cols = resolution_px or preset_resolution_px(preset, nozzle_mm, width_mm)
    rows = max(2, round((cols - 1) * height_mm / width_mm) + 1)
    mm_per_px = width_mm / (cols - 1)
    if blur_mm is not None:
        sigma_px = blur_mm / mm_per_px
    elif blur_px is not None:
        sigma_px = blur_px
    else:
        sigma_px = preset_blur_px(preset)
    return Layout(
        width_mm=float(width_mm),
        depth_mm=float(height_mm),
        cols=int(cols),
        rows=int(rows),
        target_aspect=float(height_mm / width_mm),
        fit=fit,
        sigma_px=float(sigma_px),
        warnings=tuple(warnings),
    )
