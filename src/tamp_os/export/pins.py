"""A lithograph as pages of a refreshable pin display (issue 34): Dot Pad 320, Graphiti, Monarch.

The plate already knows what is raised (members, lines, channel areas) and what its key says;
this module lays the same content out on a grid of pins, page by page:

- an overview of the whole picture, with a scale bar in pins and the orientation marker (a
  diagonal of four pins across the top-right corner, as the plate's cut corner);
- up to four zoom pages, the quarters of the picture that hold something, at twice the scale;
- a key page: a swatch of each layer and its braille label, drawn in pins.

Every page also carries its text (print and 6-dot braille), for a display's braille line.

Design rules the pages keep (and tests measure on the decoded files): each labelled region covers
at least MIN_REGION_PINS pins and keeps a one-pin gap from every other region; lines are
skeletonised at the source resolution and max-pooled, so a connected line stays connected and a
thin one is never averaged away; no isolated single pins; the scale is exact to a pin.

Pins are (rows, cols) uint8 arrays of heights 0..levels, row 0 at the top of the display, which
shows the top of the image (the far edge of the plate). Only the writers (pin_files.py) turn them
into a vendor's bytes.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ExportError

log = logging.getLogger(__name__)

MIN_REGION_PINS = 4  # a labelled region smaller than this is not found by a fingertip on pins
ZOOM = 2  # zoom pages show a quarter of the picture at twice the overview's scale
MAX_ZOOM_PAGES = 4
BAR_ROWS = 4  # a gap row, then the scale bar's row with its end ticks above and below
MARKER_PINS = 4  # the orientation marker: a diagonal of four pins across the top-right corner
LINE_THRESHOLD = 0.35  # share of the highest line above which a line print's heights are its lines

# Height of each layer on a display with several levels (Graphiti: 0-4); on one-level displays
# everything raised is 1. Domes highest, lines in between, a plateau low: as the plate stacks them.
LEVEL_OF = {"members": 4, "dots": 3, "lines": 3, "areas": 2, "furniture": 4}
RANK_OF = {"furniture": 5, "members": 4, "dots": 4, "lines": 3, "areas": 1}  # who keeps a contested pin


@dataclass(frozen=True)
class PinDevice:
    """One display: its pin grid, how many raised levels, and its braille line (cells, 0 = none)."""

    name: str
    label: str
    cols: int
    rows: int
    levels: int  # 1: pins are up or down; 4: heights 1-4 (Graphiti)
    text_cells: int = 20
    pitch_mm: float = 2.5  # pin pitch, for the simulator's drawing only

    def level(self, kind: str) -> int:
        return 1 if self.levels == 1 else min(self.levels, LEVEL_OF[kind])


DEVICES: dict[str, PinDevice] = {
    "dotpad": PinDevice("dotpad", "Dot Pad 320", 60, 40, 1, 20),
    "graphiti": PinDevice("graphiti", "Graphiti / Graphiti Plus", 60, 40, 4, 40),
    "monarch": PinDevice("monarch", "Monarch", 96, 40, 1, 32),
}


@dataclass
class Layer:
    """What the plate raises, at the picture's own resolution: members (int labels), lines (bool)
    or areas (int labels); `label` is its key text."""

    kind: str  # "members", "dots", "lines" or "areas"
    label: str
    data: np.ndarray


@dataclass
class PinSource:
    """A lithograph's picture as layers, with its scale (sample µm per picture pixel, or None)."""

    shape: tuple[int, int]
    layers: list[Layer]
    um_per_px: float | None
    title: str
    caption: str
    braille_table: str


@dataclass
class PinRegion:
    """One labelled thing on a page: its layer, its label and description, and its pins."""

    layer: str
    label: str
    description: str
    mask: np.ndarray  # bool (rows, cols)


