"""Look at an image and suggest a preset, as the reference's image check does: low contrast or
heavy clipping favour Low (fine grids would print noise), much fine detail favours High."""

from __future__ import annotations

import numpy as np

from .preprocess import blur, resample, stretch


def image_stats(values: np.ndarray, alpha: np.ndarray | None) -> dict:
    finite = values[np.isfinite(values)]
    lo, hi = float(finite.min()), float(finite.max())
    p2, p98 = np.percentile(finite, [2, 98])
    dynamic_range = float((p98 - p2) / (hi - lo)) if hi > lo else 0.0
    clipped = float(((finite <= lo) | (finite >= hi)).mean()) if hi > lo else 1.0
    image, _, uniform = stretch(values, alpha, 2.0, 98.0)
    # Detail: how much of the picture lives at scales finer than ~2 px on a 512 px grid.
    cols = min(512, image.shape[1])
    rows = max(2, round(cols * image.shape[0] / image.shape[1]))
    small = resample(image, rows, cols)
    detail = float(np.abs(small - blur(small, 2.0)).mean()) if not uniform else 0.0
    return {"dynamic_range": dynamic_range, "clipped_fraction": clipped, "detail": detail, "uniform": uniform}


def suggest_preset(stats: dict) -> tuple[str, str]:
    """(preset, reason in words)."""
    if stats["uniform"]:
        return "low", "the image is uniform, so any grid gives a flat plate"
    if stats["dynamic_range"] < 0.15 or stats["clipped_fraction"] > 0.25:
        return "low", (
            f"low contrast (middle 96 % of values span {stats['dynamic_range']:.0%} of the range) or heavy "
            f"clipping ({stats['clipped_fraction']:.0%} of pixels at the extremes): finer grids would print noise"
        )
    if stats["detail"] > 0.06:
        return "high", f"much fine detail (score {stats['detail']:.3f} > 0.06) that a finer grid keeps"
    return "medium", f"ordinary contrast and detail (score {stats['detail']:.3f})"
