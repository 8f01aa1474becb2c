"""Synthetic pictures with exact truth for the content-aware relief (issue 26).

Each maker returns a `Truth`: the picture (float32 0..1, row 0 = top) and what a finger should
find in it: members of a population (labels), a line network (mask), a lattice's pitch, grains
(labels), text labels (mask). Sizes are given for a 256 px wide picture printed 100 mm wide
(0.39 mm per px) and scale with `cols`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage


@dataclass(frozen=True)
class Truth:
    name: str
    image: np.ndarray  # (rows, cols) float32, 0..1
    members: np.ndarray | None = None  # (rows, cols) int32 labels of the population, 0 = ground
    lines: np.ndarray | None = None  # (rows, cols) bool, True on the lines
    pitch_px: float | None = None  # a lattice's period in pixels
    grains: np.ndarray | None = None  # (rows, cols) int32 grain labels, 0 = mount
    text: np.ndarray | None = None  # (rows, cols) bool, True on printed text


def _grid(rows, cols):
    return np.mgrid[0:rows, 0:cols].astype(np.float32)


def dim_and_bright_beads(rows: int = 192, cols: int = 256, seed: int = 3) -> Truth:
    """Ten fluorescent beads on a dark ground, peak brightness 0.15 to 1.0 (a 7x range), blurred
    by the optics, one touching pair, noise; plus a broad, dim glow of shading (not an object)."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    s = cols / 256
    centres = [(40, 40), (50, 120), (45, 200), (100, 70), (100, 150), (104, 159), (150, 40), (160, 110), (150, 190), (90, 230)]
    peaks = np.linspace(0.15, 1.0, len(centres))
    rng.shuffle(peaks)
    image = np.zeros((rows, cols), np.float32)
    labels = np.zeros((rows, cols), np.int32)
    for k, ((cy, cx), peak) in enumerate(zip(centres, peaks), start=1):
        cy, cx, r = cy * rows / 192, cx * s, 5.5 * s
        d2 = (yy - cy) ** 2 + (xx - cx) ** 2
        disk = d2 <= r * r
        image = np.maximum(image, peak * disk.astype(np.float32))
        labels[disk & (labels == 0)] = k
    image = ndimage.gaussian_filter(image, 1.5 * s)
    glow = 0.08 * np.exp(-((yy - 0.5 * rows) ** 2 + (xx - 0.3 * cols) ** 2) / (2 * (0.25 * cols) ** 2))
    image = image + glow + 0.02 + 0.012 * rng.standard_normal((rows, cols))
    return Truth("dim_and_bright_beads", np.clip(image, 0, 1).astype(np.float32), members=labels)


def dark_line_network(rows: int = 192, cols: int = 256, seed: int = 4) -> Truth:
    """Grains of a polished section (Voronoi cells 25–40 px across) on a bright ground, their
    boundaries dark lines 2 px wide; grains vary by ±4 % of grey, noise 3 %."""
    rng = np.random.default_rng(seed)
    cells, boundary = _voronoi(rows, cols, 40, rng)
    image = 0.8 + 0.04 * rng.uniform(-1, 1, int(cells.max()) + 1)[cells]
    lines = ndimage.binary_dilation(boundary, iterations=1)
    image = np.where(lines, 0.25, image)
    image = ndimage.gaussian_filter(image, 0.7) + 0.03 * rng.standard_normal((rows, cols))
    return Truth("dark_line_network", np.clip(image, 0, 1).astype(np.float32), lines=lines, grains=np.where(lines, 0, cells + 1))


def _voronoi(rows, cols, count, rng):
    """Voronoi cells of `count` random seeds (int labels) and their 4-connected boundary (bool)."""
    seeds = np.stack([rng.uniform(0, rows, count), rng.uniform(0, cols, count)], 1)
    yy, xx = _grid(rows, cols)
    d = (yy[..., None] - seeds[:, 0]) ** 2 + (xx[..., None] - seeds[:, 1]) ** 2
    cells = np.argmin(d, axis=-1).astype(np.int32)
    boundary = np.zeros((rows, cols), bool)
    boundary[1:] |= cells[1:] != cells[:-1]
    boundary[:, 1:] |= cells[:, 1:] != cells[:, :-1]
    return cells, boundary


