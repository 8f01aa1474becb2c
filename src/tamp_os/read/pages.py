"""Which TIFF page holds the data when a file also holds a preview or thumbnail.

Olympus SIS TIFFs (TEM cameras) store a small JPEG-compressed RGB preview with a burned-in scale
bar as page 0 and the real 16-bit data as page 1; other writers add thumbnails flagged as reduced
(NewSubfileType bit 0). Reading page 0 prints the preview. This module only looks at page
headers (shape, dtype, compression, subfile type); it never decodes pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

PAGES_LOOKED_AT = 16  # previews sit beside the data at the start; never walk a long stack
JPEG_CODES = (6, 7, 34892)  # old-style JPEG, JPEG, lossy JPEG (DNG)
SAME_SCENE_ASPECT = 0.05  # a preview keeps the data's aspect ratio within 5 %


@dataclass(frozen=True)
class _PageFacts:
    index: int
    height: int
    width: int
    bits: int
    jpeg: bool
    reduced: bool

    @property
    def pixels(self) -> int:
        return self.height * self.width

    def describe(self) -> str:
        flags = ", JPEG-compressed" if self.jpeg else ""
        flags += ", flagged as reduced" if self.reduced else ""
        return f"page {self.index}: {self.width}×{self.height}, {self.bits}-bit{flags}"


@dataclass(frozen=True)
class DataPage:
    """The page that holds the data and the preview pages beside it.

    index : the data page (0-based, as the page parameter counts in this file).
    previews : descriptions of the preview pages skipped.
    """

    index: int
    previews: tuple[str, ...]

    def note(self) -> str:
        return (
            f"this TIFF holds a preview beside the data; read page {self.index} (the data) and skipped "
            f"{'; '.join(self.previews)}. Choose another page with the page parameter."
        )


def _facts(index: int, page) -> _PageFacts | None:
    axes, shape, dtype = getattr(page, "axes", ""), getattr(page, "shape", ()), getattr(page, "dtype", None)
    if "Y" not in axes or "X" not in axes or dtype is None:
        return None  # a frame or an unreadable page: not a candidate
    rows, cols = shape[axes.index("Y")], shape[axes.index("X")]
    if not rows or not cols:
        return None
    reduced = bool(int(page.subfiletype or 0) & 1)  # NewSubfileType bit 0: a reduced-resolution copy
    return _PageFacts(index, int(rows), int(cols), dtype.itemsize * 8, int(page.compression) in JPEG_CODES, reduced)


def _is_preview_of(p: _PageFacts, data: _PageFacts) -> bool:
    """A preview shows the same scene (aspect ratio) with less: reduced, JPEG, fewer bits or fewer pixels."""
    if p.reduced:
        return True
    same_scene = abs(p.width / p.height - data.width / data.height) <= SAME_SCENE_ASPECT * data.width / data.height
    lesser = (p.jpeg and not data.jpeg) or p.bits < data.bits or p.pixels < data.pixels
    return same_scene and lesser


def find_data_page(tif) -> DataPage | None:
    """The data page of a TIFF whose page 0 is a preview of it, else None (read the series as usual).

    tif : an open tifffile.TiffFile.
    """
    pages = tif.pages
    count = min(len(pages), PAGES_LOOKED_AT)
    if count < 2:
        return None
    facts = [f for f in (_facts(i, pages[i]) for i in range(count)) if f is not None]
    full = [f for f in facts if not f.reduced] or facts
    data = max(full, key=lambda f: (not f.jpeg, f.bits, f.pixels, -f.index))
    if data.index == 0 or not facts or facts[0].index != 0 or not _is_preview_of(facts[0], data):
        return None
    previews = tuple(f.describe() for f in facts if f.index != data.index and _is_preview_of(f, data))
    return DataPage(data.index, previews)