@dataclass
class PinPage:
    name: str  # "overview", "zoom 1 (top left)", "key"
    pins: np.ndarray  # uint8 (rows, cols), 0 = down
    plain: str  # the page's text in print
    braille: str  # the same in Unicode braille (6-dot cells, blank U+2800)
    um_per_pin: float | None  # sample length one pin stands for (None: no scale, or the key page)
    window: tuple[int, int, int, int] | None  # (r0, r1, c0, c1) of the picture shown, in picture pixels
    placement: tuple[int, int, float] | None = None  # (row offset, col offset, pins per picture pixel)
    regions: list[PinRegion] = field(default_factory=list)
    scale_bar: tuple[int, int, int, float] | None = None  # (row, first col, pins long, metres)
    counts: dict = field(default_factory=dict)  # per layer: found in the window, kept on the page


@dataclass
class PinSet:
    device: PinDevice
    pages: list[PinPage]
    source: PinSource
    notes: list[str] = field(default_factory=list)

    @property
    def overview(self) -> PinPage:
        return self.pages[0]


# ---------------------------------------------------------------------------------------------
# From a lithograph to layers


def source_from_lithograph(litho) -> PinSource:
    """The layers of what `litho` raises, at its heightmap's resolution (picture rows only)."""
    from skimage.filters import threshold_otsu
    from skimage.measure import label as cc_label

    params, report = litho.params, litho.report
    channel = getattr(litho, "channel_regions", None)
    rows = channel.shape[0] if channel is not None else litho.heightmap.shape[0]
    relief = (litho.heightmap[:rows] - params.base_mm) / max(params.relief_mm, 1e-9)
    layers: list[Layer] = []
    if channel is not None and report.key:
        for value, entry in enumerate(report.key, start=1):
            mask = channel == value
            if not mask.any():
                continue
            label = entry.label
            if entry.encoding in ("domes", "dots"):
                layers.append(Layer("members" if entry.encoding == "domes" else "dots", label, cc_label(mask, connectivity=1)))
            elif entry.encoding == "ridges":
                layers.append(Layer("lines", label, mask))
            else:  # a plateau (cytoplasm) holds the domes that sit on it: the cell, not a ring around each nucleus
                on_top = np.isin(channel, [v for v, e in enumerate(report.key, start=1) if e.encoding in ("domes", "dots")])
                layers.append(Layer("areas", label, cc_label(mask | on_top, connectivity=1)))
    elif not report.uniform:
        kind = report.content_kind
        objects = getattr(litho, "objects", None)
        if kind in ("members", "shape") and objects is not None and objects.max() > 0:
            layers.append(Layer("members", "members, domes" if kind == "members" else "the shape", objects[:rows]))
        elif kind in ("lines", "grains"):
            lines = relief > LINE_THRESHOLD * relief.max()  # the lines' own height, whatever share of the relief it is
            layers.append(Layer("lines", "grain outlines, lines" if kind == "grains" else "lines", lines))
        elif kind == "plateau" and objects is not None and objects.max() > 0:
            layers.append(Layer("areas", "plateau", objects[:rows]))
        elif np.ptp(relief) > 0:
            mask = relief > threshold_otsu(relief)
            labels = cc_label(mask, connectivity=1)
            layers.append(Layer("members" if labels.max() > 5 else "areas", "raised parts" if labels.max() > 5 else "raised areas", labels))
    metres = report.pixel_size_m
    um_per_px = None
    if metres and litho.furniture is not None and litho.furniture.sample_m_per_print_mm:
        um_per_px = litho.furniture.sample_m_per_print_mm * litho.layout.mm_per_px * 1e6
    title = f"Tactile lithograph of {litho.picture.file.name}"
    caption = params.caption or _spoken_stem(litho.picture.file.name)
    return PinSource((rows, relief.shape[1]), layers, um_per_px, title, caption, params.braille_table)


def _spoken_stem(name: str) -> str:
    """A file name's stem said with spaces (for braille): fept_spheres_sem -> fept spheres sem."""
    from pathlib import Path

    return Path(name).stem.replace("_", " ").replace("-", " ") or "picture"


# ---------------------------------------------------------------------------------------------
# Sampling the picture onto pins