def membranes_on_grey(rows: int = 450, cols: int = 600, seed: int = 12) -> Truth:
    """Cell outlines as in serial-section TEM: Voronoi cells about 6 mm across on a 100 mm print
    (150 seeds), their membranes dark lines 3 px (0.5 mm) wide, on a mid-grey ground whose cells
    differ by ±8 % of grey and carry a grainy texture (cytoplasm, ±8 % in 0.25 mm grains) and a few dark specks."""
    rng = np.random.default_rng(seed)
    cells, boundary = _voronoi(rows, cols, 150, rng)
    image = 0.55 + 0.08 * rng.uniform(-1, 1, int(cells.max()) + 1)[cells]
    image = image + 0.08 * ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 1.5) / 0.19  # grain ~1.5 px, ±0.08
    specks = ndimage.binary_dilation(rng.uniform(size=(rows, cols)) < 0.002, iterations=1)
    lines = ndimage.binary_dilation(boundary, iterations=1)
    image = np.where(specks & ~lines, 0.3, image)
    image = np.where(lines, 0.2, image)
    image = ndimage.gaussian_filter(image, 0.7) + 0.03 * rng.standard_normal((rows, cols))
    return Truth("membranes_on_grey", np.clip(image, 0, 1).astype(np.float32), lines=lines, grains=np.where(lines, 0, cells + 1))


def lumps_as_wide_as_gaps(rows: int = 450, cols: int = 600, seed: int = 13) -> Truth:
    """Bright crystallite lumps (irregular, 16 px ≈ 2.7 mm across) placed at random at least 32 px
    apart (no lattice), so the mid-grey gaps between them are as wide as the lumps: no network."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    image = np.full((rows, cols), 0.45, np.float32)
    labels = np.zeros((rows, cols), np.int32)
    centres: list[tuple[float, float]] = []
    for _ in range(4000):
        y, x = rng.uniform(10, rows - 10), rng.uniform(10, cols - 10)
        if all((y - a) ** 2 + (x - b) ** 2 >= 32.0**2 for a, b in centres):
            centres.append((y, x))
    for k, (y, x) in enumerate(centres, start=1):
        angle = np.arctan2(yy - y, xx - x)
        r = 8.0 * (1 + 0.2 * np.sin(3 * angle + rng.uniform(0, 6.3)))  # an irregular lump
        lump = (yy - y) ** 2 + (xx - x) ** 2 <= r**2
        image[lump] = 0.8 + 0.1 * rng.uniform(-1, 1)
        labels[lump & (labels == 0)] = k
    image = image + 0.06 * ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 1.5) / 0.19
    image = ndimage.gaussian_filter(image, 0.7) + 0.03 * rng.standard_normal((rows, cols))
    return Truth("lumps_as_wide_as_gaps", np.clip(image, 0, 1).astype(np.float32), members=labels)


def dot_lattice(rows: int = 192, cols: int = 256, pitch_px: float = 10.0, seed: int = 5) -> Truth:
    """A square lattice of bright dots (as atoms in HRTEM) at `pitch_px` (10 px = 3.9 mm on the
    print), dot radius a quarter of the pitch, on a mid-grey ground with noise."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    p = pitch_px * cols / 256
    bump = (1 + np.cos(2 * np.pi * yy / p)) * (1 + np.cos(2 * np.pi * xx / p)) / 4  # 1 at each lattice point
    image = 0.3 + 0.5 * (bump > 0.5)
    image = ndimage.gaussian_filter(image.astype(np.float32), 0.1 * p) + 0.05 * rng.standard_normal((rows, cols))
    # Every lattice point in the picture, one member each (a disk a fifth of the pitch across, at
    # the dot's centre; cut by the picture's edge at the border, as the dots are).
    labels = np.zeros((rows, cols), np.int32)
    k = 0
    for cy in np.arange(0, rows, p):
        for cx in np.arange(0, cols, p):
            k += 1
            labels[(yy - cy) ** 2 + (xx - cx) ** 2 <= (p / 5) ** 2] = k
    return Truth("dot_lattice", np.clip(image, 0, 1).astype(np.float32), members=labels, pitch_px=p)


