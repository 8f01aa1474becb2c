"""A 2-D tactile graphic (swell paper, braille embossers) as data: what goes where, in mm.

Coordinates are plate millimetres with the origin at the bottom-left corner and +y towards the
far edge, as in every mesh; the region map's top row lies at the far edge. Only the drawing code
(tactile2d.py) turns them into page coordinates.

The layout is the 3-D plate's own (tactile.furniture.plan_furniture): the picture at the top, the
scale bar and its braille value below it, the braille caption below that, the cut corner at the top
right, and at least CLEARANCE_MM between distinct elements; a channel key's rows go below all that.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError
from ..tactile.braille import BrailleSpec, block_size_mm, cell_dots, wrap_cells
from ..tactile.furniture import BORDER_MM, BOTTOM_BORDER_MM, CLEARANCE_MM, CORNER_CUT_MM, TICK_LENGTH_MM, Furniture, corner_legs_mm, plan_furniture

MAX_LEVELS = 3  # textures a reader tells apart by touch: outline only, dots, lines
PAGE_SIZES_MM = {"a4": (210.0, 297.0), "letter": (215.9, 279.4)}


@dataclass(frozen=True)
class BrailleText:
    """Lines of Unicode braille whose first line's top dots touch y = top_mm, starting at x = left_mm."""

    lines: tuple[str, ...]
    left_mm: float
    top_mm: float

    def box(self, spec: BrailleSpec) -> tuple[float, float, float, float]:
        """x0, y0, x1, y1 of the dots' outer edges (mm)."""
        w, h = block_size_mm(list(self.lines), spec)
        return self.left_mm, self.top_mm - h, self.left_mm + w, self.top_mm

    @property
    def dots(self) -> int:
        return sum(len(cell_dots(cell)) for line in self.lines for cell in line)


@dataclass(frozen=True)
class ScaleBar2D:
    """A bar of length_mm from x0_mm, centred on y_mm, with end ticks, and its braille value."""

    x0_mm: float
    y_mm: float
    length_mm: float
    label: BrailleText
    text: str = ""

    def box(self) -> tuple[float, float, float, float]:
        return self.x0_mm, self.y_mm - TICK_LENGTH_MM / 2, self.x0_mm + self.length_mm, self.y_mm + TICK_LENGTH_MM / 2


KEY_SWATCH_MM = (12.0, 9.0)  # a key swatch on paper: room for its outline and a few texture dots or lines


@dataclass(frozen=True)
class KeyRow2D:
    """One key entry on the page: a swatch (its outline and texture) and its braille label."""

    swatch_box: tuple[float, float, float, float]  # x0, y0, x1, y1 (mm)
    texture: str  # 'outline', 'dots' or 'lines', as the picture's region it names
    label: BrailleText


@dataclass(frozen=True)
class Graphic2D:
    """Everything a 2-D tactile graphic shows.

    regions: int array (rows, cols); 0 = background, 1..N = levels or objects.
    mm_per_px: size of one region-map pixel on paper.
    picture_origin_mm: bottom-left corner of the picture on the plate.
    textures: texture name per region value ('outline', 'dots' or 'lines'); empty means the
    levels default (1 -> outline, 2 -> dots, 3 -> lines).
    """

    regions: np.ndarray
    mm_per_px: float
    plate_mm: tuple[float, float]
    picture_origin_mm: tuple[float, float]
    caption: BrailleText | None = None
    scale_bar: ScaleBar2D | None = None
    frame_box: tuple[float, float, float, float] | None = None
    corner_cut_mm: float = CORNER_CUT_MM
    spec: BrailleSpec = field(default_factory=BrailleSpec)
    textures: dict[int, str] = field(default_factory=dict)
    key: tuple[KeyRow2D, ...] = ()  # a channel print's key, below everything else

    @property
    def picture_box(self) -> tuple[float, float, float, float]:
        rows, cols = self.regions.shape
        x0, y0 = self.picture_origin_mm
        return x0, y0, x0 + cols * self.mm_per_px, y0 + rows * self.mm_per_px

    @property
    def braille_dots(self) -> int:
        texts = (self.caption, self.scale_bar.label if self.scale_bar else None) + tuple(k.label for k in self.key)
        return sum(t.dots for t in texts if t)

    def element_boxes(self) -> dict[str, tuple[float, float, float, float]]:
        """Bounding boxes of the distinct elements, for checking the clearances between them."""
        boxes = {"picture": self.picture_box}
        if self.scale_bar:
            boxes["scale bar"] = self.scale_bar.box()
            boxes["scale value"] = self.scale_bar.label.box(self.spec)
        if self.caption:
            boxes["caption"] = self.caption.box(self.spec)
        for i, row in enumerate(self.key):
            boxes[f"key swatch {i + 1}"] = row.swatch_box
            boxes[f"key label {i + 1}"] = row.label.box(self.spec)
        return boxes


def regions_from_image(image01: np.ndarray, levels: int = MAX_LEVELS) -> np.ndarray:
    """A region map from a 0..1 image by multi-Otsu thresholds: 0 = background, 1..levels.

    A stand-in for the `levels` relief style (that style makes the real region maps).

    Parameters
    ----------
    image01 : (rows, cols) float array in 0..1
    levels : 1..3 raised levels above the background

    Returns
    -------
    (rows, cols) int32 array of 0..levels
    """
    from skimage.filters import threshold_multiotsu

    if not 1 <= levels <= MAX_LEVELS:
        raise ParameterError(f"levels: must be 1–{MAX_LEVELS} (textures that differ by touch); got {levels}.")
    img = np.asarray(image01, dtype=np.float64)
    if img.ndim != 2:
        raise ParameterError(f"region map: need a 2-D image; got shape {img.shape}.")
    try:
        thresholds = threshold_multiotsu(img, classes=levels + 1)
    except ValueError:  # too few distinct values for Otsu (e.g. a uniform image): even steps
        thresholds = np.linspace(0, 1, levels + 2)[1:-1]
    return np.digitize(img, thresholds).astype(np.int32)


