"""Small grey previews of pictures for the web app's pages (an upload's, each panel's)."""

from __future__ import annotations

import numpy as np

THUMB_PX = 160


def thumbnail(values: np.ndarray, size_px: int = THUMB_PX) -> np.ndarray:
    """An 8-bit grey thumbnail, at most `size_px` on its longer side, from an H×W float image."""
    step = max(1, int(np.ceil(max(values.shape) / size_px)))
    small = values[::step, ::step]
    finite = small[np.isfinite(small)]
    lo, hi = (np.percentile(finite, [1, 99]) if finite.size else (0.0, 1.0))
    scaled = np.nan_to_num((small - lo) / ((hi - lo) or 1.0), nan=0.0)
    return (np.clip(scaled, 0, 1) * 255).astype(np.uint8)