def faint_grains(rows: int = 192, cols: int = 256, seed: int = 6) -> Truth:
    """Channelling contrast: grains (Voronoi cells) whose grey levels differ by 3 % steps of the
    full range (0.60, 0.63, 0.66), noise 1 %, on a specimen that covers the right 80 %; the
    mount at the left is black."""
    rng = np.random.default_rng(seed)
    cells, _ = _voronoi(rows, cols, 30, rng)
    shade = 0.60 + 0.03 * (np.arange(int(cells.max()) + 1) % 3)
    image = shade[cells]
    grains = cells + 1
    mount = np.zeros((rows, cols), bool)
    mount[:, : int(0.2 * cols)] = True
    image = np.where(mount, 0.05, image) + 0.01 * rng.standard_normal((rows, cols))
    return Truth("faint_grains", np.clip(image, 0, 1).astype(np.float32), grains=np.where(mount, 0, grains).astype(np.int32))


def polished_alloy(rows: int = 400, cols: int = 400, seed: int = 7) -> Truth:
    """Issue 32, class 3: a polished alloy on a dark mount. A square specimen (the middle 70 %) of 40
    Voronoi grains whose grey levels differ by up to 20 of 255 (0.67 ± 0.04), with dark carbide dots
    (2 % of it, 0.24) and bright twin lines (0.74) that span the range beside the grains' weak
    contrast; the mount is 0.1; noise 1 %."""
    rng = np.random.default_rng(seed)
    cells, _ = _voronoi(rows, cols, 40, rng)
    shade = 0.67 + rng.integers(-10, 11, int(cells.max()) + 1) / 255.0
    image = shade[cells]
    yy, xx = _grid(rows, cols)
    specimen = (np.abs(yy - rows / 2) < 0.35 * rows) & (np.abs(xx - cols / 2) < 0.35 * cols)
    for _ in range(6):  # twin lines inside grains
        cy, cx, a = rng.uniform(0.2 * rows, 0.8 * rows), rng.uniform(0.2 * cols, 0.8 * cols), rng.uniform(0, np.pi)
        line = np.abs((yy - cy) * np.cos(a) - (xx - cx) * np.sin(a)) < 0.8
        image = np.where(line & (cells == cells[int(cy), int(cx)]), 0.74, image)
    for _ in range(30):  # carbides
        cy, cx = rng.uniform(0.17 * rows, 0.83 * rows), rng.uniform(0.17 * cols, 0.83 * cols)
        image = np.where((yy - cy) ** 2 + (xx - cx) ** 2 < 4.5, 0.24, image)
    image = np.where(specimen, image, 0.1) + 0.01 * rng.standard_normal((rows, cols))
    return Truth("polished_alloy", np.clip(image, 0, 1).astype(np.float32), grains=np.where(specimen, cells + 1, 0).astype(np.int32))


