"""Pin pages (export/pins.py) as the files each display reads, and a simulator picture of them.

- Dot Pad 320 (`.dtms`): JSON with title, lang, device "dotpad320" and one item a page; each
  page's graphic is 300 cells (30 across × 10 down, row by row) of 2 × 4 pins, one byte a cell
  written as two hex digits, bit (row + 4 × column) for the pin at that row (0-3) and column
  (0-1) of the cell; its text is the page's braille, 20 cells a line (one byte a cell, dots 1-6
  as bits 0-5, each line padded with blank cells), and `plain` its print, as the vendor's sample
  files hold them.
- Graphiti (`.graphiti`): per page the frame its Update Display command sends: 0x1B 0x15, then
  for each of the 2400 pins row by row its height (0-4) and blink rate (0), then the checksum
  (two's complement of the byte sum after the start byte); a data or checksum byte equal to 0x1B
  is sent twice. Also each page as a PNG for its Send Image command.
- Monarch (`.monarch.svg`, then `.monarch-2.svg`... for the zoom and key pages): an SVG a page in
  the IMAGE profile: one <title>, a layer per kind of thing as <g data-image-layer>, each region a
  path of whole pins with aria-label and aria-description, on a 96 × 40 view box, so that
  rasterised at 96 × 40 every region covers exactly its pins.

Every file goes through files.write_atomic.
"""

from __future__ import annotations

import json
from pathlib import Path
from xml.sax.saxutils import quoteattr, escape

import numpy as np

from .files import write_atomic, write_png
from .pins import PinPage, PinSet

SOF = 0x1B
UPDATE_DISPLAY = 0x15
CELL_ROWS, CELL_COLS = 4, 2


# ---------------------------------------------------------------------------------------------
# Dot Pad