def _samples(window, shape, s: float, ph: int, pw: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Source row and column indices of n×n sample points inside each pin of a ph × pw area."""
    r0, r1, c0, c1 = window
    n = max(2, math.ceil(1 / s) + 1)
    sub = (np.arange(n) + 0.5) / n
    ys = r0 + (np.arange(ph)[:, None] + sub[None, :]).ravel() / s
    xs = c0 + (np.arange(pw)[:, None] + sub[None, :]).ravel() / s
    yi = np.clip(np.floor(ys).astype(int), r0, min(r1, shape[0]) - 1)
    xi = np.clip(np.floor(xs).astype(int), c0, min(c1, shape[1]) - 1)
    return yi, xi, n


def _pooled(data: np.ndarray, yi, xi, n: int, ph: int, pw: int) -> np.ndarray:
    """(ph, pw, n*n) samples of `data` in each pin."""
    return data[np.ix_(yi, xi)].reshape(ph, n, pw, n).transpose(0, 2, 1, 3).reshape(ph, pw, n * n)


def _label_coverage(labels: np.ndarray, yi, xi, n, ph, pw) -> tuple[np.ndarray, np.ndarray]:
    """Per pin: the label covering most of it (0 if none) and the share it covers."""
    samples = _pooled(labels, yi, xi, n, ph, pw)
    flat = samples.reshape(-1, n * n)
    best = np.zeros(flat.shape[0], np.int64)
    share = np.zeros(flat.shape[0])
    nonzero = (flat > 0).any(axis=1)
    for i in np.flatnonzero(nonzero):
        values, counts = np.unique(flat[i][flat[i] > 0], return_counts=True)
        k = int(np.argmax(counts))
        best[i], share[i] = values[k], counts[k] / (n * n)
    return best.reshape(ph, pw), share.reshape(ph, pw)


def skeleton_of(mask: np.ndarray) -> np.ndarray:
    from skimage.morphology import skeletonize

    return skeletonize(mask) if mask.any() else mask


# ---------------------------------------------------------------------------------------------
# One picture page


def _marker(device: PinDevice) -> np.ndarray:
    m = np.zeros((device.rows, device.cols), bool)
    for i in range(MARKER_PINS):
        m[i, device.cols - MARKER_PINS + i] = True
    return m


def _keep_out(device: PinDevice) -> np.ndarray:
    """Pins the picture may not use: the marker's corner triangle and a one-pin gap around it."""
    from scipy.ndimage import binary_dilation

    r, c = np.indices((device.rows, device.cols))
    corner = (c - r >= device.cols - MARKER_PINS) & (r < MARKER_PINS)
    return binary_dilation(corner | _marker(device), np.ones((3, 3), bool))


def _separate(labels: np.ndarray, rank: dict[int, float]) -> np.ndarray:
    """Lower every pin whose 8-neighbour belongs to another region and that loses to it (lower
    rank; among equals the larger region gives way). One pass leaves every pair of regions a
    one-pin gap: of two touching pins, the one that loses is always the same."""
    out = labels.copy()
    padded = np.pad(labels, 1)
    lose = np.zeros(labels.shape, bool)
    key = np.vectorize(lambda v: rank.get(int(v), 0.0), otypes=[float])
    own = key(labels)
    h, w = labels.shape
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == 0 and dc == 0:
                continue
            other = padded[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w]
            clash = (labels > 0) & (other > 0) & (other != labels)
            if clash.any():
                theirs = key(other)
                lose |= clash & ((own < theirs) | ((own == theirs) & (labels > other)))
    out[lose] = 0
    return out


def _settle(region_id: np.ndarray, rank: dict[int, float], keep_out: np.ndarray) -> np.ndarray:
    """Separate the regions, keep each one's largest piece, and drop those under MIN_REGION_PINS."""
    region_id = region_id.copy()
    region_id[keep_out] = 0
    region_id = _separate(region_id, rank)
    out = np.zeros_like(region_id)
    for rid in np.unique(region_id):
        if rid == 0:
            continue
        mask = _largest_piece(region_id == rid)
        if mask.sum() >= MIN_REGION_PINS:
            out[mask] = rid
    return out


def _largest_piece(mask: np.ndarray) -> np.ndarray:
    from skimage.measure import label as cc_label

    pieces = cc_label(mask, connectivity=2)
    if pieces.max() <= 1:
        return mask
    sizes = np.bincount(pieces.ravel())
    sizes[0] = 0
    return pieces == int(np.argmax(sizes))


def render_picture_page(source: PinSource, device: PinDevice, window, *, s: float, name: str) -> PinPage:
    """The part `window` (r0, r1, c0, c1) of the picture at s pins per picture pixel, with the
    marker and, when the scale is known, a scale bar."""
    R, C = device.rows, device.cols
    r0, r1, c0, c1 = window
    ph, pw = min(R - BAR_ROWS, int(math.floor((r1 - r0) * s + 1e-9))), min(C, int(math.floor((c1 - c0) * s + 1e-9)))
    ph, pw = max(ph, 1), max(pw, 1)
    oy, ox = 0, (C - pw) // 2
    grid = (_samples(window, source.shape, s, ph, pw), (oy, ox, ph, pw))
    region_id = np.zeros((R, C), np.int64)
    areas = np.zeros((R, C), np.int64)
    done = _Placed()
    for layer in source.layers:
        placed = np.zeros((R, C), np.int64)
        if layer.kind == "lines":
            _place_lines(layer, window, grid, placed, done)
        else:
            _place_labels(layer, source, device, window, s, grid, placed, done)
        if layer.kind == "areas":
            areas[placed > 0] = placed[placed > 0]
        else:
            free = region_id == 0
            region_id[free & (placed > 0)] = placed[free & (placed > 0)]
    # members and lines first settle among themselves; areas then take the pins left (so a plateau
    # is not shredded by footprints that lose to their neighbours), and all are separated again
    keep_out = _keep_out(device)
    region_id = _settle(region_id, done.rank, keep_out)
    region_id[(region_id == 0) & (areas > 0)] = areas[(region_id == 0) & (areas > 0)]
    region_id = _settle(region_id, done.rank, keep_out)
    pins = np.zeros((R, C), np.uint8)
    regions = []
    for rid, (kind, label, desc) in done.info.items():
        mask = region_id == rid
        if not mask.any():
            continue
        pins[mask] = device.level(kind)
        regions.append(PinRegion(kind, label, desc, mask))
        done.counts[label]["kept"] = done.counts[label].get("kept", 0) + 1
    um_pin = source.um_per_px / s if source.um_per_px else None
    bar = _page_furniture(device, um_pin, pins, regions)
    words = [source.caption if name == "overview" else name]
    if um_pin:
        words.append(f"1 pin = {length_words(um_pin)}")
        if bar:
            words.append(f"bar {length_words(bar[3] * 1e6)}")
    plain = ". ".join(words) + "."
    return PinPage(name, pins, plain, _braille(plain, source.braille_table), um_pin, window, (oy, ox, s), regions, bar,
                   done.counts)


@dataclass
class _Placed:
    """The regions a page has placed so far: id -> (kind, layer label, description), who keeps a
    contested pin, and each layer's counts."""

    info: dict = field(default_factory=dict)
    rank: dict = field(default_factory=dict)
    counts: dict = field(default_factory=dict)
    next_id: int = 1

    def add(self, mask: np.ndarray, placed: np.ndarray, kind: str, label: str, desc: str, rank: float) -> None:
        placed[mask] = self.next_id
        self.info[self.next_id] = (kind, label, desc)
        self.rank[self.next_id] = rank
        self.next_id += 1


def _place_lines(layer, window, grid, placed: np.ndarray, done: _Placed) -> None:
    """A line layer: skeletonised at the source, max-pooled onto the pins, one region per line."""
    from skimage.measure import label as cc_label

    r0, r1, c0, c1 = window
    (yi, xi, n), (oy, ox, ph, pw) = grid
    skeleton = skeleton_of(layer.data.astype(bool))
    hit = _pooled(skeleton, yi, xi, n, ph, pw).any(axis=2)
    thin = skeleton_of(hit)
    # a thinned line keeps its topology; endpoints that thinning shortened are not lost
    pieces = cc_label(thin, connectivity=2)
    done.counts[layer.label] = {"found": int(cc_label(skeleton[r0:r1, c0:c1], connectivity=2).max())}
    for k in range(1, pieces.max() + 1):
        block = np.zeros(placed.shape, bool)
        block[oy : oy + ph, ox : ox + pw] = pieces == k
        # a long line keeps its pins
        done.add(block, placed, layer.kind, layer.label, f"a line of {int(block.sum())} pins",
                 RANK_OF["lines"] + 1e-6 * block.sum())


def _place_labels(layer, source: PinSource, device: PinDevice, window, s: float, grid, placed: np.ndarray,
                  done: _Placed) -> None:
    """A labelled layer (members, dots, areas): each label the pins it covers for the most part."""
    r0, r1, c0, c1 = window
    (yi, xi, n), (oy, ox, ph, pw) = grid
    R, C = placed.shape
    ids = [int(v) for v in np.unique(layer.data[r0:r1, c0:c1]) if v > 0]
    done.counts[layer.label] = {"found": len(ids)}
    best, share = _label_coverage(layer.data, yi, xi, n, ph, pw)
    areas, centres = _label_stats(layer.data)  # one pass for all labels, not one over the picture per label
    for v in ids:
        pins = np.zeros((R, C), bool)
        pins[oy : oy + ph, ox : ox + pw] = (best == v) & (share >= 0.4)
        area_px = float(areas[v])
        if layer.kind in ("members", "dots") and pins.sum() < MIN_REGION_PINS and area_px * s * s >= 1.0:
            pins = _block_at(centres[v], window, s, oy, ox, ph, pw, R, C)
        pins &= placed == 0
        if not pins.any():
            continue
        if layer.kind == "areas" and device.levels == 1:
            pins = _outline(pins)  # a large solid field of raised pins reads as one blur
        diameter = 2 * math.sqrt(area_px / math.pi) * (source.um_per_px or 0)
        desc = f"{layer.label}, about {length_words(diameter)} across" if source.um_per_px else layer.label
        done.add(pins, placed, layer.kind, layer.label, desc, RANK_OF[layer.kind] - 1e-6 * pins.sum())


def _page_furniture(device: PinDevice, um_pin, pins: np.ndarray, regions: list) -> tuple | None:
    """The orientation marker and, when the scale is known, the scale bar; returns the bar."""
    R, C = pins.shape
    marker = _marker(device)
    pins[marker] = device.level("furniture")
    regions.append(PinRegion("furniture", "orientation marker", "top right corner, as the plate's cut corner", marker))
    bar = _scale_bar(device, um_pin) if um_pin else None
    if bar is not None:
        row, col, length, metres = bar
        mask = np.zeros((R, C), bool)
        mask[row, col : col + length] = True
        mask[row - 1 : row + 2, col] = True
        mask[row - 1 : row + 2, col + length - 1] = True
        pins[mask] = device.level("furniture")
        regions.append(PinRegion("furniture", "scale bar", f"{length_words(metres * 1e6)} long", mask))
    return bar


def _label_stats(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each label's area in pixels and centre (mean row, mean column), by label value, in one pass
    (a checkerboard's 1,250 members made 14,000 passes over a 1000² picture: 17 s)."""
    flat = np.asarray(labels).ravel()
    areas = np.bincount(flat)
    rows, cols = np.divmod(np.arange(flat.size), labels.shape[1])
    with np.errstate(invalid="ignore", divide="ignore"):  # sums of integers: exact, as the mean of each label's rows is
        centres = np.column_stack([np.bincount(flat, weights=rows, minlength=areas.size) / areas,
                                   np.bincount(flat, weights=cols, minlength=areas.size) / areas])
    return areas, centres


def _block_at(centre_px, window, s, oy, ox, ph, pw, R, C) -> np.ndarray:
    """A 2 × 2 block of pins at a small member's centre (row, column in picture pixels; it is at
    least a pin large)."""
    r0, _, c0, _ = window
    cy, cx = (centre_px[0] + 0.5 - r0) * s, (centre_px[1] + 0.5 - c0) * s
    i, j = int(round(cy - 1)), int(round(cx - 1))
    i, j = min(max(i, 0), ph - 2), min(max(j, 0), pw - 2)
    out = np.zeros((R, C), bool)
    if ph >= 2 and pw >= 2:
        out[oy + i : oy + i + 2, ox + j : ox + j + 2] = True
    return out


def _outline(mask: np.ndarray) -> np.ndarray:
    from scipy.ndimage import binary_erosion

    inner = binary_erosion(mask, np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool))
    return mask & ~inner


NICE = (1, 2, 5)


def _scale_bar(device: PinDevice, um_per_pin: float) -> tuple[int, int, int, float] | None:
    """(row, first col, length in pins, metres) of a round bar between 8 and half the width."""
    best = None
    for exponent in range(-6, 7):
        for m in NICE:
            um = m * 10.0**exponent
            length = um / um_per_pin
            if 8 <= length <= device.cols // 2 and abs(length - round(length)) <= 0.5:
                if best is None or length > best[0]:
                    best = (length, um)
    if best is None:
        return None
    length, um = best
    return device.rows - 2, 0, int(round(length)), um * 1e-6


def length_words(um: float) -> str:
    from ..units import format_length

    return format_length(float(f"{um:.2g}") * 1e-6)


def _braille(text: str, table: str) -> str:
    from ..tactile.braille import to_braille

    return to_braille(text, table, what="pin display text")


# ---------------------------------------------------------------------------------------------
# The key page: a swatch of each layer and its label in braille, drawn in pins


BRAILLE_PITCH = (4, 3)  # rows, cols per cell on pins: 3 × 2 dots and a blank row and column


def braille_pins(cells: str, max_cells: int) -> np.ndarray:
    """Unicode braille drawn on pins: each cell 3 rows × 2 columns of dots, one pin apart."""
    from ..tactile.braille import DOT_POSITION, cell_dots

    cells = cells[:max_cells]
    out = np.zeros((3, max(1, len(cells) * 3 - 1)), bool)
    for k, cell in enumerate(cells):
        for dot in cell_dots(cell):
            col, row = DOT_POSITION[dot]
            if row < 3:
                out[row, 3 * k + col] = True
    return out


def render_key_page(source: PinSource, device: PinDevice, bar_text: str | None) -> PinPage:
    from ..tactile.braille import wrap_cells

    R, C = device.rows, device.cols
    pins = np.zeros((R, C), np.uint8)
    regions = []
    top = 0
    rows = [(layer.kind, layer.label) for layer in source.layers]
    if bar_text:
        rows.append(("furniture", bar_text))
    swatch_w, text_x = 6, 8
    cells = (C - text_x + 1) // BRAILLE_PITCH[1]
    title = _braille("key", source.braille_table)
    t = braille_pins(title, cells)
    pins[top : top + 3, : t.shape[1]][t] = device.level("furniture")
    regions.append(PinRegion("braille", "key", "the word key", np.pad(t, ((top, R - top - 3), (0, C - t.shape[1])))))
    top += BRAILLE_PITCH[0] + 1
    plain_rows = []
    for kind, label in rows:
        braille = _braille(label, source.braille_table)
        lines = wrap_cells(braille, cells)
        height = max(3, len(lines) * BRAILLE_PITCH[0] - 1)
        if top + height > R:
            break
        swatches = []  # each swatch piece is its own region (two domes are two members)
        if kind in ("members", "dots"):
            for x in ((0, 4) if kind == "members" else (0,)):
                piece = np.zeros((R, C), bool)
                piece[top : top + 2, x : x + 2] = True
                swatches.append(piece)
        else:
            piece = np.zeros((R, C), bool)
            if kind == "lines":
                piece[top + 1, 0:swatch_w] = True
            elif kind == "areas":
                piece[top : top + 3, 0:swatch_w] = True
                if device.levels == 1:
                    piece = _outline(piece)
            else:  # the scale bar, with its end ticks
                piece[top + 1, 0:swatch_w] = True
                piece[top : top + 3, 0] = piece[top : top + 3, swatch_w - 1] = True
            swatches.append(piece)
        for piece in swatches:
            pins[piece] = device.level(kind)
            regions.append(PinRegion(kind, label, f"swatch of {label}", piece))
        for i, line in enumerate(lines):
            b = braille_pins(line, cells)
            y = top + i * BRAILLE_PITCH[0]
            mask = np.zeros((R, C), bool)
            mask[y : y + 3, text_x : text_x + b.shape[1]] = b
            pins[mask] = device.level("furniture")
            regions.append(PinRegion("braille", label, "braille label", mask))
        plain_rows.append(label)
        top += height + 2
    marker = _marker(device)  # the key page is held the same way up as the picture pages
    pins[marker] = device.level("furniture")
    regions.append(PinRegion("furniture", "orientation marker", "top right corner, as the plate's cut corner", marker))
    plain = "Key: " + "; ".join(plain_rows) + "."
    return PinPage("key", pins, plain, _braille(plain, source.braille_table), None, None, None, regions, None, {})


# ---------------------------------------------------------------------------------------------
# All pages


def zoom_windows(shape: tuple[int, int], device: PinDevice, s: float, *, zoom: float = ZOOM) -> list[tuple[int, int, int, int]]:
    """Windows (r0, r1, c0, c1) the display shows at ZOOM × s pins per pixel, tiling the picture:
    each the display's own shape (a wide strip gives slices along it, a 4:3 picture its quarters),
    evenly spaced so that together they cover it."""
    rows, cols = shape
    win_r = min(rows, max(1, int((device.rows - BAR_ROWS) / (s * zoom))))
    win_c = min(cols, max(1, int(device.cols / (s * zoom))))
    starts_r = np.linspace(0, rows - win_r, max(1, math.ceil(rows / win_r))).round().astype(int)
    starts_c = np.linspace(0, cols - win_c, max(1, math.ceil(cols / win_c))).round().astype(int)
    return [(int(r), int(r) + win_r, int(c), int(c) + win_c) for r in starts_r for c in starts_c]


def _where(window, shape) -> str:
    r0, r1, c0, c1 = window
    rows, cols = shape
    v = ("top" if (r0 + r1) / 2 < rows / 3 else "bottom" if (r0 + r1) / 2 > 2 * rows / 3 else "middle")
    h = ("left" if (c0 + c1) / 2 < cols / 3 else "right" if (c0 + c1) / 2 > 2 * cols / 3 else "centre")
    return "centre" if v == "middle" and h == "centre" else f"{v} {h}" if v != "middle" else f"middle {h}" if h != "centre" else v


def pin_pages(source: PinSource, device: PinDevice) -> PinSet:
    """Overview, zoom pages and key for `device`; ExportError when nothing fits usefully."""
    rows, cols = source.shape
    s = min(device.cols / cols, (device.rows - BAR_ROWS) / rows)
    overview = render_picture_page(source, device, (0, rows, 0, cols), s=s, name="overview")
    pages = [overview]
    raised = np.zeros(source.shape, bool)
    for layer in source.layers:
        raised |= layer.data.astype(bool)
    windows = [w for w in zoom_windows(source.shape, device, s) if raised[w[0] : w[1], w[2] : w[3]].any()]
    if len(windows) > MAX_ZOOM_PAGES:  # the densest, in reading order
        density = [raised[w[0] : w[1], w[2] : w[3]].mean() for w in windows]
        chosen = sorted(np.argsort(density)[::-1][:MAX_ZOOM_PAGES])
        windows = [windows[i] for i in chosen]
    for window in windows:
        name = f"zoom {len(pages)}, {_where(window, source.shape)}, twice the scale"
        pages.append(render_picture_page(source, device, window, s=s * ZOOM, name=name))
    bar = overview.scale_bar
    pages.append(render_key_page(source, device, f"scale bar {length_words(bar[3] * 1e6)}" if bar else None))
    pin_set = PinSet(device, pages, source)
    _check_useful(pin_set, s)
    pin_set.notes.extend(_partial_notes(pin_set, s))
    for note in pin_set.notes:
        log.warning(note)
    return pin_set


def _typical_size_px(layer: Layer) -> float:
    """About how wide a layer's things are, in picture pixels (members: the median's circle;
    lines: twice the mean width, the spacing a pin would need to tell two apart)."""
    if layer.kind == "lines":
        m = layer.data.astype(bool)
        return max(m.sum() / max(1, int(skeleton_of(m).sum())), 1.0) * 2
    areas = np.bincount(layer.data.ravel())[1:]
    areas = areas[areas > 0]
    return 2 * math.sqrt(float(np.median(areas)) / math.pi) if areas.size else 1.0


ZOOMS_TRIED = (3, 4, 6, 8, 12, 16)


def zoom_needed(source: PinSource, device: PinDevice, s: float, *, layer: Layer) -> int | None:
    """The least zoom (of ZOOMS_TRIED) at which the densest window keeps 90 % of the layer's
    members it holds, each on its own; None when even 16× does not."""
    raised = layer.data > 0
    one = PinSource(source.shape, [layer], source.um_per_px, source.title, source.caption, source.braille_table)
    for zoom in ZOOMS_TRIED:
        windows = zoom_windows(source.shape, device, s, zoom=zoom)
        best = max(windows, key=lambda w: raised[w[0] : w[1], w[2] : w[3]].sum())
        page = render_picture_page(one, device, best, s=s * zoom, name="trial")
        count = page.counts.get(layer.label, {})
        if count.get("found") and count.get("kept", 0) >= 0.9 * count["found"]:
            return zoom
    return None


def _partial_notes(pin_set: PinSet, s: float) -> list[str]:
    """A sentence for each layer of members the overview shows less than half of, with the zoom
    at which each would be felt on its own."""
    notes = []
    overview = pin_set.overview
    for layer in pin_set.source.layers:
        if layer.kind not in ("members", "dots"):
            continue
        count = overview.counts.get(layer.label, {})
        found, kept = count.get("found", 0), count.get("kept", 0)
        if found and kept < found / 2:
            zoomed = [p.counts.get(layer.label, {}) for p in pin_set.pages[1:-1]]
            z_found, z_kept = sum(c.get("found", 0) for c in zoomed), sum(c.get("kept", 0) for c in zoomed)
            need = zoom_needed(pin_set.source, pin_set.device, s, layer=layer)
            at = (f"would each be felt on their own at about {need}× (crop the picture to about 1/{need} of its width "
                  f"for the pin pages)") if need else "stay too close together even at 16×"
            notes.append(f"{pin_set.device.label}: the overview shows {kept} of the {found} {layer.label} and the zoom pages "
                         f"{z_kept} of {z_found}; they are too small and close for a pin each, and {at}.")
    return notes


def _check_useful(pin_set: PinSet, s: float) -> None:
    """ExportError when the picture has content and no page shows any of it: the structure is finer
    than a pin at every zoom. Says the zoom it would need."""
    source = pin_set.source
    if not source.layers:
        return
    shown = sum(1 for p in pin_set.pages[:-1] for r in p.regions if r.layer not in ("furniture", "braille"))
    if shown:
        return
    size_px = min(_typical_size_px(layer) for layer in source.layers)
    need = math.ceil(2 / max(size_px * s, 1e-9))  # two pins across the typical structure
    tried = [zoom_needed(source, pin_set.device, s, layer=layer) for layer in source.layers if layer.kind != "lines"]
    if tried and all(tried):
        need = min(tried)
    pin_um = f" (a pin is {length_words(source.um_per_px / (s * ZOOM))} at the closest zoom)" if source.um_per_px else ""
    size = f"about {length_words(size_px * source.um_per_px)}" if source.um_per_px else f"about {size_px:.1f} picture pixels"
    raise ExportError(
        f"{source.caption}: the structure ({size} across) is finer than a pin on every page of the "
        f"{pin_set.device.label}{pin_um}; it needs a zoom of about {need}× (the pages go to {ZOOM}×). "
        f"Crop the picture to about 1/{need} of its width and make the pin pages from that crop."
    )
