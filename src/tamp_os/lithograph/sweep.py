"""Parameter sweeps: the same image with one parameter varied (or several, as a grid), clearly
named outputs, and a labelled contact sheet of the heightmaps (plus renders when available)."""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..export.files import to_uint8, write_png, write_text
from ..params import LithoParams, parse_field

FIELD_NAMES = {f.name for f in dataclasses.fields(LithoParams)}
ALIASES = {"resolution": "resolution_px", "relief": "relief_mm", "base": "base_mm", "blur": "blur_px", "width": "width_mm", "error": "max_error_mm"}
SHORT = {field: short for short, field in ALIASES.items()}
FONT = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"


def parse_vary(specs: list[str]) -> dict[str, list]:
    """['resolution=64,128', 'relief=2,3'] -> {'resolution_px': [64, 128], 'relief_mm': [2.0, 3.0]}."""
    out = {}
    for spec in specs:
        name, _, values = spec.partition("=")
        name = ALIASES.get(name.strip(), name.strip())
        if name not in FIELD_NAMES or not values.strip():
            raise ParameterError(
                f"vary {spec!r}: write NAME=V1,V2,… with NAME a parameter ({', '.join(sorted(ALIASES))} or any field name)."
            )
        out[name] = [parse_field(name, v) for v in values.split(",") if v.strip()]
    if not out:
        raise ParameterError("sweep: give at least one parameter to vary, as NAME=V1,V2,…")
    return out


def _label(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def variants(params: LithoParams, vary: dict[str, list]) -> list[tuple[str, LithoParams]]:
    """(suffix such as 'resolution_px_256', params) for every combination; each is validated."""
    names = list(vary)
    out = []
    for combo in itertools.product(*(vary[n] for n in names)):
        suffix = "_".join(f"{SHORT.get(n, n)}_{_label(v)}" for n, v in zip(names, combo))
        out.append((suffix, params.replace(**dict(zip(names, combo)))))
    return out


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.truetype(FONT, size)
    except OSError:
        return ImageFont.load_default()


def contact_sheet(panels: list[tuple[str, np.ndarray]], panel_px: int = 320):
    """Images side by side (up to 4 per row), each scaled into a square panel with its label under it."""
    from PIL import Image, ImageDraw

    cols = min(4, len(panels))
    rows = -(-len(panels) // cols)
    label_h = 36
    sheet = Image.new("RGB", (cols * panel_px, rows * (panel_px + label_h)), "white")
    draw = ImageDraw.Draw(sheet)
    for i, (label, image) in enumerate(panels):
        if image.dtype != np.uint8:
            image = to_uint8(image)
        tile = Image.fromarray(image)
        tile.thumbnail((panel_px - 10, panel_px - 10))
        x, y = (i % cols) * panel_px, (i // cols) * (panel_px + label_h)
        sheet.paste(tile, (x + (panel_px - tile.width) // 2, y + (panel_px - tile.height) // 2))
        draw.text((x + 8, y + panel_px + 6), label, fill="black", font=_font(18))
    return sheet


def save_png(image, path: Path, alt: str) -> list[Path]:
    written = [write_png(path, image), write_text(path.with_suffix(".alt.txt"), alt + "\n")]
    return written


@dataclass(frozen=True)
class SweepResult:
    conversions: tuple  # convert.Conversion of each variant, in order
    sheets: tuple[Path, ...]  # the contact sheets (PNG), each with its .alt.txt

    @property
    def written(self) -> list[Path]:
        """Every file written: each variant's files, then the sheets and their alt texts."""
        files = [p for c in self.conversions for p in c.all_written]
        return files + [q for sheet in self.sheets for q in (sheet, sheet.with_suffix(".alt.txt"))]


def run_sweep(source, params: LithoParams, vary: dict[str, list], *, out_dir: Path, render: bool = True,
              name: str | None = None) -> SweepResult:
    """Make every variant of an image file, an array or a read Picture, convert each (named
    NAME_VARIANT.ext, sliced when `gcode` is set) and write the contact sheet(s)."""
    from .convert import convert
    from ..read.model import Picture

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if isinstance(source, (str, Path)):
        source = Path(source)
        name, shown = name or source.stem, source.name
    else:
        name = name or (Path(source.file.name).stem if isinstance(source, Picture) else "array")
        shown = name
    panels, render_panels, conversions, sheets = [], [], [], []
    for suffix, p in variants(params, vary):
        conversion = convert(source, p, out_dir, stem=f"{name}_{suffix}")  # a figure: the sheet shows its overview
        conversions.append(conversion)
        label = suffix.replace("_", " ")
        panels.append((label, conversion.litho.heightmap))
        if render:
            from .render import View, render_views

            mesh = conversion.litho.mesh
            full, _ = render_views(mesh.vertices, mesh.faces, View(width_px=480, height_px=360))
            render_panels.append((label, full))
    names = ", ".join(vary)
    sheets.append(save_png(
        contact_sheet(panels), out_dir / f"{name}_sweep_heightmaps.png",
        f"Contact sheet of {len(panels)} heightmaps of {shown}, varying {names}; brighter means higher. "
        f"Panels, left to right and top to bottom: {'; '.join(label for label, _ in panels)}.",
    )[0])
    if render_panels:
        sheets.append(save_png(
            contact_sheet(render_panels), out_dir / f"{name}_sweep_renders.png",
            f"Contact sheet of {len(render_panels)} rendered reliefs of {shown}, varying {names}. "
            f"Panels: {'; '.join(label for label, _ in render_panels)}.",
        )[0])
    return SweepResult(tuple(conversions), tuple(sheets))
