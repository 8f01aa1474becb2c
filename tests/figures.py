"""Multi-panel figures composed for the panel tests and benchmark, with their true layout.

Panels are real micrographs from the shared fixtures (when present) or synthetic pictures, laid
out as journals do: gutters of pure white or black, letters in label boxes or in the gutter.
Each maker returns a `Figure`: the picture (uint8, row 0 = top) and the true boxes and letters.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont
from scipy import ndimage

FONT = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf"
FIXTURES = Path(__file__).resolve().parents[1].parent / "shared" / "fixtures"


@dataclass(frozen=True)
class Figure:
    name: str
    image: np.ndarray  # (rows, cols) uint8, or (rows, cols, 3) for a colour figure
    boxes: list[tuple[int, int, int, int]]  # x, y, w, h of each panel, in reading order
    letters: list[str | None]  # the letter printed on each panel (None: no letter)


def font(size: int):
    return ImageFont.truetype(FONT, size)


def micrograph(name: str, rows: int, cols: int) -> np.ndarray:
    """A real micrograph from the fixtures, its picture area (no data band) resized to rows × cols, uint8."""
    from tamp_os.clean.stage import clean_picture
    from tamp_os.read.image import read_image

    picture = read_image(FIXTURES / name)
    cleaned = clean_picture(picture, pixel_size_m=None, remove_annotations=False)
    return _resize(cleaned.values, rows, cols)


def _resize(values: np.ndarray, rows: int, cols: int) -> np.ndarray:
    lo, hi = np.percentile(values, [1, 99])
    scaled = np.clip((values - lo) / max(hi - lo, 1e-9), 0, 1)
    image = Image.fromarray((scaled * 255).astype(np.uint8)).resize((cols, rows), Image.Resampling.BILINEAR)
    return np.asarray(image)


def synthetic_texture(rows: int, cols: int, seed: int) -> np.ndarray:
    """Blobs on a noisy grey ground, uint8 (a stand-in micrograph)."""
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.standard_normal((rows, cols)), max(2, rows / 20))
    field = (field - field.min()) / (np.ptp(field) + 1e-9)
    noise = rng.normal(0, 0.05, (rows, cols))
    return (np.clip(0.15 + 0.7 * field + noise, 0, 1) * 255).astype(np.uint8)


def dark_fluorescence(rows: int, cols: int, seed: int) -> np.ndarray:
    """A dark fluorescence panel: black background, a few dim spots, uint8 (most columns pure black)."""
    rng = np.random.default_rng(seed)
    image = np.zeros((rows, cols), np.float32)
    yy, xx = np.mgrid[0:rows, 0:cols]
    for _ in range(5):
        cy, cx = rng.uniform(0.2, 0.8) * rows, rng.uniform(0.2, 0.8) * cols
        image += 0.5 * np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * (rows / 25) ** 2))
    return (np.clip(image, 0, 1) * 255).astype(np.uint8)


def fluorescence_composite(rows: int, cols: int, seed: int = 0) -> np.ndarray:
    """An RGB fluorescence composite, uint8 (rows, cols, 3): on a black ground, red filaments (long
    thin lines), green spots and blue round nuclei, with a little noise (as test_channels makes)."""
    yy, xx = np.mgrid[0:rows, 0:cols]
    s = min(rows, cols) / 300
    nuclei = np.zeros((rows, cols))
    for cy, cx in [(0.2, 0.2), (0.2, 0.67), (0.67, 0.33), (0.73, 0.8)]:
        nuclei[(yy - cy * rows) ** 2 + (xx - cx * cols) ** 2 < (25 * s) ** 2] = 1.0
    fil = np.zeros((rows, cols))
    for k in range(6):
        fil[np.abs(yy - (0.4 * xx + (30 + 45 * k) * s)) < 2.0 * s] = 1.0
    rng = np.random.default_rng(seed + 3)
    spots = np.zeros((rows, cols))
    for cy, cx in zip(rng.integers(10, rows - 10, 60), rng.integers(10, cols - 10, 60)):
        spots[(yy - cy) ** 2 + (xx - cx) ** 2 < (2.5 * s) ** 2] = 1.0
    noise = np.random.default_rng(seed).normal(0, 8, (rows, cols, 3))
    return np.clip(np.stack([fil, spots, nuclei], axis=-1) * 180 + noise, 0, 255).astype(np.uint8)


def stained_section(rows: int, cols: int) -> np.ndarray:
    """A crop of the H&E skin slide fixture (aperio_cmu1_he_skin.svs, 600 × 800 px at full
    resolution: epidermis, dermis and white glass), resized to rows × cols, uint8 RGB."""
    from tamp_os.read.channels import read_channels

    planes = read_channels(FIXTURES / "real" / "aperio_cmu1_he_skin.svs")
    crop = np.stack([p.values[1150:1750, 980:1780] for p in planes[:3]], axis=-1).astype(np.uint8)
    return np.asarray(Image.fromarray(crop).resize((cols, rows), Image.Resampling.BOX))


def _letter_in_box(canvas: Image.Image, x: int, y: int, letter: str, size: int) -> None:
    """A black letter in a white box at the panel's top-left corner."""
    draw = ImageDraw.Draw(canvas)
    pad = size // 4
    draw.rectangle([x, y, x + size + pad, y + size + 2 * pad], fill=255)
    draw.text((x + pad, y + pad // 2), letter, fill=0, font=font(size))


def grid_white_boxes(panels: list[np.ndarray], cols: int, gutter: int = 24, letters="abcd", size: int = 36) -> Figure:
    """Equal panels in a grid on white, lower-case letters in white boxes at each top-left."""
    ph, pw = panels[0].shape
    rows = (len(panels) + cols - 1) // cols
    H, W = rows * ph + (rows + 1) * gutter, cols * pw + (cols + 1) * gutter
    canvas = Image.new("L", (W, H), 255)
    boxes = []
    for i, panel in enumerate(panels):
        r, c = divmod(i, cols)
        x, y = gutter + c * (pw + gutter), gutter + r * (ph + gutter)
        canvas.paste(Image.fromarray(panel), (x, y))
        if letters:
            _letter_in_box(canvas, x, y, letters[i], size)
        boxes.append((x, y, pw, ph))
    return Figure("grid_white", np.asarray(canvas), boxes, list(letters) if letters else [None] * len(panels))


def grid_colour(panels: list[np.ndarray], cols: int, gutter: int = 24, letters="abcd", size: int = 36) -> Figure:
    """Equal panels, colour (rows, cols, 3) or grey (rows, cols), uint8, in a grid on white, lower-case
    letters in white boxes at each top-left; the picture is RGB (rows, cols, 3)."""
    ph, pw = panels[0].shape[:2]
    rows = (len(panels) + cols - 1) // cols
    H, W = rows * ph + (rows + 1) * gutter, cols * pw + (cols + 1) * gutter
    canvas = Image.new("RGB", (W, H), (255, 255, 255))
    boxes = []
    for i, panel in enumerate(panels):
        r, c = divmod(i, cols)
        x, y = gutter + c * (pw + gutter), gutter + r * (ph + gutter)
        canvas.paste(Image.fromarray(panel).convert("RGB"), (x, y))
        draw, pad = ImageDraw.Draw(canvas), size // 4
        draw.rectangle([x, y, x + size + pad, y + size + 2 * pad], fill=(255, 255, 255))
        draw.text((x + pad, y + pad // 2), letters[i], fill=(0, 0, 0), font=font(size))
        boxes.append((x, y, pw, ph))
    return Figure("grid_colour", np.asarray(canvas), boxes, list(letters[:len(panels)]))


def row_on_black(panels: list[np.ndarray], gutter: int = 20, top: int = 60, letters="ABC", size: int = 40) -> Figure:
    """Panels in one row on black, upper-case white letters in the black margin above each."""
    ph, pw = panels[0].shape
    H, W = ph + top + gutter, len(panels) * pw + (len(panels) + 1) * gutter
    canvas = Image.new("L", (W, H), 0)
    draw = ImageDraw.Draw(canvas)
    boxes = []
    for i, panel in enumerate(panels):
        x, y = gutter + i * (pw + gutter), top
        canvas.paste(Image.fromarray(panel), (x, y))
        draw.text((x, (top - size) // 2 - 4), letters[i], fill=255, font=font(size))
        boxes.append((x, y, pw, ph))
    return Figure("row_black", np.asarray(canvas), boxes, list(letters))


def unequal(big: np.ndarray, small: list[np.ndarray], gutter: int = 30, letters="abc", size: int = 36) -> Figure:
    """A tall panel on the left, two smaller stacked on the right, on white."""
    bh, bw = big.shape
    sh, sw = small[0].shape
    H = max(bh, 2 * sh + gutter) + 2 * gutter
    W = bw + sw + 3 * gutter
    canvas = Image.new("L", (W, H), 255)
    boxes = [(gutter, gutter, bw, bh)]
    canvas.paste(Image.fromarray(big), (gutter, gutter))
    for i, panel in enumerate(small):
        x, y = 2 * gutter + bw, gutter + i * (sh + gutter)
        canvas.paste(Image.fromarray(panel), (x, y))
        boxes.append((x, y, sw, sh))
    for (x, y, _, _), letter in zip(boxes, letters):
        _letter_in_box(canvas, x, y, letter, size)
    return Figure("unequal", np.asarray(canvas), boxes, list(letters))


def with_title(panels: list[np.ndarray], title: str = "Figure 3. Grain growth after annealing", gutter: int = 24) -> Figure:
    """A title strip of text over panels in one row, letters (a), (b)… in white boxes."""
    ph, pw = panels[0].shape
    title_h = 70
    H, W = title_h + ph + 2 * gutter, len(panels) * pw + (len(panels) + 1) * gutter
    canvas = Image.new("L", (W, H), 255)
    ImageDraw.Draw(canvas).text((gutter, 18), title, fill=0, font=font(34))
    boxes, letters = [], []
    for i, panel in enumerate(panels):
        x, y = gutter + i * (pw + gutter), title_h + gutter
        canvas.paste(Image.fromarray(panel), (x, y))
        letter = "abcd"[i]
        draw = ImageDraw.Draw(canvas)
        draw.rectangle([x, y, x + 72, y + 50], fill=255)
        draw.text((x + 6, y + 4), f"({letter})", fill=0, font=font(34))
        boxes.append((x, y, pw, ph))
        letters.append(letter)
    return Figure("title", np.asarray(canvas), boxes, letters)


def save(figure: Figure, folder: Path) -> Path:
    path = folder / f"{figure.name}.png"
    Image.fromarray(figure.image).save(path)
    return path


def box_error(found, truth) -> float:
    """Largest difference of any box coordinate, as a share of the true panel's own size."""
    fx, fy, fw, fh = found
    tx, ty, tw, th = truth
    return max(abs(fx - tx) / tw, abs(fx + fw - tx - tw) / tw, abs(fy - ty) / th, abs(fy + fh - ty - th) / th)