def packed_cells(rows: int = 450, cols: int = 600, seed: int = 3, overlap: float = 0.75, tries: int = 3000,
                 fibres: int = 8) -> Truth:
    """Issue 32, class 1: bright biconcave cells packed edge to edge (a backscatter SEM of cells on a
    filter, no modality recorded), of one even brightness, so the picture's most common brightness is
    the cells' own and the dark gaps between them split into more pieces than the cells do. Discs of
    radius 21-27 px (4.6-6 mm on a 100 mm print), centres at least `overlap` × the sum of two radii
    apart; a dimple in each; `fibres` thin bright fibres over everything. Members: the discs (overlaps
    go to the first)."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    image = 0.12 + 0.03 * rng.standard_normal((rows, cols))
    labels = np.zeros((rows, cols), np.int32)
    centres: list[tuple[float, float, float]] = []
    for _ in range(tries):
        cy, cx, r = rng.uniform(0, rows), rng.uniform(0, cols), rng.uniform(21, 27)
        if any((cy - a) ** 2 + (cx - b) ** 2 < (overlap * (r + c)) ** 2 for a, b, c in centres):
            continue
        centres.append((cy, cx, r))
        d = np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2) / r
        inside = d <= 1
        image = np.where(inside, 0.78 + 0.06 * np.exp(-((d - 0.7) / 0.22) ** 2) - 0.08 * np.exp(-(d / 0.35) ** 2), image)
        labels[inside & (labels == 0)] = len(centres)
    for _ in range(fibres):  # thin fibres across
        y0, angle = rng.uniform(0, rows), rng.uniform(0, np.pi)
        dist = np.abs((yy - y0) * np.cos(angle) - (xx - cols / 2) * np.sin(angle))
        image = np.maximum(image, 0.8 * np.exp(-((dist / 1.2) ** 2)))
    image = image + 0.02 * rng.standard_normal((rows, cols))
    return Truth("packed_cells", np.clip(image, 0, 1).astype(np.float32), members=labels)


def cells_and_fibres(rows: int = 450, cols: int = 600, seed: int = 11, fibres: int = 6, fibre_px: float = 2.0) -> Truth:
    """Issue 32, class 1's last part: bright round cells (radius 21-27 px, 4.6-6 mm on a 100 mm
    print) on a dark filter, apart by gaps, and `fibres` thin bright straight fibres (Gaussian
    profile, half-width `fibre_px`: about 0.4 mm wide on the print) crossing cells and gaps alike.
    Members: the cells; lines: the fibres' centre lines (one pixel wide)."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    image = 0.12 + 0.02 * rng.standard_normal((rows, cols))
    labels = np.zeros((rows, cols), np.int32)
    centres: list[tuple[float, float, float]] = []
    for _ in range(2000):
        cy, cx, r = rng.uniform(30, rows - 30), rng.uniform(30, cols - 30), rng.uniform(21, 27)
        if any((cy - a) ** 2 + (cx - b) ** 2 < (r + c + 10) ** 2 for a, b, c in centres):
            continue
        centres.append((cy, cx, r))
        d = np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2) / r
        inside = d <= 1
        image = np.where(inside, 0.72 + 0.06 * np.exp(-((d - 0.7) / 0.22) ** 2) - 0.06 * np.exp(-(d / 0.35) ** 2), image)
        labels[inside] = len(centres)
    lines = np.zeros((rows, cols), bool)
    for k in range(fibres):  # straight fibres at spread angles, across the whole picture
        y0, angle = rng.uniform(0.2 * rows, 0.8 * rows), (k + rng.uniform(0.2, 0.8)) * np.pi / fibres
        dist = (yy - y0) * np.cos(angle) - (xx - cols / 2) * np.sin(angle)
        image = np.maximum(image, 0.95 * np.exp(-((dist / fibre_px) ** 2)))
        lines |= np.abs(dist) <= 0.5
    image = image + 0.02 * rng.standard_normal((rows, cols))
    return Truth("cells_and_fibres", np.clip(image, 0, 1).astype(np.float32), members=labels, lines=lines)


