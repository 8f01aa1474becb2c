"""The microscopy stage between reading and preprocessing: find the physical scale, crop the data
band, remove burned-in annotations, and fall back to a scale bar's label when the file records
no scale. Used by the pipeline and by `tamp-os info`, so both report the same facts."""

from __future__ import annotations

import functools
import os
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np

from ..read.model import Picture
from . import annotations as marks
from .annotations import Annotation
from .band import Band, band_from_metadata, band_text, detect_info_band
from .instrument import Instrument, instrument_from_text, read_instrument, with_band_words
from .labels import find_labels, on_paper, read_labels
from .scale import PixelSize, read_pixel_size
from .scalebar import scale_from_bars


BAND_SHADE = 0.5  # the cropped band's grey in the mask image; inpainted boxes are white (1)


@dataclass(frozen=True)
class Cleaned:
    """A picture ready for preprocessing, and what cleaning found and removed.

    values : (H', W) float32, the band cropped and annotations inpainted.
    alpha : (H', W) float32 opacity in 0..1, or None.
    pixel_size_found : the physical pixel size and its provenance, or its Future while a scale
        bar's label is still being read (read `pixel_size`, which waits for it).
    band : the rows cropped from the source image.
    annotations : burned-in annotations removed (empty when removal is off).
    mask : (H', W) bool where annotations were removed, or None when removal is off.
    instrument_found : magnification, kV and detector when the file records them (completed by
        the data band's text when the file names no detector), else None; or its Future while
        the band is being read (read `instrument`, which waits for it).
    annotations_read : the annotations with their text labels read by OCR, or its Future while
        they are being read (read `annotations_with_text`, which waits), or None: none to read.
    """

    values: np.ndarray
    alpha: np.ndarray | None
    pixel_size_found: "PixelSize | Future[PixelSize]"
    band: Band
    annotations: list[Annotation]
    mask: np.ndarray | None
    instrument_found: "Instrument | Future[Instrument | None] | None" = None
    annotations_read: "list[Annotation] | Future[list[Annotation]] | None" = None

    @property
    def annotations_with_text(self) -> list[Annotation]:
        """The annotations, each text label with its words (labels.read_labels)."""
        found = self.annotations_read
        if found is None:
            return self.annotations
        return found.result() if isinstance(found, Future) else found

    @property
    def instrument(self) -> Instrument | None:
        found = self.instrument_found
        return found.result() if isinstance(found, Future) else found

    @property
    def pixel_size(self) -> PixelSize:
        found = self.pixel_size_found
        return found.result() if isinstance(found, Future) else found

    def source_mask(self) -> np.ndarray | None:
        """What cleaning took away, over the whole source image, for NAME.annotations.png.

        Returns (H, W) float32: 0 = kept, 0.5 (grey) = a cropped data band row, 1 (white) = inpainted;
        None when nothing was cropped and annotation removal was off.
        """
        top, bottom = self.band.top_rows, self.band.bottom_rows
        if self.mask is None and not (top or bottom):
            return None
        h, w = self.values.shape
        full = np.empty((top + h + bottom, w), dtype=np.float32)  # each row written once, the mask cast in place
        full[:top], full[top + h :] = BAND_SHADE, BAND_SHADE
        full[top : top + h] = 0.0 if self.mask is None else self.mask
        return full


def _band(picture: Picture, remove_annotations: bool) -> Band:
    """The vendor's band, always cropped; a detected one only when annotations are removed."""
    file, height = picture.file, picture.values.shape[0]
    band = band_from_metadata(file.metadata, file.tiff_tags, file.path, height_px=height)
    if band is None and remove_annotations:
        top, bottom = detect_info_band(picture.values)
        band = Band(top, bottom, "detected data band" if top or bottom else "")
    if band is None or band.top_rows + band.bottom_rows >= height - 1:
        return Band()
    return band