def layout_graphic(regions: np.ndarray, mm_per_px: float, furniture: Furniture | None = None, *,
                   textures: dict[int, str] | None = None, key: list[tuple[str, str]] | None = None) -> Graphic2D:
    """Place the picture, scale bar, braille value and caption on a plate: the 3-D plate's own layout
    (tactile.furniture.plan_furniture), so paper and print put each element in the same place.

    Parameters
    ----------
    regions : (rows, cols) int array, 0 = background
    mm_per_px : picture pixel size on paper (mm)
    furniture : caption, braille table, scale bar, frame and cut corner (frame_mm > 0 draws a frame line
        along the middle of the plate's raised frame)
    key : (texture, Unicode braille label) per key entry of a channel print, drawn below everything
        else: a swatch of the texture, CLEARANCE_MM, then the label, each row CLEARANCE_MM apart
    """
    if mm_per_px <= 0 or not np.isfinite(mm_per_px):
        raise ParameterError(f"mm_per_px: must be a positive number; got {mm_per_px}.")
    furniture = furniture or Furniture()
    spec = furniture.spec
    rows, cols = np.shape(regions)
    placed = plan_furniture(cols * mm_per_px, rows * mm_per_px, furniture).placed
    plate_w, plate_d = placed.plate_mm
    below_rows = placed.scale_bar_box is not None or placed.caption_box is not None
    key_bottom = BOTTOM_BORDER_MM if below_rows else placed.relief_origin_mm[1]
    key_rows, lift = _key_rows(key or [], plate_w, spec, key_bottom)  # the key below all else lifts the rest

    def up(box):
        return None if box is None else (box[0], box[1] + lift, box[2], box[3] + lift)

    caption = None
    if placed.caption_box is not None:
        box = up(placed.caption_box)
        caption = BrailleText(tuple(placed.caption_braille), box[0], box[3])
    scale_bar = None
    if placed.scale_bar_box is not None:
        bar, label = up(placed.scale_bar_box), up(placed.scale_label_box)
        scale_bar = ScaleBar2D(bar[0], (bar[1] + bar[3]) / 2, bar[2] - bar[0],
                               BrailleText(tuple(placed.scale_label_lines), label[0], label[3]), placed.scale_label or "")
    frame_box = None
    if placed.frame_box is not None:  # the line along the middle of the plate's frame
        x0, y0, x1, y1 = up(placed.frame_box)
        half = furniture.frame_mm / 2
        frame_box = (x0 + half, y0 + half, x1 - half, y1 - half)
    plate = (plate_w, plate_d + lift)
    corner = corner_legs_mm(*plate) if furniture.corner_cut else 0.0
    origin = (placed.relief_origin_mm[0], placed.relief_origin_mm[1] + lift)
    return Graphic2D(np.asarray(regions), mm_per_px, plate, origin, caption, scale_bar, frame_box, corner_cut_mm=corner,
                     spec=spec, textures=dict(textures or {}), key=key_rows)


def _key_rows(key: list[tuple[str, str]], plate_w: float, spec: BrailleSpec, bottom_mm: float):
    """(KeyRow2D rows stacked upwards from bottom_mm, the depth they add including CLEARANCE_MM above each)."""
    if not key:
        return (), 0.0
    sw, sh = KEY_SWATCH_MM
    text_x = BORDER_MM + sw + CLEARANCE_MM
    cells = max(1, int((plate_w - BORDER_MM - text_x - spec.dot_spacing_mm - spec.dot_diameter_mm) // spec.cell_spacing_mm) + 1)
    laid = []
    for texture, braille in key:
        lines = wrap_cells(braille, cells)
        laid.append((texture, lines, max(sh, block_size_mm(lines, spec)[1])))
    rows, y = [], bottom_mm
    for texture, lines, row_h in reversed(laid):  # the first entry on top, read first
        mid = y + row_h / 2
        text_h = block_size_mm(lines, spec)[1]
        rows.append(KeyRow2D((BORDER_MM, mid - sh / 2, BORDER_MM + sw, mid + sh / 2), texture,
                             BrailleText(tuple(lines), text_x, mid + text_h / 2)))
        y += row_h + CLEARANCE_MM
    return tuple(reversed(rows)), y - bottom_mm


def page_placement(plate_mm: tuple[float, float], page_size: str | None) -> tuple[tuple[float, float], tuple[float, float]]:
    """Page size and the plate's offset on it (mm): the plate's own size, or centred on a4/letter.

    Portrait first, landscape when only that fits; a ParameterError when neither does.
    """
    w, d = plate_mm
    if page_size in (None, "", "plate"):
        return (w, d), (0.0, 0.0)
    key = page_size.lower()
    if key not in PAGE_SIZES_MM:
        raise ParameterError(f"`page_size`: must be one of plate, {', '.join(PAGE_SIZES_MM)}; got {page_size!r}.")
    pw, ph = PAGE_SIZES_MM[key]
    for page in ((pw, ph), (ph, pw)):
        if w <= page[0] + 1e-9 and d <= page[1] + 1e-9:
            return page, ((page[0] - w) / 2, (page[1] - d) / 2)
    raise ParameterError(
        f"`page_size` {key}: the graphic is {w:.1f} × {d:.1f} mm and does not fit a {pw:g} × {ph:g} mm page in either "
        f"orientation; make the print smaller (`width_mm`) or use `page_size` plate (the graphic's own size)."
    )
