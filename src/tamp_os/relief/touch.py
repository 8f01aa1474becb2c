"""Suggest a preset (grid density) by what a fingertip can feel at the print size.

A finer grid only helps when the picture holds real structure between the nozzle width and
about 1 mm at the print size; a fingertip feels anything finer as roughness. Noise is never a
reason for a finer grid: a noisy picture gets Low, whose coarser grid smooths the grain away.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .preprocess import resample, stretch
from .scales import gaussian_mm

NOISY = 0.35  # noise standard deviation ÷ the picture's, above which the picture is noise-led
MOSTLY_NOISE = 0.85  # above this the picture is almost all noise (white noise gives 1.0; the real fixtures 0.0-0.73)
NOISE_SAMPLE_PX = 512  # the noise share is measured on a centre crop at most this wide and high
FINE_FEELABLE = 0.15  # share of variance between 2 nozzle widths and 1 mm that justifies High


@dataclass(frozen=True)
class TouchSuggestion:
    """preset: low, medium or high; reason: one sentence in millimetres; figures behind it."""

    preset: str
    reason: str
    noise_ratio: float
    fine_share: float
    coarse_pitch_mm: float


def suggest_by_touch(values: np.ndarray, alpha: np.ndarray | None, *, width_mm: float, nozzle_mm: float) -> TouchSuggestion:
    """Judge the source picture at its print size and suggest a preset.

    Parameters
    ----------
    values : (rows, cols) source pixel values (any dtype; percentiles are taken on them).
    alpha : (rows, cols) opacity or None.
    width_mm : print width in mm.
    nozzle_mm : nozzle diameter in mm.
    """
    image, _, uniform = stretch(values, alpha, 2.0, high_pct=98.0)
    if uniform or float(image.std()) < 1e-6:
        return TouchSuggestion("low", "the picture is uniform, so every grid gives the same flat plate", 0.0, 0.0, 2 * nozzle_mm)
    # Noise measured on the source pixels, relative to the picture's spread.
    noise = noise_sigma(image)
    noise_ratio = noise / float(image.std())
    # The picture as the High grid would sample it: one point per half nozzle width.
    pitch = nozzle_mm / 2
    cols = max(8, min(image.shape[1], int(round(width_mm / pitch)) + 1))
    rows = max(8, round((cols - 1) * image.shape[0] / image.shape[1]) + 1)
    pitch = width_mm / (cols - 1)
    grid = resample(image, rows, cols)
    total = float(grid.var()) or 1.0
    # Variance between two nozzle widths and a fingertip (1 mm): what only a finer grid keeps.
    band = gaussian_mm(grid, nozzle_mm / 2, pitch) - gaussian_mm(grid, 1.0, pitch)
    fine_share = float(band.var()) / total
    if noise_ratio > NOISY:
        source_mm = width_mm / max(image.shape[1] - 1, 1)
        reason = (
            f"the picture is noisy (noise is {noise_ratio:.0%} of its contrast): its pixel-to-pixel grain, "
            f"{source_mm:.2g} mm per source pixel at {width_mm:g} mm wide, is not structure, and Low's "
            f"{2 * nozzle_mm:g} mm grid smooths it instead of printing it as roughness"
        )
        return TouchSuggestion("low", reason, noise_ratio, fine_share, 2 * nozzle_mm)
    if fine_share > FINE_FEELABLE:
        reason = (
            f"{fine_share:.0%} of the picture's contrast lies in clean detail between {2 * nozzle_mm:g} mm and 1 mm at "
            f"{width_mm:g} mm wide (edges and thin lines); High's {nozzle_mm / 2:g} mm grid keeps them crisp"
        )
        return TouchSuggestion("high", reason, noise_ratio, fine_share, 2 * nozzle_mm)
    reason = (
        f"at {width_mm:g} mm wide the picture's structure is coarser than about 1 mm, which Medium's "
        f"{nozzle_mm:g} mm grid carries; a finer grid would add nothing a finger can feel"
    )
    return TouchSuggestion("medium", reason, noise_ratio, fine_share, 2 * nozzle_mm)


def noise_sigma(image: np.ndarray) -> float:
    """Standard deviation of white noise in a picture (Immerkaer, 1996).

    The 3×3 kernel is the difference of two Laplacians, blind to edges and smooth shading, so
    what it sees is mostly noise. Written here because scikit-image's estimator needs
    PyWavelets, which we do not otherwise depend on, and this is three lines.
    """
    if min(image.shape) < 3:
        return 0.0
    kernel = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float64)
    # copy=False: convolve only reads its input, and a float64 picture needs no copy.
    response = ndimage.convolve(image.astype(np.float64, copy=False), kernel)[1:-1, 1:-1]
    return float(np.sqrt(np.pi / 2) * np.abs(response).mean() / 6)


def noise_share(values: np.ndarray, source_range: tuple[float, float]) -> float:
    """Noise standard deviation ÷ the picture's, with the source pixels mapped by `source_range`
    (the contrast stretch's low and high values) to 0..1. The noise is measured on a centre crop of
    at most NOISE_SAMPLE_PX a side (noise is much the same everywhere), the picture's spread on the
    whole picture (every k-th pixel), so an empty centre does not make a picture with structure
    elsewhere look like noise. About 1.0 for white noise, under 0.3 for most micrographs; 0.0 for a
    flat picture."""
    lo, hi = source_range
    if not hi > lo:
        return 0.0

    def unit(a: np.ndarray) -> np.ndarray:
        # In place on one float64 copy: the same numbers as nan_to_num, subtract, divide and clip
        # each making a new array (a tenth of a conversion's warnings on a 1-Mpx picture).
        out = a.astype(np.float64)
        if not np.isfinite(out).all():
            np.nan_to_num(out, copy=False, nan=lo)
        out -= lo
        out /= hi - lo
        return np.clip(out, 0.0, 1.0, out=out)

    rows, cols = values.shape[:2]
    step = max(1, int(np.ceil(np.sqrt(rows * cols / 1e6))))  # at most about a million pixels for the spread
    spread = _std_in_place(unit(values[::step, ::step]))
    if spread <= 1e-6:
        return 0.0
    top, left = max(0, (rows - NOISE_SAMPLE_PX) // 2), max(0, (cols - NOISE_SAMPLE_PX) // 2)
    return noise_sigma(unit(values[top : top + NOISE_SAMPLE_PX, left : left + NOISE_SAMPLE_PX])) / spread


def _std_in_place(x: np.ndarray) -> float:
    """float(x.std()) with the same arithmetic (numpy's _var: the sum over all, divided by the
    count; the deviations squared; their sum divided by the count), but in x's own buffer: std's
    picture-sized float64 temporary cost more than the arithmetic (3.8 -> 1.0 ms on 1024 x 768)."""
    n = x.size
    x -= np.add.reduce(x, axis=None, keepdims=True) / n
    np.multiply(x, x, out=x)
    return float(np.sqrt(np.add.reduce(x, axis=None) / n))
