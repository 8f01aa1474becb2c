"""Uploaded images: checked by their header before anything is decoded, decoded in a worker thread
(never on the event loop) with a bound on how many decode at once, and refused in plain words.

A PNG of a few hundred kilobytes can claim 19500 × 19500 pixels; decoding it takes gigabytes.
So the header's claim is priced in decoded bytes first, with a lower cap than the command line's.
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, TampError
from ..export.files import write_png
from .thumbnail import thumbnail

log = logging.getLogger(__name__)

TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")


@dataclass
class Upload:
    """One uploaded image as the web app shows it."""

    name: str
    path: Path
    width: int
    height: int
    suggested: str
    reason: str
    thumb: str = ""  # file name in the job's thumbs folder
    override: str = ""
    contents: str = ""  # axes and channels of a microscope file, in words ("2 channels: DAPI, GFP")
    channels: int = 1  # colour or fluorescence channels: a channel choice applies when more than one
    z_slices: int = 1  # slices of a z-stack: a slice choice applies when more than one
    caption: str = ""  # this image's braille caption (issue 24: one caption per image, not one for all)
    subject: str = ""  # what this image shows, for its description
    time_points: int = 1  # time points of a series: a time choice applies when more than one
    scenes: int = 1  # scenes or series of a multi-scene file
    panels: tuple = ()  # a figure's panels found at upload (panel_choice.PanelFound); () for one picture
    panel_choice: tuple[str, ...] | None = None  # the panels ticked; None: every panel


def decoded_bytes(path: Path) -> tuple[int, int, int] | None:
    """(width, height, decoded bytes) that the file's header claims, or None when the header is
    not one we can price (DM files: the reader's own megapixel check applies). Width is 0 when
    only the pixel count is known (then height holds the pixel count).

    Raises InputError in plain words when the file is not an image at all.
    """
    with path.open("rb") as fh:
        head = fh.read(8)
    if head[:4] in TIFF_MAGIC:
        import tifffile

        try:
            with tifffile.TiffFile(path) as tif:
                series = _level_read(tif.series[0])
                x, y = series.shape[series.axes.index("X")], series.shape[series.axes.index("Y")]
                return int(x), int(y), int(np.prod(series.shape)) * series.dtype.itemsize
        except Exception:
            raise InputError(f"{path.name} looks like a TIFF file but is damaged, so it cannot be read. Export it again.") from None
    if head[:4] == b"\x00\x00\x00\x04" or head[:4] == b"\x00\x00\x00\x03":
        return None  # Digital Micrograph
    from ..read.image import vendor_kind

    if vendor_kind(path):
        return None  # a microscope vendor's file: its reader prices the planes it reads before decoding
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as im:  # reads the header only
            samples = len(im.getbands()) * (2 if im.mode.startswith("I;16") else 4 if im.mode in ("I", "F") else 1)
            return im.width, im.height, im.width * im.height * samples
    except Image.DecompressionBombError as exc:  # Pillow refuses to open it at all: price it from its message
        pixels = int(re.search(r"\((\d+) pixels\)", str(exc)).group(1))
        return 0, pixels, pixels
    except UnidentifiedImageError:
        raise InputError(not_an_image(path.name)) from None
    except Exception:
        raise InputError(f"{path.name} is damaged or truncated, so it cannot be read. Export it again.") from None


def _level_read(series):
    """The pyramid level read.py reads (the smallest at least 2048 px wide): that is what is decoded."""
    from ..read.model import DEFAULT_TARGET_PX

    levels = getattr(series, "levels", None) or [series]
    wide = [lv for lv in levels if lv.shape[lv.axes.index("X")] >= DEFAULT_TARGET_PX]
    return min(wide, key=lambda lv: lv.shape[lv.axes.index("X")]) if wide else levels[0]


def not_an_image(name: str) -> str:
    return (f"{name} is not an image TAMP-OS can read. Choose a PNG, JPEG, TIFF (also microscope TIFFs), "
            "BMP, GIF, WebP or DM3/DM4 file, or a microscope file (CZI, LIF, ND2, TIA .ser, EMD, HyperSpy, MRC, JEOL .img, Phenom .elid).")


def check_size(path: Path, max_decoded_mb: float) -> None:
    """Refuse, before decoding, an image whose pixels would take more than `max_decoded_mb` MB."""
    claim = decoded_bytes(path)
    if claim and claim[2] > max_decoded_mb * 1e6:
        w, h, n = claim
        size = f"{w:,} × {h:,} pixels" if w else f"{h / 1e6:,.0f} million pixels"
        raise InputError(
            f"{path.name} is {size}, which takes {n / 1e6:,.0f} MB once opened; this web app opens "
            f"images up to {max_decoded_mb:g} MB. Make the image smaller (for example half as wide), or use the "
            "tamp-os command, which accepts larger images."
        )


def plain_error(exc: TampError, path: Path, name: str) -> str:
    """A library error about an upload in the web app's words, with the upload's name instead of
    its temporary path; advice about a setting this app does not have becomes its own."""
    from .forms import offers, web_words

    text = web_words(exc).replace(str(path), name)
    if exc.hint and not all(offers(n) for n in exc.hint_names()) and "smaller" not in text:
        text += " Make the image smaller and try again."
    return text


def inspect_upload(path: Path, name: str, thumbs: Path, *, index: int, max_decoded_mb: float) -> Upload:
    """Read an upload once (in a worker process, gui/workers.py): refuse non-images and oversized
    ones, suggest a level of detail from its contrast and detail, and write a small thumbnail."""
    from .workers import read_memory_gb, shared_pool

    check_size(path, max_decoded_mb)
    try:
        seen = shared_pool().run(name, inspect_in_worker, path, thumbs, index, max_decoded_mb=max_decoded_mb, max_memory_gb=read_memory_gb())
    except TampError as exc:
        raise InputError(plain_error(exc, path, name)) from None
    return Upload(name, path, seen.width, seen.height, seen.suggested, seen.reason, seen.thumb, contents=seen.contents,
                  channels=seen.channels, z_slices=seen.z_slices, time_points=seen.time_points, scenes=seen.scenes,
                  panels=seen.panels)


@dataclass(frozen=True)
class Inspected:
    """What the worker process found in an upload (sent back pickled)."""

    width: int
    height: int
    suggested: str
    reason: str
    thumb: str
    contents: str
    channels: int
    z_slices: int
    time_points: int
    scenes: int
    panels: tuple = ()  # panel_choice.PanelFound of a figure


def inspect_in_worker(path: Path, thumbs: Path, index: int, *, max_decoded_mb: float, max_memory_gb: float) -> Inspected:
    """What an upload holds (size, suggested preset, thumbnail, channels and axes), read with the web app's own caps:
    the page read_image will read is priced by read_image itself (tiles, copies, working arrays)."""
    from ..printing.printers import BUILTIN_PRINTERS
    from ..read.image import read_image
    from ..relief.touch import suggest_by_touch

    picture = read_image(path, max_megapixels=max_decoded_mb, max_decoded_gb=max_decoded_mb / 1000,
                         max_memory_gb=max_memory_gb)  # max_megapixels: one byte per pixel at least
    standard = BUILTIN_PRINTERS["standard"]  # the printer is chosen later; judge at its width and nozzle
    suggestion = suggest_by_touch(picture.values, picture.alpha, width_mm=standard.width_mm, nozzle_mm=standard.nozzle_mm)
    thumb = f"{index}.png"
    write_png(thumbs / thumb, thumbnail(picture.values))
    axes = picture.file.axes or {}
    try:
        from ..lithograph.figure import figure_colour
        from ..params import LithoParams
        from .panel_choice import find_panels

        panels = find_panels(picture.values, thumbs, index, colour=lambda: figure_colour(path, picture, LithoParams()))
    except Exception:  # the panels are a choice offered, not the upload: it stays, printed as auto decides
        log.warning("panel detection failed on %s", path.name, exc_info=True)
        panels = ()
    return Inspected(picture.file.width, picture.file.height, suggestion.preset, suggestion.reason, thumb,
                     contents_words(picture.file), max(int(picture.file.channel_count or 1), int(picture.file.channels or 1)),
                     int(axes.get("Z", 1)), int(axes.get("T", 1)), int(axes.get("scenes", 1)), panels)


def contents_words(file) -> str:
    """'3 time points, 2 channels: ChA-T1 (579 nm), ChA-T2 (522 nm)': what a microscope file holds beyond one plane."""
    words = {"scenes": "scenes", "T": "time points", "Z": "z slices"}
    parts = [f"{n} {words[a]}" for a, n in file.axes.items() if a in words]
    if file.channel_count > 1 or file.channel_names:
        names = file.channel_names or []
        waves = list(file.wavelengths_nm) + [None] * len(names)
        named = ", ".join(f"{n} ({w:.0f} nm)" if w else n for n, w in zip(names, waves))
        parts.append(f"{file.channel_count} channel{'s' if file.channel_count != 1 else ''}" + (f": {named}" if named else ""))
    return ", ".join(parts)
