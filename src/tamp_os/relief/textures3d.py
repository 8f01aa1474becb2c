"""Tactile textures for 3-D prints: smooth, dots, ridges, cross-hatch, as heights in mm.

Each texture is a pattern on the print grid (`mm_per_px` per grid step), 0..1, that a channel's
region carries. Sizes follow tactile-graphics practice for fingertips: dots at least 1.5 mm
across on a pitch of at least 3 mm, ridges at least 0.8 mm wide on a pitch of at least 2.5 mm,
so that each reads as its own texture and not as noise. At most four textures on one print:
more are not told apart reliably by touch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError

TEXTURES = ("smooth", "dots", "ridges", "crosshatch")
MAX_TEXTURES = 4
DOT_DIAMETER_MM = 1.6
DOT_PITCH_MM = 3.2
RIDGE_WIDTH_MM = 1.0
RIDGE_PITCH_MM = 2.8
HATCH_PITCH_MM = 3.0


@dataclass(frozen=True)
class TextureSpec:
    """One texture: its kind, pitch (mm, centre to centre), feature width (mm), direction (degrees from x)."""

    kind: str
    pitch_mm: float = 0.0
    width_mm: float = 0.0
    angle_deg: float = 0.0


def spec_for(kind: str, angle_deg: float = 0.0) -> TextureSpec:
    if kind == "smooth":
        return TextureSpec("smooth")
    if kind == "dots":
        return TextureSpec("dots", DOT_PITCH_MM, DOT_DIAMETER_MM)
    if kind == "ridges":
        return TextureSpec("ridges", RIDGE_PITCH_MM, RIDGE_WIDTH_MM, angle_deg)
    if kind == "crosshatch":
        return TextureSpec("crosshatch", HATCH_PITCH_MM, RIDGE_WIDTH_MM, angle_deg)
    raise ParameterError(f"`channels`: unknown texture {kind!r}; use one of {', '.join(TEXTURES)}.")


def _line_profile(u_mm: np.ndarray, pitch_mm: float, width_mm: float) -> np.ndarray:
    """Rounded (half-cosine) ridges of `width_mm` every `pitch_mm` along u; 0 between them."""
    d = np.abs((u_mm + pitch_mm / 2) % pitch_mm - pitch_mm / 2)  # distance to the nearest ridge centre
    return np.where(d < width_mm / 2, np.cos(np.pi * d / width_mm), 0.0)


def pattern(spec: TextureSpec, shape: tuple[int, int], mm_per_px: float) -> np.ndarray:
    """The texture's 0..1 pattern on a (rows, cols) grid; row 0 = top, x along columns."""
    rows, cols = shape
    if spec.kind == "smooth":
        return np.ones(shape)
    y_mm, x_mm = np.meshgrid(np.arange(rows) * mm_per_px, np.arange(cols) * mm_per_px, indexing="ij")
    if spec.kind == "dots":
        # hexagonal packing: every other row of dots shifted by half a pitch
        row_pitch = spec.pitch_mm * math.sqrt(3) / 2
        k = np.round(y_mm / row_pitch)
        dy = y_mm - k * row_pitch
        shift = np.where(k % 2 == 1, spec.pitch_mm / 2, 0.0)
        dx = (x_mm - shift + spec.pitch_mm / 2) % spec.pitch_mm - spec.pitch_mm / 2
        r2 = (dx ** 2 + dy ** 2) / (spec.width_mm / 2) ** 2
        return np.sqrt(np.clip(1.0 - r2, 0.0, 1.0))  # hemispherical caps
    a = math.radians(spec.angle_deg)
    u = -x_mm * math.sin(a) + y_mm * math.cos(a)  # across ridges running along the angle
    ridges = _line_profile(u, spec.pitch_mm, spec.width_mm)
    if spec.kind == "ridges":
        return ridges
    v = x_mm * math.cos(a) + y_mm * math.sin(a)
    return np.maximum(ridges, _line_profile(v, spec.pitch_mm, spec.width_mm))


def check_resolvable(spec: TextureSpec, mm_per_px: float) -> None:
    """A texture needs at least ~3 grid points across its feature, else it prints as noise."""
    if spec.kind != "smooth" and spec.width_mm < 2.5 * mm_per_px:
        raise ParameterError(
            f"`resolution_px`: the grid pitch {mm_per_px:.2f} mm is too coarse for {spec.kind} "
            f"({spec.width_mm:g} mm features); use a finer preset or a larger `resolution_px`."
        )


def ridge_angle_unlike(image: np.ndarray) -> float:
    """A ridge direction (0, 45, 90 or 135 degrees) unlike the picture's dominant line direction.

    The structure tensor of the whole region gives the dominant orientation of its edges;
    ridges drawn across it stay distinguishable from the picture's own lines.
    """
    gy, gx = np.gradient(image.astype(np.float64))
    jxx, jyy, jxy = (gx * gx).sum(), (gy * gy).sum(), (gx * gy).sum()
    if jxx + jyy <= 0:
        return 0.0
    grad_deg = math.degrees(0.5 * math.atan2(2 * jxy, jxx - jyy))  # gradient direction: across the lines
    line_deg = (grad_deg + 90) % 180
    # choose the candidate furthest from the lines' direction (in the image's y-down frame)
    cands = (0.0, 45.0, 90.0, 135.0)
    return max(cands, key=lambda c: min(abs(c - line_deg) % 180, 180 - abs(c - line_deg) % 180))
