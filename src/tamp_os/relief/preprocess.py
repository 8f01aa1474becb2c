"""From source pixel values to a normalized image in [0, 1] on the output grid.

Order matters and is fixed: the percentile stretch runs on the source values (so the output
resolution never changes what counts as dark or bright), then the picture is fitted to the
print's aspect, resampled with antialiasing in float, blurred, inverted and weighted by opacity.
Row 0 stays the top of the image here; mesh.py places it at the far edge of the print.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from .order import percentiles


# A tail of the picture is a distinct population (sparse content: ink strokes on paper, a few
# beads on an empty ground) when its pixels lie over DISTINCT_SIGMAS noise deviations from the
# ground's median, and half of them over DISTINCT_MEDIAN_SIGMAS (a long tail of an ordinary
# picture, as the moon's, hugs the threshold: its median lies just beyond it)...
DISTINCT_SIGMAS = 8.0
DISTINCT_MEDIAN_SIGMAS = 16.0
# ...holds at least this share of the usable pixels (fewer are specks, hot pixels or dust)...
DISTINCT_MIN_SHARE = 2e-4
# ...and at least this share of it touches another of its pixels (shapes, not scattered noise).
DISTINCT_MIN_CLUSTERED = 0.5
SUBSAMPLE_PX = 1 << 20  # pixels enough to measure the ground's median and noise


def _noise_sd(quartiles: np.ndarray, low: float, high: float) -> float:
    """The ground's own spread: the interquartile range as a normal deviation, or a quarter of
    the span between the stretch's percentiles when that is wider (a ground quantised to one or
    two grey levels has no interquartile range but still a noise band)."""
    return max(float(quartiles[1] - quartiles[0]) / 1.349, float(high - low) / 4.0)


def _clustered_share(tail: np.ndarray) -> float:
    """Share of the True pixels of a 2-D mask that have a True 4-neighbour."""
    near = np.zeros_like(tail)
    near[1:] |= tail[:-1]
    near[:-1] |= tail[1:]
    near[:, 1:] |= tail[:, :-1]
    near[:, :-1] |= tail[:, 1:]
    count = int(np.count_nonzero(tail))
    return int(np.count_nonzero(tail & near)) / count if count else 0.0


def _content_extreme(values, usable, sample_size, tail_of, pct):
    """The `pct` percentile of the pixels `tail_of(values)` selects, or None when they are fewer
    than DISTINCT_MIN_SHARE of `sample_size` or mostly touch none of their own kind."""
    with np.errstate(invalid="ignore"):
        tail = tail_of(values)
    if usable is not None:
        tail &= usable
    if np.count_nonzero(tail) < DISTINCT_MIN_SHARE * sample_size or tail.ndim != 2 or _clustered_share(tail) < DISTINCT_MIN_CLUSTERED:
        return None
    return float(percentiles(values[tail], [pct])[0])


def _subsample_step(sample_size: int, row_px: int) -> int:
    """Every how many pixels the ground's statistics look (see _distinct_tails)."""
    step = max(1, sample_size // SUBSAMPLE_PX)
    while step > 1 and math.gcd(step, row_px) != 1:
        step += 1
    return step


def _distinct_tails(values, usable, sample, low_pct, high_pct, low, high, quartiles=None):
    """(low, high) with each end that fell in the ground's noise while a distinct population lies
    beyond it moved to that population's own percentile (see stretch). The ground's median and
    spread, and a first look at each tail, come from at most SUBSAMPLE_PX evenly spaced pixels
    (a statistic of the noise needs no more); a tail that passes is measured on every pixel.
    The step between them shares no factor with the row length, so every column is visited
    (a one-pixel vertical stroke is not stepped over). `quartiles`: those of that subsample,
    when the caller has them."""
    sub = sample[:: _subsample_step(sample.size, values.shape[-1])]
    q1, median, q3 = percentiles(sub, [25.0, 50.0, 75.0]) if quartiles is None else quartiles
    noise_sd = _noise_sd(np.array([q1, q3]), low, high)
    far, very_far = DISTINCT_SIGMAS * noise_sd, DISTINCT_MEDIAN_SIGMAS * noise_sd

    def distinct(tail: np.ndarray) -> bool:  # a population apart, not a long tail hugging the threshold
        return tail.size > 0 and abs(float(np.median(tail)) - median) >= very_far

    if low_pct > 0 and median - far <= low and distinct(sub[sub < median - far]):
        level = _content_extreme(values, usable, sample.size, lambda v: v < median - far, low_pct)
        low = low if level is None else level
    if high_pct < 100 and high <= median + far and distinct(sub[sub > median + far]):
        level = _content_extreme(values, usable, sample.size, lambda v: v > median + far, high_pct)
        high = high if level is None else level
    return low, high


def _all_finite(values: np.ndarray) -> bool:
    """Whether every value is finite: min and max propagate NaN, and with no NaN an infinity is
    one of them. Two reductions in the values' own type, not a float64 sum (a converted copy of
    every pixel)."""
    return values.size == 0 or bool(np.isfinite(values.min()) and np.isfinite(values.max()))


def stretch(values: np.ndarray, alpha: np.ndarray | None, low_pct: float, *, high_pct: float):
    """Map the low..high percentiles of the opaque, finite source pixels to 0..1 (clipped).

    Sparse content keeps its contrast. When a percentile lies in the ground's noise (within
    DISTINCT_SIGMAS noise deviations of the median) and beyond that distance lies a distinct
    population (half of it over DISTINCT_MEDIAN_SIGMAS away, at least DISTINCT_MIN_SHARE of the
    picture, mostly in touching pixels: ink strokes on paper, a few beads on an empty ground),
    clipping at the percentile would make the content as dark (or bright) as the noise's
    extremes and spread the noise over the whole range; that end is taken instead at the same
    percentile of the content itself. Other pictures keep the plain percentile stretch.

    Returns (normalized float32 image with unknown pixels at 0, (low, high) source values,
    uniform flag). A uniform image (low == high) is all zeros: a flat plate.
    """
    clean = alpha is None and _all_finite(values)
    usable = None
    if clean:
        sample = values.ravel()  # all finite and opaque: no masked copy needed
    else:
        usable = np.isfinite(values)
        if alpha is not None:
            usable &= alpha > 0
        sample = values[usable]
    if sample.size == 0:
        return np.zeros(values.shape, np.float32), (0.0, 0.0), True
    # A picture of up to SUBSAMPLE_PX pixels is its own subsample: its quartiles come from the
    # same partition as the stretch's percentiles (the same order statistics, one pass fewer).
    whole = _subsample_step(sample.size, values.shape[-1]) == 1
    low, high, *quartiles = percentiles(sample, [low_pct, high_pct] + ([25.0, 50.0, 75.0] if whole else []))
    if not high > low:  # percentiles can coincide in mostly flat images: fall back to the full range
        low, high = float(sample.min()), float(sample.max())
    else:
        low, high = _distinct_tails(values, usable, sample, low_pct, high_pct, float(low), float(high), quartiles if whole else None)
    if not high > low:
        return np.zeros(values.shape, np.float32), (float(low), float(high)), True
    out = (values - np.float32(low)) / np.float32(high - low)
    if not clean:
        out = np.nan_to_num(out, nan=0.0)
    np.clip(out, 0.0, 1.0, out=out)
    return out.astype(np.float32, copy=False), (float(low), float(high)), False


def fit_aspect(image: np.ndarray, alpha: np.ndarray | None, target_aspect: float, *, mode: str):
    """Make image (H×W) match target_aspect = height/width by padding or cropping (centred).

    Padding is transparent (alpha 0), so it prints at base level. 'stretch' returns it unchanged,
    as does an image already within one pixel of the aspect. alpha stays None when all is opaque.
    """
    h, w = image.shape
    if mode == "stretch" or (round(w * target_aspect) == h or round(h / target_aspect) == w):
        return image, alpha
    if mode == "crop":
        if h / w > target_aspect:
            new_h = max(2, round(w * target_aspect))
            rows = slice((h - new_h) // 2, (h - new_h) // 2 + new_h)
            return image[rows], None if alpha is None else alpha[rows]
        new_w = max(2, round(h / target_aspect))
        cols = slice((w - new_w) // 2, (w - new_w) // 2 + new_w)
        return image[:, cols], None if alpha is None else alpha[:, cols]
    if alpha is None:
        alpha = np.ones_like(image)
    if h / w > target_aspect:
        new_w = round(h / target_aspect)
        pad = ((0, 0), ((new_w - w) // 2, new_w - w - (new_w - w) // 2))
    else:
        new_h = round(w * target_aspect)
        pad = (((new_h - h) // 2, new_h - h - (new_h - h) // 2), (0, 0))
    return np.pad(image, pad), np.pad(alpha, pad)


def resample(image: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Antialiased resize in float32: Pillow's triangle filter, widened when shrinking.

    Pillow's float ('F') resize is 10-15x faster than scikit-image's resize with anti-aliasing
    and, unlike Lanczos, never overshoots the input range.
    """
    if image.shape == (rows, cols):
        return image.astype(np.float32, copy=False)
    from PIL import Image

    picture = Image.fromarray(np.ascontiguousarray(image, dtype=np.float32))
    return np.asarray(picture.resize((cols, rows), Image.Resampling.BILINEAR), dtype=np.float32)


def blur(image: np.ndarray, sigma_px: float) -> np.ndarray:
    if sigma_px <= 0:
        return image
    return ndimage.gaussian_filter(image, sigma=sigma_px, mode="nearest").astype(np.float32)


def renormalize(image: np.ndarray) -> np.ndarray:
    """Spread to exactly 0..1 again after resampling and blur, so the relief reaches its full height."""
    low, high = float(image.min()), float(image.max())
    if high - low < 1e-6:
        return np.zeros_like(image)
    return ((image - low) / (high - low)).astype(np.float32)


@dataclass(frozen=True)
class Prepared:
    image: np.ndarray  # float32 (rows, cols) in 0..1, row 0 = top of the picture
    stretch_source_range: tuple[float, float]  # source values mapped to 0 and 1
    uniform: bool  # every usable source pixel had the same value
    fitted_width_px: float  # source pixels across the picture after padding or cropping to the aspect
    # The stretched source fitted to the aspect, before resampling and blur (and its alpha, and
    # whether the picture is inverted or mirrored): `finer` draws the picture on a finer grid from it.
    fitted: np.ndarray | None = field(default=None, repr=False, compare=False)
    fitted_alpha: np.ndarray | None = field(default=None, repr=False, compare=False)
    invert: bool = False
    flip_x: bool = False

    def finer(self, cols: int) -> np.ndarray | None:
        """The picture `cols` wide on the output grid's aspect (or the source itself when it is
        no wider), stretched, inverted and mirrored as `image` is but neither blurred nor renormalised: lines
        thinner than a print pixel, which the print grid's resampling and blur fade, are still
        there. None when the picture is uniform or was prepared without its source."""
        if self.fitted is None or self.uniform:
            return None
        out_rows, out_cols = self.image.shape
        cols = int(min(cols, self.fitted.shape[1]))
        rows = max(2, round((out_rows - 1) * (cols - 1) / max(out_cols - 1, 1)) + 1)
        if cols == self.fitted.shape[1]:
            # The source itself (its aspect differs from the grid's by the grid's rounding at
            # most): a resample by a few rows would smear one-pixel lines.
            rows = self.fitted.shape[0]
        image = resample(self.fitted, rows, cols)
        if self.invert:
            image = 1.0 - image
        if self.fitted_alpha is not None:
            image = image * np.clip(resample(self.fitted_alpha, rows, cols), 0.0, 1.0)
        if self.flip_x:
            image = image[:, ::-1]
        return np.ascontiguousarray(image, dtype=np.float32)


def prepare(
    values: np.ndarray,
    alpha: np.ndarray | None,
    *,
    rows: int,
    cols: int,
    target_aspect: float,
    fit: str,
    low_pct: float,
    high_pct: float,
    sigma_px: float,
    invert: bool,
    flip_x: bool,
):
    """The whole preprocessing chain: stretch on the source, fit the aspect, resample to rows × cols,
    blur by `sigma_px` grid pixels, invert and mirror as asked. See `Prepared` for the result."""
    image, (low, high), uniform = stretch(values, alpha, low_pct, high_pct=high_pct)
    image, alpha = fit_aspect(image, alpha, target_aspect, mode=fit)
    fitted, fitted_alpha = image, alpha
    fitted_width_px = image.shape[1]
    image = resample(image, rows, cols)
    image = blur(image, sigma_px)
    if not uniform:
        image = renormalize(image)
    if invert and not uniform:
        image = 1.0 - image
    if alpha is not None:
        image = image * np.clip(resample(alpha, rows, cols), 0.0, 1.0)
    if flip_x:
        image = image[:, ::-1]
    return Prepared(np.ascontiguousarray(image, dtype=np.float32), (low, high), uniform, fitted_width_px, fitted, fitted_alpha, invert, flip_x)
