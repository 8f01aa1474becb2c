"""The data band: rows at the top or bottom of a microscope image that hold the vendor's text and
scale bar, not the sample. Named by the vendor's metadata when it records it, otherwise detected
from the pixels; cropped either way. Its text is read (band_text) for what the file may not
record: the detector ("Det SE", "BSD Full"), which says which side of the picture is matter."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..facts import Facts
from .vendor import number, tescan_main


@dataclass(frozen=True)
class Band(Facts):
    """Rows removed from the source image.

    top_rows, bottom_rows : rows cut at each edge (0 when none).
    provenance : what named the band ("FEI [Image] ResolutionY", "detected data band"), or "".
    """

    top_rows: int = 0
    bottom_rows: int = 0
    provenance: str = ""

    def as_dict(self) -> dict:
        """The band as reported in the info command's JSON and the lithograph's report."""
        return {"top_rows": self.top_rows, "bottom_rows": self.bottom_rows, "left_columns": 0, "right_columns": 0,
                "source": self.provenance or None}

    def rows(self, height_px: int) -> slice:
        """The rows of an image `height_px` high that are picture, not band."""
        return slice(self.top_rows, height_px - self.bottom_rows)


def band_from_metadata(metadata: dict, tiff_tags: dict, path: str | None, *, height_px: int) -> Band | None:
    """The band the vendor's metadata records (FEI ResolutionY, TESCAN ImageStripSize), else None."""
    fei = metadata.get("fei_metadata")
    if fei:
        rows = number(fei.get("Image", {}).get("ResolutionY"))
        if rows and 0 < rows < height_px:
            return Band(0, height_px - int(rows), "FEI [Image] ResolutionY")
    found = tescan_main(tiff_tags, Path(path) if path else None)
    if found is not None:
        main, where = found
        strip = number(main.get("ImageStripSize"))
        if strip and strip > 0:
            return Band(0, int(strip), f"{where} ImageStripSize")
    return None