def stress_fibres(rows: int = 450, cols: int = 600, seed: int = 5, count: int = 14) -> Truth:
    """Issue 32, class 8: a cell's actin stress fibres in one fluorescence channel, unnamed: a dim
    oval cell body on a dark ground with `count` thin bright straight fibres (Gaussian half-width
    2 px, about 0.8 mm across on a 100 mm print) running mostly one way (25 ± 8 degrees), crossing
    at small angles. Lines: the fibres' centre lines."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    image = 0.08 + 0.02 * rng.standard_normal((rows, cols))
    cell = ((yy - rows / 2) / (0.38 * rows)) ** 2 + ((xx - cols / 2) / (0.42 * cols)) ** 2 <= 1
    image = np.where(cell, image + 0.12, image)
    lines = np.zeros((rows, cols), bool)
    for k in range(count):
        y0, angle = 0.2 * rows + k * 0.6 * rows / count + rng.uniform(-5, 5), np.radians(25 + rng.uniform(-8, 8))
        dist = (yy - y0) * np.cos(angle) - (xx - cols / 2) * np.sin(angle)
        image = np.maximum(image, 0.2 + 0.7 * np.exp(-((dist / 2.0) ** 2)) * cell)
        lines |= (np.abs(dist) <= 0.5) & cell
    image = image + 0.02 * rng.standard_normal((rows, cols))
    return Truth("stress_fibres", np.clip(image, 0, 1).astype(np.float32), lines=lines)


def line_diagram(rows: int = 192, cols: int = 256, seed: int = 7) -> Truth:
    """A diagram: black strokes 2 px wide on white (a box, a circle, a connecting line) with
    three short text labels in black beside them."""
    from PIL import Image, ImageDraw, ImageFont

    picture = Image.new("L", (cols, rows), 255)
    draw = ImageDraw.Draw(picture)
    s = cols / 256
    w = max(2, round(2 * s))
    draw.rectangle([20 * s, 30 * s, 100 * s, 110 * s], outline=0, width=w)
    draw.ellipse([150 * s, 40 * s, 230 * s, 120 * s], outline=0, width=w)
    draw.line([100 * s, 70 * s, 150 * s, 80 * s], fill=0, width=w)
    strokes = np.asarray(picture) < 128
    text = Image.new("L", (cols, rows), 255)
    tdraw = ImageDraw.Draw(text)
    font = ImageFont.load_default()
    for x, y, word in ((25, 130, "cell A"), (160, 135, "nucleus"), (105, 50, "link")):
        tdraw.text((x * s, y * s), word, fill=0, font=font)
    text_mask = np.asarray(text) < 128
    image = np.where(strokes | text_mask, 0.0, 1.0).astype(np.float32)
    rng = np.random.default_rng(seed)
    image = image + 0.02 * rng.standard_normal((rows, cols)).astype(np.float32)
    return Truth("line_diagram", np.clip(image, 0, 1).astype(np.float32), lines=strokes, text=text_mask & ~strokes)


def thin_boundary_grains(rows: int = 600, cols: int = 800, seed: int = 8) -> Truth:
    """Grains as an SE image shows a sintered ceramic (README of the Al2O3 fixture), drawn on a
    rows x cols layout and shown twice as large: Voronoi cells about 200 px across at 0.62 ± 2 %
    grey, their boundaries a dark core two pixels wide (0.42) between bright rims two pixels wide
    (0.72), noise 1.5 %. Core and rims balance (the core's deficit is the rims' excess), so on
    the Medium grid (250 px across 100 mm, a boundary under a print pixel wide) resampling and
    blur cancel them."""
    rng = np.random.default_rng(seed)
    seeds = np.stack([rng.uniform(0, rows, 48), rng.uniform(0, cols, 48)], 1)
    yy, xx = _grid(rows, cols)
    best = np.full((rows, cols), np.inf)
    cells = np.zeros((rows, cols), np.int32)
    for k, (sy, sx) in enumerate(seeds):  # nearest seed, one seed at a time (a full distance cube is 180 MB)
        d = (yy - sy) ** 2 + (xx - sx) ** 2
        cells = np.where(d < best, k, cells)
        best = np.minimum(best, d)
    core = np.zeros((rows, cols), bool)
    core[1:] |= cells[1:] != cells[:-1]
    core[:, 1:] |= cells[:, 1:] != cells[:, :-1]
    rims = ndimage.binary_dilation(core) & ~core
    image = 0.62 + 0.02 * rng.uniform(-1, 1, 48)[cells]
    image = np.where(rims, 0.72, np.where(core, 0.42, image))

    def twice(a):
        return np.kron(a, np.ones((2, 2), a.dtype))

    image = twice(image) + 0.015 * rng.standard_normal((2 * rows, 2 * cols))
    return Truth("thin_boundary_grains", np.clip(image, 0, 1).astype(np.float32), lines=twice(core | rims),
                 grains=twice(np.where(core | rims, 0, cells + 1).astype(np.int32)))


def _grey_levels(image: np.ndarray) -> np.ndarray:
    """An 8-bit picture's values (0..1 in steps of 1/255), as a scanner or camera writes them."""
    return (np.round(np.clip(image, 0, 1) * 255) / 255).astype(np.float32)