def clean_picture(picture: Picture, *, pixel_size_m: float | None, remove_annotations: bool) -> Cleaned:
    """Scale, band crop and annotation removal for one picture.

    Parameters
    ----------
    picture : the image as read.
    pixel_size_m : the user's pixel size in metres, or None to use the file's.
    remove_annotations : detect and remove data bands and burned-in annotations.
    """
    file = picture.file
    size = read_pixel_size(file.metadata, file.tiff_tags, file.path, width_px=file.width, pixel_size_m=pixel_size_m)
    instrument = read_instrument(file.metadata, file.tiff_tags, file.path)
    band = _band(picture, remove_annotations)
    if band.top_rows + band.bottom_rows and (instrument is None or instrument.signal is None):
        # The band may name the detector the file does not (OCR, ~0.1 s, beside the inpainting on the other core).
        instrument = _reader().submit(_with_band_words, picture.values, band, instrument)
    rows = band.rows(picture.values.shape[0])
    values = picture.values[rows]
    alpha = None if picture.alpha is None else picture.alpha[rows]
    if not remove_annotations:
        return Cleaned(values, alpha, size, band, [], None, instrument)
    paper = on_paper(values)  # a diagram or drawing: its arrows and strokes are content, its words are labels
    mask, found = marks.detect_annotations(values, arrows=not paper)
    words_mask, words = find_labels(values, mask) if paper else (None, [])
    if words:
        mask = mask | words_mask
        found = found + words
    # Every removed text label is read (OCR) on the thread that reads scale bars, beside the relief.
    read = _reader().submit(read_labels, values, found) if any(a.kind == "text" for a in found) else None
    if size.metres is None:  # OCR of a scale bar's label (Tesseract, ~0.1 s) runs beside the inpainting and relief on the other core
        size = _reader().submit(_scale_from_bars, picture.values, band, values, found, size)
    removal = marks.Removal(marks.inpaint(values, mask), mask, found)  # what marks.remove_annotations does
    return Cleaned(removal.values, alpha, size, band, removal.annotations, removal.mask, instrument, read)


@functools.lru_cache(maxsize=1)
def _reader() -> ThreadPoolExecutor | _InPlace:
    """One thread for reading scale bars: Tesseract is a separate process, so it overlaps the
    relief and mesh work of this one (the pipeline needs the scale only for the furniture).
    A batch worker that has one core to itself (TAMP_THREADS=1) reads them in place instead:
    its neighbour worker already uses the other core, and a second thread would only compete."""
    if os.environ.get("TAMP_THREADS") == "1":
        return _InPlace()
    return ThreadPoolExecutor(max_workers=1, thread_name_prefix="tamp-scalebar")


class _InPlace:
    """`submit` that runs the call at once and returns its finished future (the same result, no thread)."""

    def submit(self, fn, /, *args, **kwargs) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # handed to whoever asks for the result, as a thread's would be
            future.set_exception(exc)
        return future


os.register_at_fork(after_in_child=_reader.cache_clear)  # a forked worker starts its own thread, not the parent's


def _with_band_words(source: np.ndarray, band: Band, instrument: Instrument | None) -> Instrument | None:
    """The file's acquisition facts, completed by the detector and voltage its data band names."""
    return with_band_words(instrument, instrument_from_text(band_text(source, band)))


def _scale_from_bars(source: np.ndarray, band: Band, picture: np.ndarray, found: list[Annotation], size: PixelSize) -> PixelSize:
    """The pixel size read from burned-in scale bars, used only when the file records none.

    Bars are looked for in the cropped band, at the top and bottom quarter of the picture, and
    in label boxes; `size` is returned with a warning when a bar was seen but not read.
    """
    h = source.shape[0]
    regions = [source[:band.top_rows]] if band.top_rows >= 5 else []
    regions += [source[h - band.bottom_rows :]] if band.bottom_rows >= 5 else []
    for a in found:
        if a.kind == "bar":  # a bar found among the annotations, with room for its label
            margin, length = max(6 * (a.rows[1] - a.rows[0]), 40), a.cols[1] - a.cols[0]
            regions.append(picture[max(0, a.rows[0] - margin) : a.rows[1] + margin, max(0, a.cols[0] - length // 4) : a.cols[1] + length // 4])
    quarter = max(1, picture.shape[0] // 4)
    boxes = [picture[a.rows[0] : a.rows[1], a.cols[0] : a.cols[1]] for a in found if a.kind == "box"]
    reading = scale_from_bars(regions, boxes, strips=[picture[-quarter:], picture[:quarter]])
    if reading.metres is not None:
        return PixelSize(reading.metres, reading.detail, size.warnings)
    if reading.bar_seen:
        return replace(size, warnings=size.warnings + (reading.detail,))
    return size
