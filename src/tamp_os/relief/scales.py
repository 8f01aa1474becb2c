"""Filters in print millimetres, and the working grid the relief styles compute on.

The styles think at fingertip scale (about 1–2 mm), so a 4096-point grid across 100 mm
(0.024 mm pitch) carries nothing they need that a grid at half the nozzle width does not.
`WorkGrid` shrinks the image to that pitch, the style runs there, and the result is resized
back to the output grid: this keeps a style's extra work well under a second at 4096².
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage


def gaussian_mm(image: np.ndarray, sigma_mm: float, pitch_mm: float) -> np.ndarray:
    """Gaussian low-pass with sigma given on the print.

    Parameters
    ----------
    image : (rows, cols) float array.
    sigma_mm : standard deviation in millimetres on the print (<= 0 returns the image).
    pitch_mm : grid pitch in millimetres per pixel.
    """
    if sigma_mm <= 0:
        return image.astype(np.float32, copy=False)
    return ndimage.gaussian_filter(image.astype(np.float32, copy=False), sigma=sigma_mm / pitch_mm, mode="nearest")


def coarse_gaussian_mm(image: np.ndarray, sigma_mm: float, pitch_mm: float) -> np.ndarray:
    """A wide Gaussian low-pass computed on a grid shrunk to about sigma/4 and resized back.

    Same arguments as `gaussian_mm`. A trend many millimetres wide has nothing at the grid's
    pitch, and a wide kernel on the full grid costs O(sigma) per pixel.
    """
    factor = int(sigma_mm / pitch_mm / 4)
    rows, cols = image.shape
    if factor < 2 or min(rows, cols) // factor < 4:
        return gaussian_mm(image, sigma_mm, pitch_mm)
    small = resize_to(image, (-(-rows // factor), -(-cols // factor)), nearest=False)
    sigma_small_px = sigma_mm / pitch_mm * small.shape[1] / cols
    blurred = ndimage.gaussian_filter(small, sigma=sigma_small_px, mode="nearest")
    return resize_to(blurred, (rows, cols), nearest=False)


def wide_gaussian(image: np.ndarray, sigma_px: float, *, truncate: float = 4.0) -> np.ndarray:
    """ndimage.gaussian_filter(image, sigma_px, mode="nearest") in float32, to float32 rounding
    (measured: 2.4e-7 at most on 0..1 pictures), by FFT of the picture extended by its edge pixels.
    A kernel of 4 sigma each side costs O(sigma) per pixel directly: at sigma 20 px (a 4 mm blur
    on a fine grid) 15 ms against 3.6 ms here. For wide kernels whose result is only measured
    (the lattice spectrum's detail), not printed."""
    import scipy.fft

    radius = int(truncate * sigma_px + 0.5)
    offsets = np.arange(-radius, radius + 1, dtype=np.float64)
    kernel = np.exp(-0.5 * (offsets / sigma_px) ** 2)
    kernel /= kernel.sum()
    rows, cols = image.shape
    shape = (scipy.fft.next_fast_len(rows + 2 * radius, real=True), scipy.fft.next_fast_len(cols + 2 * radius, real=True))

    def centred(n: int) -> np.ndarray:  # the kernel wrapped around index 0: its transform is real
        line = np.zeros(n)
        line[: radius + 1], line[n - radius :] = kernel[radius:], kernel[:radius]
        return line

    spectrum = scipy.fft.rfft2(np.pad(image.astype(np.float32, copy=False), radius, mode="edge"), s=shape)
    spectrum *= scipy.fft.fft(centred(shape[0])).real.astype(np.float32)[:, None]
    spectrum *= scipy.fft.rfft(centred(shape[1])).real.astype(np.float32)[None, :]
    return scipy.fft.irfft2(spectrum, s=shape)[radius : radius + rows, radius : radius + cols]


def disk(radius_px: float) -> np.ndarray:
    """Boolean disk footprint of the given radius in pixels (at least the 3×3 cross)."""
    r = max(1, int(round(radius_px)))
    y, x = np.ogrid[-r : r + 1, -r : r + 1]
    return (x * x + y * y) <= r * r + 0.5


def guided_smooth(image: np.ndarray, radius_px: float, eps: float) -> np.ndarray:
    """Edge-preserving smoothing: the self-guided filter (He, Sun and Tang, 2010).

    Flattens variations whose local variance is below `eps` (in squared image units) over a
    window of `radius_px`, and keeps steps much larger than sqrt(eps). Written here on
    scipy's box filters because neither SciPy nor scikit-image ships it and it costs six box
    filters (linear time at any radius), where a bilateral or total-variation filter of the
    same reach is 10–100× slower.

    Parameters
    ----------
    image : (rows, cols) float array, values about 0..1.
    radius_px : window half-width in pixels.
    eps : regularisation; edges with contrast well above sqrt(eps) are kept.
    """
    size = 2 * max(1, int(round(radius_px))) + 1
    img = image.astype(np.float32, copy=False)

    def box(a):
        return ndimage.uniform_filter(a, size=size, mode="reflect")

    mean = box(img)
    var = np.maximum(box(img * img) - mean * mean, 0.0)
    a = var / (var + np.float32(eps))
    b = mean - a * mean
    return (box(a) * img + box(b)).astype(np.float32)


def robust_unit(image: np.ndarray, low_pct: float = 1.0, high_pct: float = 99.0) -> np.ndarray:
    """Map the low..high percentiles of the image to 0..1 (clipped); all zeros if flat.

    A few extreme pixels (a bright sample edge) then cannot take the whole relief.
    """
    lo, hi = np.percentile(image, [low_pct, high_pct])
    if not hi - lo > 1e-6:
        lo, hi = float(image.min()), float(image.max())
        if not hi - lo > 1e-6:
            return np.zeros(image.shape, np.float32)
    return np.clip((image - lo) / (hi - lo), 0.0, 1.0).astype(np.float32)


# The relief styles (content analysis above all: members, lines, blobs) run on at most this many
# points. A 4:3 plate up to about 500 x 375 mm keeps the nozzle's pitch; a larger one (1000 mm at High
# is 5001 x 3751 print points) is read on a grid coarsened by a whole factor to fit, 0.8 mm at 1000
# mm: still finer than the 1-2 mm a fingertip resolves and than the 1.0 mm lines and 2 mm domes
# the styles draw. Measured on a 160 x 120 noise picture at 1000 mm, High: the content analysis
# took 100 s and 2 GB on the nozzle's 2500 x 1875 grid (issue 40).
WORK_MAX_POINTS = 1_200_000


@dataclass(frozen=True)
class WorkGrid:
    """A coarser grid for a style's computation, and the way back to the output grid.

    shape: (rows, cols) of the output grid; work_shape: the working grid; pitch_mm: the
    working grid's pitch in mm per pixel.
    """

    shape: tuple[int, int]
    work_shape: tuple[int, int]
    pitch_mm: float

    @classmethod
    def plan(cls, shape: tuple[int, int], mm_per_px: float, target_pitch_mm: float,
             *, max_points: float | None = None) -> "WorkGrid":
        """Shrink by a whole factor when the output grid is finer than target_pitch_mm, or by a
        larger one when the working grid would hold more than `max_points` (None: no bound)."""
        rows, cols = shape
        factor = int(target_pitch_mm // mm_per_px)
        if max_points is not None and rows * cols > max_points:
            factor = max(factor, math.ceil(math.sqrt(rows * cols / max_points)))
        if factor < 2 or min(rows, cols) // factor < 16:
            return cls(shape, shape, mm_per_px)
        work = (max(2, round((rows - 1) / factor) + 1), max(2, round((cols - 1) / factor) + 1))
        pitch = mm_per_px * (cols - 1) / (work[1] - 1)
        return cls(shape, work, pitch)

    @property
    def resized(self) -> bool:
        return self.work_shape != self.shape

    def down(self, image: np.ndarray) -> np.ndarray:
        """Output grid -> working grid (antialiased)."""
        if not self.resized:
            return image.astype(np.float32, copy=False)
        return resize_to(image, self.work_shape, nearest=False)

    def up(self, image: np.ndarray, nearest: bool = False) -> np.ndarray:
        """Working grid -> output grid (bilinear; nearest keeps plateaus as exact steps)."""
        if not self.resized:
            return image
        return resize_to(image, self.shape, nearest=nearest)


def resize_to(image: np.ndarray, shape: tuple[int, int], nearest: bool) -> np.ndarray:
    # Pillow's float resize: 10-15x faster than skimage.transform.resize with antialiasing.
    from PIL import Image

    picture = Image.fromarray(np.ascontiguousarray(image, dtype=np.float32))
    method = Image.Resampling.NEAREST if nearest else Image.Resampling.BILINEAR
    return np.asarray(picture.resize((shape[1], shape[0]), method), dtype=np.float32)


@dataclass(frozen=True)
class StyleOptions:
    """Settings of the relief styles (all lengths on the print, in mm).

    detail_mm : finest shape a finger should read as shape; finer detail becomes texture.
    texture_mm : peak-to-peak height of that fine texture (0 = none).
    level_count : plateaus of the `levels` style, 2–5.
    min_area_mm2 : smallest region (`levels`) or object (`objects`) kept: about a fingertip.
    nozzle_mm : nozzle diameter; outlines are smoothed at this scale.
    """

    detail_mm: float = 2.0
    texture_mm: float = 0.3
    level_count: int = 3
    min_area_mm2: float = 6.0
    nozzle_mm: float = 0.4


def large_shape(work: np.ndarray, pitch_mm: float, options: StyleOptions) -> np.ndarray:
    """Fingertip-scale shape of the picture, 0..1 (working grid).

    Noise is first damped by a Gaussian of detail/4; the self-guided filter then flattens
    what varies less than about 0.1 of the range within `detail_mm` and keeps larger steps as
    steps; half of the very-large-scale trend (8 × detail) is removed so that dim objects on
    a dark side still rise; the 1st–99th percentiles are spread over the relief.
    """
    damped = gaussian_mm(work, options.detail_mm / 4, pitch_mm)
    shape = guided_smooth(damped, options.detail_mm / pitch_mm, eps=0.01)
    trend = coarse_gaussian_mm(shape, 8 * options.detail_mm, pitch_mm)
    return robust_unit(shape - 0.5 * trend)