def sparse_strokes(rows: int = 600, cols: int = 800, ink_pct: float = 1.0, seed: int = 9) -> Truth:
    """A sparse line drawing scanned from paper: a few dark strokes (open curves and straight
    lines, 2 px wide at 800 px across, 0.1 grey) on paper at 0.9 with noise of 2 grey levels
    (0.008), 8-bit. Strokes are added until they cover `ink_pct` % of the picture (0.5 to 2 %):
    under the 2nd percentile, where the stretch used to clip the paper's darkest noise to the
    same black as the ink."""
    from PIL import Image, ImageDraw

    rng = np.random.default_rng(seed)
    s = cols / 800
    w = max(2, round(2 * s))
    picture = Image.new("L", (cols, rows), 0)
    draw = ImageDraw.Draw(picture)
    target = ink_pct / 100 * rows * cols
    margin = 0.08
    while np.count_nonzero(np.asarray(picture)) < target:
        x0, y0 = rng.uniform(margin, 1 - margin) * cols, rng.uniform(margin, 1 - margin) * rows
        if rng.random() < 0.5:  # a straight stroke 15-35 % of the width long
            length, angle = rng.uniform(0.15, 0.35) * cols, rng.uniform(0, np.pi)
            x1 = float(np.clip(x0 + length * np.cos(angle), margin * cols, (1 - margin) * cols))
            y1 = float(np.clip(y0 + length * np.sin(angle), margin * rows, (1 - margin) * rows))
            draw.line([x0, y0, x1, y1], fill=255, width=w)
        else:  # an open arc of a circle 8-20 % of the width across
            r = rng.uniform(0.04, 0.10) * cols
            start = rng.uniform(0, 360)
            draw.arc([x0 - r, y0 - r, x0 + r, y0 + r], start, start + rng.uniform(120, 270), fill=255, width=w)
    strokes = np.asarray(picture) > 0
    image = np.where(strokes, 0.1, 0.9) + 0.008 * rng.standard_normal((rows, cols))
    return Truth(f"sparse_strokes_{ink_pct:g}pct", _grey_levels(image), lines=strokes)


