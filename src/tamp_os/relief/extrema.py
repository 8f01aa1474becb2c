"""h-maxima of a 2-D float picture: scikit-image's `morphology.h_maxima`, the same pixels, in
about half its time.

scikit-image reconstructs by dilation with its downhill filter (a compiled loop over the pixels
in rank order), and sorts the padded seed-and-mask array twice to get there: once for the order,
once (in `rank_order`) for each value's rank. The ranks follow from the first sort, so here it is
sorted once; the loop is given the arrays scikit-image would give it, and the loop is
scikit-image's own. Only the order among equal values may differ (float32 pictures are sorted as
64-bit keys of value and index, a SIMD sort, where an argsort takes 4-5 times longer): the loop
raises each pixel in rank order, so what it reaches, the reconstruction, is the same whichever of
two equal values comes first. Where that loop is not importable as it is in the versions we know,
scikit-image's h_maxima runs instead.
"""

from __future__ import annotations

import numpy as np

from .order import float32_keys, sorted_pairs


def h_maxima(image: np.ndarray, h: float) -> np.ndarray:
    """skimage.morphology.h_maxima(image, h) (uint8) for a 2-D float `image` and the default
    footprint (all eight neighbours); other pictures, and h <= 0 (an error there), go to scikit-image."""
    from skimage import morphology

    loop = _reconstruction_loop()
    if loop is None or image.ndim != 2 or not np.issubdtype(image.dtype, np.floating) or not h > 0:
        return morphology.h_maxima(image, h)
    if h > np.ptp(image):
        return np.zeros(image.shape, dtype=np.uint8)
    # As scikit-image: the seed lies h (and a rounding allowance) under the picture.
    resolution = 2 * np.finfo(image.dtype).resolution * np.abs(image)
    shifted = image - h - resolution
    residue = image - _reconstruct(shifted, image, loop)
    return (residue >= h).astype(np.uint8)


def _reconstruction_loop():
    try:
        from skimage.morphology._grayreconstruct import reconstruction_loop
    except ImportError:
        return None
    return reconstruction_loop


def _reconstruct(seed: np.ndarray, mask: np.ndarray, loop) -> np.ndarray:
    """skimage.morphology.reconstruction(seed, mask, method="dilation") for 2-D float arrays with
    seed <= mask, with the arrays that function hands its loop (its order among equal values may
    differ: the loop's result, the reconstruction, does not depend on it)."""
    rows, cols = seed.shape
    padded = (rows + 2, cols + 2)
    dtype = np.float32 if mask.dtype in (np.float16, np.float32) else np.float64
    images = np.full((2, *padded), np.min(seed), dtype=dtype)
    images[0, 1:-1, 1:-1] = seed
    images[1, 1:-1, 1:-1] = mask
    size = images.size
    signed = np.result_type(np.min_scalar_type(-size), np.int32)
    unsigned = np.dtype(signed.char.upper())
    # The eight neighbours in scikit-image's order (its footprint's mgrid, row by row).
    strides = np.array([dy * padded[1] + dx for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx], signed)
    flat = images.reshape(-1)
    ascending, distinct = _ascending(flat)
    # The loop walks the pixels from the highest: each one's previous is the next higher, its
    # following the next lower (scattered through intp indices read forwards: twice as fast).
    linked = ascending.astype(signed)
    prev = np.full(size, -1, signed)
    following = np.full(size, -1, signed)
    prev[ascending[:-1]] = linked[1:]
    following[ascending[1:]] = linked[:-1]
    # Each value's rank among the distinct values, from the same sort (rank_order sorts again).
    step = np.empty(size, unsigned)
    step[0] = 0
    np.cumsum(distinct, out=step[1:], dtype=unsigned)
    ranks = np.empty(size, unsigned)
    ranks[ascending] = step
    values = flat[ascending[np.concatenate([[True], distinct])]]
    loop(ranks, prev, following, strides, linked[-1], padded[0] * padded[1])
    return values[ranks[: padded[0] * padded[1]]].reshape(padded)[1:-1, 1:-1]


def _ascending(flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The indices that sort `flat` (1-D float) ascending, and whether each sorted value differs
    from the one before it (size - 1 bools). float32 without NaN: one sort of 64-bit keys, the
    value's bits ordered as numbers above the index (NumPy's SIMD sort: several times faster
    than an argsort); equal values then come in index order. Else NumPy's argsort."""
    bits = float32_keys(flat) if flat.dtype == np.float32 and flat.size < 1 << 32 else None
    if bits is None:
        ascending = np.argsort(flat)
        ordered = flat[ascending]
        return ascending, ordered[:-1] != ordered[1:]
    value, index = sorted_pairs(bits, np.arange(flat.size, dtype=np.uint32))
    return index.astype(np.intp), value[:-1] != value[1:]