def _row_mode_fraction(values: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the most common value (in 256 bins over lo..hi) and the fraction of pixels in it."""
    scaled = np.subtract(values, lo)  # the same float operations as ((values - lo) / (hi - lo) * 255), in place
    scaled /= hi - lo
    scaled *= 255
    if scaled.size and 0 <= scaled.min() and scaled.max() < 256:  # truncated to a byte: as to int64 then clipped, 3x sooner
        bins = scaled.astype(np.uint8)
    else:
        bins = np.clip(scaled.astype(np.int64), 0, 255)
    rows = values.shape[0]
    keys = (np.arange(rows, dtype=np.int64)[:, None] * 256 + bins).ravel()
    counts = np.bincount(keys, minlength=rows * 256).reshape(rows, 256)
    mode = counts.argmax(axis=1)
    return mode, counts[np.arange(rows), mode] / values.shape[1]


def _band_run(order: list[int], bandlike: np.ndarray, fraction: np.ndarray, row_std: "_RowSpread") -> int:
    """Rows of band counted from an edge (`order` lists rows from that edge inwards), or 0."""
    h = len(order)
    count, misses, last_good = 0, 0, 0
    for r in order:
        count += 1
        if bandlike[r]:
            misses, last_good = 0, count
        else:
            misses += 1
            if misses > 6:  # a line of text may break the background for a few rows
                break
    if not 0.02 * h <= last_good <= 0.30 * h:
        return 0
    # Bands are uniform across the image; the picture above them is not: compare to be sure.
    if fraction[order[:last_good]].mean() < 0.75:
        return 0
    # Swallow a thin frame line (a few rows of low variation) between band and picture.
    extra = 0
    for r in order[last_good : last_good + 3]:
        if row_std[r] < 0.1:
            extra += 1
        else:
            break
    return last_good + extra


def detect_info_band(values: np.ndarray) -> tuple[int, int]:
    """(rows to remove at the top, rows to remove at the bottom) for a data band, else (0, 0).

    values : (H, W) float image, NaN where unknown.

    A data band is a run of full-width rows at an edge whose most common value (the band's
    background, nearly always white or black) covers most of each row, between 2 % and 30 % of
    the image height, plus up to 3 rows of frame line next to it, and that holds marks (text
    or a scale bar): a plain margin is not a data band.
    """
    finite = np.isfinite(values)
    everywhere = bool(finite.all())  # the common case: no copies of the picture
    lo, hi = (float(values.min()), float(values.max())) if everywhere else (float(values[finite].min()), float(values[finite].max()))
    if hi <= lo:
        return 0, 0
    filled = values if everywhere else np.where(finite, values, lo)
    mode, fraction = _row_mode_fraction(filled, lo, hi)
    bandlike = (fraction >= 0.6) & ((mode <= 12) | (mode >= 243))
    row_std = _RowSpread(filled, hi - lo)
    h = values.shape[0]
    bottom = _band_run(list(range(h - 1, -1, -1)), bandlike, fraction, row_std)
    if bottom and not _holds_marks(filled[h - bottom + 3 :], lo, hi, inner_row=0):  # not the frame rows next to the picture
        bottom = 0
    top = _band_run(list(range(h)), bandlike, fraction, row_std) if not bottom else 0
    if top and not _holds_marks(filled[: top - 3], lo, hi, inner_row=-1):
        top = 0
    return top, bottom


class _RowSpread:
    """Each row's standard deviation over `scale`, as `values.std(axis=1) / scale` gives it, worked
    out only for the few rows asked (at most three next to a band). A picture not laid out row by
    row (a channel's view, a transposed read) is summed in another order by a one-row slice, so
    its rows are all worked out as before: the same bits either way."""

    def __init__(self, values: np.ndarray, scale: float):
        self.values, self.scale = values, scale
        self.all = None if values.flags.c_contiguous else values.std(axis=1) / scale

    def __getitem__(self, row: int) -> float:
        if self.all is not None:
            return self.all[row]
        return (self.values[row : row + 1].std(axis=1) / self.scale)[0]


def _holds_marks(band: np.ndarray, lo: float, hi: float, inner_row: int | None = None) -> bool:
    """Whether rows of uniform background hold text or a scale bar (a data band) rather than
    nothing (a black or white margin, which is left alone: it is not known to be unwanted).

    `inner_row`: the band's row next to the picture (0 or -1). A mark that reaches it runs on into
    the picture: it is the picture's content at its edge (tissue on the glass of a slide), not a
    band's text, and is not counted."""
    from scipy import ndimage

    if band.size == 0:
        return False
    background = np.median(band)
    ink = np.abs(band - background) > 0.5 * (hi - lo)
    if inner_row is not None:  # grouped 2 px around, as a noisy edge breaks into specks
        labels, _ = ndimage.label(ndimage.binary_dilation(ink, iterations=2))
        ink &= ~np.isin(labels, np.unique(labels[inner_row][labels[inner_row] > 0]))
    if ink.sum() < 0.002 * ink.size:
        return False
    _, marks = ndimage.label(ink)
    return marks >= 3


OCR_BAND_PX = 114  # the band is scaled to about this many rows for OCR (its text 25-40 px high)
OCR_MAX_WIDTH_PX = 4000  # and to at most this width (a wide band at 4x costs seconds)


def band_text(values: np.ndarray, band: Band) -> str | None:
    """The text of the cropped band (the lower one when there are two), read by OCR as a block
    of lines; None when there is no band, no OCR here, or nothing read.

    values : (H, W) the image as read, band included."""
    from PIL import Image

    from . import ocr

    h = values.shape[0]
    rows = values[h - band.bottom_rows :] if band.bottom_rows >= 5 else values[: band.top_rows] if band.top_rows >= 5 else None
    if rows is None or ocr.backend() is None:
        return None
    finite = np.isfinite(rows)
    if not finite.any():
        return None
    lo, hi = float(rows[finite].min()), float(rows[finite].max())
    if hi <= lo:
        return None
    grey = ((np.where(finite, rows, lo) - lo) / (hi - lo) * 255).astype(np.uint8)
    if np.median(grey) < 128:  # light letters on a dark band: Tesseract reads dark on light best
        grey = 255 - grey
    image = Image.fromarray(np.pad(grey, 10, constant_values=255))
    scale = int(np.clip(round(OCR_BAND_PX / grey.shape[0]), 1, 4))
    scale = max(1, min(scale, OCR_MAX_WIDTH_PX // max(image.width, 1)))
    if scale > 1:
        image = image.resize((image.width * scale, image.height * scale), Image.Resampling.BICUBIC)
    text = ocr.read_text(image, 6, "")
    return text if text and text.strip() else None