def dotpad_cells(pins: np.ndarray) -> bytes:
    """300 cell bytes, row by row, for a 40 × 60 array of pins (raised = nonzero)."""
    up = np.asarray(pins) > 0
    rows, cols = up.shape
    out = bytearray()
    for cr in range(rows // CELL_ROWS):
        for cc in range(cols // CELL_COLS):
            value = 0
            for c in range(CELL_COLS):
                for r in range(CELL_ROWS):
                    if up[cr * CELL_ROWS + r, cc * CELL_COLS + c]:
                        value |= 1 << (r + 4 * c)
            out.append(value)
    return bytes(out)


def braille_line_bytes(braille: str, cells: int = 20) -> bytes:
    """The page's braille as text-area bytes (dots 1-6 as bits 0-5), lines of `cells` padded with
    blank cells; lines break at blank cells (tactile.braille.wrap_cells)."""
    from ..tactile.braille import wrap_cells

    out = bytearray()
    for line in wrap_cells(braille, cells):
        row = bytes(ord(ch) - 0x2800 for ch in line)
        out += row + bytes(cells - len(row))
    return bytes(out)


def dtms_document(pin_set: PinSet, title: str) -> dict:
    items = []
    for number, page in enumerate(pin_set.pages, start=1):
        items.append({
            "page": number,
            "title": page.name,
            "graphic": {"name": f"{number}.dtm", "data": dotpad_cells(page.pins).hex()},
            "text": {"name": f"{number}.txt", "data": braille_line_bytes(page.braille).hex().upper(), "plain": page.plain},
        })
    return {"title": title, "lang": "english", "lang_option": "1", "device": "dotpad320", "items": items}


def write_dtms(pin_set: PinSet, path: Path, title: str) -> Path:
    text = json.dumps(dtms_document(pin_set, title), ensure_ascii=False, separators=(",", ":"))
    return write_atomic(Path(path), lambda fh: fh.write(text.encode("utf-8")))


# ---------------------------------------------------------------------------------------------
# Graphiti


def checksum(payload: bytes) -> int:
    """Two's complement of the byte sum (the command byte onwards; not the start byte)."""
    return (-sum(payload)) & 0xFF


def frame(payload: bytes) -> bytes:
    """0x1B, the payload with each 0x1B doubled, and the checksum (doubled if it is 0x1B)."""
    body = bytes(payload).replace(bytes([SOF]), bytes([SOF, SOF]))
    check = checksum(payload)
    return bytes([SOF]) + body + (bytes([check, check]) if check == SOF else bytes([check]))


def update_display_frame(pins: np.ndarray, blink: np.ndarray | None = None) -> bytes:
    """The Update Display command for a 40 × 60 array of heights 0-4."""
    heights = np.asarray(pins, np.uint8).ravel()
    rates = np.zeros_like(heights) if blink is None else np.asarray(blink, np.uint8).ravel()
    pairs = np.empty(heights.size * 2, np.uint8)
    pairs[0::2], pairs[1::2] = heights, rates
    return frame(bytes([UPDATE_DISPLAY]) + pairs.tobytes())


def write_graphiti(pin_set: PinSet, path: Path) -> Path:
    data = b"".join(update_display_frame(page.pins) for page in pin_set.pages)
    return write_atomic(Path(path), lambda fh: fh.write(data))


def page_image(page: PinPage, levels: int) -> np.ndarray:
    """A page as an 8-bit grey picture one pixel a pin, black the highest (for Send Image)."""
    return (255 - np.round(page.pins.astype(float) * 255 / max(levels, 1))).astype(np.uint8)


# ---------------------------------------------------------------------------------------------
# Monarch (IMAGE SVG profile)


def _pins_path(mask: np.ndarray) -> str:
    """A path of unit squares, one per run of raised pins along a row."""
    parts = []
    for r in range(mask.shape[0]):
        row = mask[r]
        c = 0
        while c < row.size:
            if row[c]:
                start = c
                while c < row.size and row[c]:
                    c += 1
                parts.append(f"M{start} {r}H{c}V{r + 1}H{start}Z")
            else:
                c += 1
    return "".join(parts)


LAYER_NAMES = {"members": "members", "dots": "spots", "lines": "lines", "areas": "areas", "furniture": "furniture", "braille": "braille"}


def monarch_svg(page: PinPage, pin_set: PinSet, title: str) -> str:
    rows, cols = page.pins.shape
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{cols}" height="{rows}" viewBox="0 0 {cols} {rows}">',
           f"<title>{escape(title + '. ' + page.plain)}</title>"]
    by_layer: dict[str, list] = {}
    for region in page.regions:
        by_layer.setdefault(region.layer, []).append(region)
    for layer, regions in by_layer.items():
        names = sorted({r.label for r in regions})
        name = LAYER_NAMES.get(layer, layer)
        out.append(f"<g data-image-layer={quoteattr(name)} aria-label={quoteattr(', '.join(names))}>")
        for i, region in enumerate(regions, start=1):
            label = f"{region.label} {i}" if layer in ("members", "dots") else region.label
            out.append(f"<path d={quoteattr(_pins_path(region.mask))} fill=\"black\" "
                       f"aria-label={quoteattr(label)} aria-description={quoteattr(region.description)}/>")
        out.append("</g>")
    out.append("</svg>")
    return "\n".join(out) + "\n"


def monarch_paths(path: Path, pages: int) -> list[Path]:
    """The overview at `path` (NAME.monarch.svg), each further page beside it (NAME.monarch-2.svg, ...)."""
    path = Path(path)
    stem = path.name[: -len(".monarch.svg")] if path.name.endswith(".monarch.svg") else path.stem
    return [path] + [path.with_name(f"{stem}.monarch-{k}.svg") for k in range(2, pages + 1)]


def write_monarch(pin_set: PinSet, path: Path, title: str) -> list[Path]:
    """One SVG a page (the IMAGE profile holds one graphic): the overview, zooms and key."""
    out = []
    for page, target in zip(pin_set.pages, monarch_paths(path, len(pin_set.pages))):
        text = monarch_svg(page, pin_set, title)
        out.append(write_atomic(target, lambda fh, text=text: fh.write(text.encode("utf-8"))))
    return out


# ---------------------------------------------------------------------------------------------
# The simulator: every page as round dots, grey by height, with its braille line beneath


def simulator_image(pin_set: PinSet, scale: int = 10) -> np.ndarray:
    """(rows, cols) uint8: the pages one under the other, each pin a disc (darker = higher), the
    page's braille line drawn below it as dots."""
    from ..tactile.braille import DOT_POSITION, cell_dots, wrap_cells

    device = pin_set.device
    R, C = device.rows, device.cols
    page_h = (R + 2 + 8) * scale  # pins, a gap, two braille lines of four dot rows each
    image = np.full((page_h * len(pin_set.pages) + scale, (C + 2) * scale), 255, np.uint8)
    yy, xx = np.mgrid[0:scale, 0:scale]
    disc = (yy - (scale - 1) / 2) ** 2 + (xx - (scale - 1) / 2) ** 2 <= (scale * 0.4) ** 2
    small = (yy - (scale - 1) / 2) ** 2 + (xx - (scale - 1) / 2) ** 2 <= (scale * 0.18) ** 2
    for p, page in enumerate(pin_set.pages):
        y0 = p * page_h + scale
        image[y0 - scale // 2 : y0 - scale // 2 + 1, :] = 160  # a rule between pages
        for r in range(R):
            for c in range(C):
                h = int(page.pins[r, c])
                cell = image[y0 + r * scale : y0 + (r + 1) * scale, (c + 1) * scale : (c + 2) * scale]
                if h:
                    cell[disc] = int(200 - 200 * h / device.levels)
                else:
                    cell[small] = 215
        lines = wrap_cells(page.braille, device.text_cells or 20)[:2]
        half = scale // 2
        for i, line in enumerate(lines):
            base_y = y0 + (R + 1 + 4 * i) * scale
            for k, ch in enumerate(line):
                for dot in cell_dots(ch):
                    col, row = DOT_POSITION[dot]
                    y, x = base_y + row * half, (1 + 3 * k) * half + col * half + scale
                    if x + half <= image.shape[1]:
                        image[y : y + half, x : x + half][disc[::2, ::2][:half, :half]] = 0
    return image


def write_simulator(pin_set: PinSet, path: Path) -> Path:
    return write_png(Path(path), simulator_image(pin_set))


# ---------------------------------------------------------------------------------------------
# A lithograph's pin files


PIN_SUFFIXES = {"dotpad": ".dtms", "graphiti": ".graphiti", "monarch": ".monarch.svg"}


def pin_sets(litho, formats) -> dict:
    """The pages for each pin format asked for; raises ExportError before any file is written
    when the picture cannot be shown usefully."""
    from .pins import DEVICES, pin_pages, source_from_lithograph

    source = source_from_lithograph(litho)
    return {fmt: pin_pages(source, DEVICES[fmt]) for fmt in formats}


def save_pins(pin_set: PinSet, fmt: str, folder: Path, *, stem: str, title: str) -> list[Path]:
    """Write one pin format's files: its device file, (Graphiti) each page as PNG, and the simulator PNG."""
    folder = Path(folder)
    written = []
    if fmt == "dotpad":
        written.append(write_dtms(pin_set, folder / f"{stem}.dtms", title))
    elif fmt == "graphiti":
        written.append(write_graphiti(pin_set, folder / f"{stem}.graphiti"))
        for number, page in enumerate(pin_set.pages, start=1):
            written.append(write_png(folder / f"{stem}.graphiti-{number}.png", page_image(page, pin_set.device.levels)))
    elif fmt == "monarch":
        written += write_monarch(pin_set, folder / f"{stem}.monarch.svg", title)
    written.append(write_simulator(pin_set, folder / f"{stem}.{fmt}-simulator.png"))
    return written
