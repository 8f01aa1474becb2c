"""A few plateaus from a smooth image: thresholds, smooth outlines, no region under a fingertip."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from skimage import filters, measure


def plateau_classes(shape01: np.ndarray, count: int, *, pitch_mm: float, nozzle_mm: float, min_area_mm2: float) -> np.ndarray:
    """Class 0..count-1 of every pixel: multi-level Otsu, outlines smoothed, small regions merged.

    Parameters
    ----------
    shape01 : (rows, cols) float, 0..1, already smooth at fingertip scale.
    count : number of classes, 2–5.
    pitch_mm : grid pitch in mm per pixel.
    nozzle_mm : outlines are smoothed at the nozzle's width.
    min_area_mm2 : regions smaller than this are merged into their neighbours.

    Returns
    -------
    (rows, cols) int32 classes, 0 = lowest.
    """
    if np.ptp(shape01) <= 1e-6:
        return np.zeros(shape01.shape, np.int32)
    thresholds = filters.threshold_multiotsu(shape01, classes=count)
    classes = np.digitize(shape01, thresholds).astype(np.int32)
    classes = _smooth_outlines(classes, count, nozzle_mm / pitch_mm)
    min_px = max(1, int(np.ceil(min_area_mm2 / pitch_mm**2)))
    for _ in range(4):  # merging can, rarely, leave a new small region: repeat a few times
        classes, merged = _merge_small(classes, min_px)
        if not merged:
            break
    return classes


def _smooth_outlines(classes: np.ndarray, count: int, sigma_px: float) -> np.ndarray:
    """Majority vote of each class's blurred indicator: outlines lose their pixel steps and
    slivers narrower than about a nozzle width."""
    # Kept as a running best rather than np.argmax over a stack: argmax along the first axis
    # walks memory with a stride and takes 3x longer. Ties keep the lower class, as argmax does.
    best = np.full(classes.shape, -np.inf, np.float32)
    out = np.zeros(classes.shape, np.int32)
    for k in range(count):
        vote = ndimage.gaussian_filter((classes == k).astype(np.float32), max(sigma_px, 0.7))
        higher = vote > best
        out[higher] = k
        best = np.maximum(best, vote)
    return out


def _merge_small(classes: np.ndarray, min_px: int) -> tuple[np.ndarray, bool]:
    """Give every region smaller than min_px the class of its nearest large region."""
    regions = measure.label(classes, background=-1, connectivity=1)
    areas = np.bincount(regions.ravel())
    small = areas[regions] < min_px
    if not small.any():
        return classes, False
    if small.all():
        return np.zeros_like(classes), True
    # Nearest pixel of a large region, for every pixel (scipy's exact Euclidean transform).
    _, (iy, ix) = ndimage.distance_transform_edt(small, return_indices=True)
    return classes[iy, ix], True
