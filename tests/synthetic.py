"""Synthetic pictures with known ground truth, for the relief-style tests and the benchmark.

Each maker returns a `Synthetic`: the picture (float32, 0..1, row 0 = top) and what is known
about it: a mask of the objects (True inside) or the clean structure under the noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class Synthetic:
    name: str
    image: np.ndarray  # (rows, cols) float32, 0..1
    objects: np.ndarray | None = None  # (rows, cols) bool, True where an object is
    clean: np.ndarray | None = None  # (rows, cols) float32: the structure without the noise


def _grid(rows, cols):
    return np.mgrid[0:rows, 0:cols].astype(np.float32)


def sem_spheres(rows: int = 192, cols: int = 256, seed: int = 0, noise: float = 0.04) -> Synthetic:
    """Secondary-electron SEM-like spheres.

    The body of each sphere is shaded (lighter towards the upper left, darker to the lower
    right) with a mean as bright as the substrate; a bright rim glows along the outline,
    strongest at the upper left; a dark shadow falls on the substrate to the lower right.
    Brightness mapped to height makes rings over trenches here.
    """
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    scale = cols / 256
    centres = [(60, 70, 34), (70, 175, 30), (140, 110, 28), (135, 200, 22)]
    image = np.full((rows, cols), 0.5, np.float32)
    image += 0.03 * ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 3 * scale).astype(np.float32) * 10
    mask = np.zeros((rows, cols), bool)
    # Shadows first: they fall on the ground, beside and under the spheres.
    for cy, cx, r in centres:
        cy, cx, r = cy * rows / 192, cx * scale, r * scale
        shifted = (yy - cy - 0.3 * r) ** 2 + (xx - cx - 0.3 * r) ** 2 <= (1.05 * r) ** 2
        image[shifted] = 0.22
    for cy, cx, r in centres:
        cy, cx, r = cy * rows / 192, cx * scale, r * scale
        d = np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2)
        inside = d <= r
        # Shading across the body from upper left (+) to lower right (-), zero mean.
        shade = -0.12 * ((yy - cy) + (xx - cx)) / (1.414 * r)
        body = 0.5 + shade
        rim_w = max(1.5, 0.1 * r)
        rim = np.exp(-(((d - r + rim_w) / rim_w) ** 2))
        direction = np.clip(0.6 - 0.4 * ((yy - cy) + (xx - cx)) / (1.414 * r), 0.2, 1.0)
        image[inside] = (body + 0.45 * rim * direction)[inside]
        mask |= inside
    image += noise * rng.standard_normal((rows, cols)).astype(np.float32)
    return Synthetic("sem_spheres", np.clip(image, 0, 1).astype(np.float32), objects=mask)


def particles_on_texture(rows: int = 192, cols: int = 256, seed: int = 1) -> Synthetic:
    """Bright round particles (5–12 px radius) on a textured, mid-grey substrate, with noise."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    scale = cols / 256
    substrate = ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 1.5 * scale)
    substrate = 0.35 + 0.12 * substrate / (substrate.std() + 1e-9)
    image = substrate.astype(np.float32)
    mask = np.zeros((rows, cols), bool)
    placed: list[tuple[float, float, float]] = []
    for _ in range(400):
        if len(placed) == 14:
            break
        r = rng.uniform(6, 12) * scale
        cy, cx = rng.uniform(r + 2, rows - r - 2), rng.uniform(r + 2, cols - r - 2)
        if any((cy - y) ** 2 + (cx - x) ** 2 < (r + q + 6 * scale) ** 2 for y, x, q in placed):
            continue
        placed.append((cy, cx, r))
        disk_ = (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
        image[disk_] = 0.8 + 0.05 * rng.standard_normal(int(disk_.sum()))
        mask |= disk_
    image += 0.05 * rng.standard_normal((rows, cols)).astype(np.float32)
    return Synthetic("particles_on_texture", np.clip(image, 0, 1).astype(np.float32), objects=mask)


def tem_texture(rows: int = 192, cols: int = 256, seed: int = 2, noise_to_signal: float = 3.0) -> Synthetic:
    """Noisy TEM-like texture: smooth grains about 12 px across buried in white noise whose
    standard deviation is `noise_to_signal` times the grains'."""
    rng = np.random.default_rng(seed)
    scale = cols / 256
    clean = ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 6 * scale)
    clean = (clean - clean.mean()) / (clean.std() + 1e-12)
    image = 0.5 + 0.1 * clean + 0.1 * noise_to_signal * rng.standard_normal((rows, cols))
    return Synthetic("tem_texture", np.clip(image, 0, 1).astype(np.float32), clean=clean.astype(np.float32))


def all_synthetic(rows: int = 192, cols: int = 256) -> list[Synthetic]:
    return [sem_spheres(rows, cols), particles_on_texture(rows, cols), tem_texture(rows, cols)]