def sparse_beads(rows: int = 600, cols: int = 800, count: int = 5, cover_pct: float = 0.6, seed: int = 10) -> Truth:
    """A sparse fluorescence field: `count` (3 to 6) beads, equal discs together covering
    `cover_pct` % of the picture (0.3 to 1 %), peaks 0.5 to 0.9 on a dark ground at 0.06 with
    noise of 2 grey levels (0.008), blurred by the optics (1 px at 800 px across), 8-bit. Beads
    lie at least four radii apart and away from the border."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    r = float(np.sqrt(cover_pct / 100 * rows * cols / (count * np.pi)))
    centres: list[tuple[float, float]] = []
    while len(centres) < count:
        c = (rng.uniform(3 * r, rows - 3 * r), rng.uniform(3 * r, cols - 3 * r))
        if all((c[0] - a) ** 2 + (c[1] - b) ** 2 >= (4 * r) ** 2 for a, b in centres):
            centres.append(c)
    image = np.zeros((rows, cols), np.float32)
    labels = np.zeros((rows, cols), np.int32)
    for k, ((cy, cx), peak) in enumerate(zip(centres, rng.uniform(0.5, 0.9, count)), start=1):
        disk = (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
        image[disk] = peak
        labels[disk] = k
    image = ndimage.gaussian_filter(image, cols / 800) + 0.06 + 0.008 * rng.standard_normal((rows, cols))
    return Truth(f"sparse_beads_{count}_{cover_pct:g}pct", _grey_levels(image), members=labels)


def bse_blood_cells(rows: int = 450, cols: int = 600, seed: int = 12, mesh: int = 30, overlap: float = 0.8,
                    grey: tuple[float, float] = (0.36, 0.44), strand: float = 0.95, strand_px: float = 1.3,
                    radius: tuple[float, float] = (20, 27), dimple: float = 0.07, rim: float = 0.1) -> Truth:
    """Issue 53, class 1: a backscatter SEM of red blood cells on a filter, no modality recorded.
    Mid-grey biconcave discs (each of one grey in `grey`, a dimple 0.07 darker and a thin darker
    rim where cells meet; radius 20-27 px, 4.4-6 mm on a 100 mm print), centres at least
    `overlap` × the sum of two radii apart, so many touch, on dark gaps (0.08, the filter,
    speckled) that split into concave shards; `mesh` thin fibrin strands brighter than the cells
    (`strand`, Gaussian half-width `strand_px`: about 0.3 mm on the print) over cells and gaps
    alike. BSE shows composition, so the cells are flat grey, not shaded, and the strands take the
    top of the contrast stretch: the most common brightness is the cells' own, mid-grey. Members:
    the discs as drawn (a later disc only where no earlier one lies); lines: the strands' centre
    lines."""
    rng = np.random.default_rng(seed)
    yy, xx = _grid(rows, cols)
    image = 0.08 + 0.03 * rng.standard_normal((rows, cols))
    labels = np.zeros((rows, cols), np.int32)
    centres: list[tuple[float, float, float]] = []
    for _ in range(4000):
        cy, cx, r = rng.uniform(0, rows), rng.uniform(0, cols), rng.uniform(*radius)
        if any((cy - a) ** 2 + (cx - b) ** 2 < (overlap * (r + c)) ** 2 for a, b, c in centres):
            continue
        centres.append((cy, cx, r))
        d = np.sqrt((yy - cy) ** 2 + (xx - cx) ** 2) / r
        inside = (d <= 1) & (labels == 0)
        disc = rng.uniform(*grey) - dimple * np.exp(-((d / 0.4) ** 2)) - rim * (d > 0.94)
        image = np.where(inside, disc, image)
        labels[inside] = len(centres)
    lines = np.zeros((rows, cols), bool)
    for _ in range(mesh):  # fibrin strands: straight pieces between random ends, across cells and gaps
        y0, y1 = rng.uniform(0, rows, 2)
        x0, x1 = rng.uniform(0, cols, 2)
        length = max(float(np.hypot(y1 - y0, x1 - x0)), 1.0)
        t = np.clip(((yy - y0) * (y1 - y0) + (xx - x0) * (x1 - x0)) / length**2, 0, 1)
        dist = np.hypot(yy - (y0 + t * (y1 - y0)), xx - (x0 + t * (x1 - x0)))
        image = np.maximum(image, strand * np.exp(-((dist / strand_px) ** 2)))
        lines |= dist <= 0.5
    image = ndimage.gaussian_filter(image, 0.7) + 0.02 * rng.standard_normal((rows, cols))
    return Truth("bse_blood_cells", np.clip(image, 0, 1).astype(np.float32), members=labels, lines=lines)


def with_data_band(image: np.ndarray, text: str, rows: int = 40) -> np.ndarray:
    """`image` with an SEM data band below it: `rows` black rows holding `text` in white letters
    (DejaVu Sans, two thirds of the band high) and a scale bar, as a Phenom or FEI band. The
    picture above keeps its rows, so a truth made for `image` holds for the cropped picture."""
    from PIL import Image, ImageDraw, ImageFont

    cols = image.shape[1]
    band = Image.new("L", (cols, rows), 0)
    draw = ImageDraw.Draw(band)
    draw.text((8, rows // 6), text, fill=255, font=ImageFont.truetype("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", rows // 2))
    draw.rectangle([cols - 120, rows // 2 - 2, cols - 20, rows // 2 + 2], fill=255)
    return np.concatenate([image, np.asarray(band, np.float32) / 255], axis=0)


def all_content(rows: int = 192, cols: int = 256) -> list[Truth]:
    return [dim_and_bright_beads(rows, cols), dark_line_network(rows, cols), dot_lattice(rows, cols),
            faint_grains(rows, cols), line_diagram(rows, cols)]


def fluorescence_composite(side_px: int = 200) -> np.ndarray:
    """An RGB fluorescence picture on black: blue round nuclei, red lines, green spots (a channel print with a key)."""
    yy, xx = np.mgrid[0:side_px, 0:side_px]
    rgb = np.zeros((side_px, side_px, 3))
    for cy, cx in ((50, 50), (50, 150), (150, 80), (160, 170)):
        rgb[..., 2][(yy - cy) ** 2 + (xx - cx) ** 2 < 20 ** 2] = 1.0
    for k in range(5):
        rgb[..., 0][np.abs(yy - (0.4 * xx + 20 + 40 * k)) < 2.0] = 1.0
    for cy, cx in np.random.default_rng(3).integers(8, side_px - 8, size=(40, 2)):
        rgb[..., 1][(yy - cy) ** 2 + (xx - cx) ** 2 < 2.5 ** 2] = 1.0
    return (rgb * 230).astype(np.uint8)
