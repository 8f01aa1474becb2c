"""The Low/Medium/High cards of the settings page, with the facts of each uploaded image."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import TampError
from ..params import LithoParams
from ..lithograph.presets import preset_rows, size_words


@dataclass
class ImageFacts:
    name: str
    cols: int
    rows: int
    width_mm: float
    depth_mm: float
    files: str  # "STL about 1.2 MB, 3MF about 300 kB"


@dataclass
class DetailCard:
    preset: str
    mm_per_px: float
    height_levels: int
    images: list[ImageFacts]


def detail_cards(job, params: LithoParams) -> list[DetailCard]:
    """One card per level of detail; each lists every image's grid, size and file sizes."""
    per_image = [(u.name, _rows(params, u.width, u.height)) for u in job.uploads]
    cards = []
    for i, first in enumerate(per_image[0][1]):
        images = [
            ImageFacts(name, rows[i]["cols"], rows[i]["rows"], rows[i]["width_mm"], rows[i]["depth_mm"],
                       size_words(rows[i]["bytes"], about="about "))
            for name, rows in per_image
        ]
        cards.append(DetailCard(first["preset"], first["mm_per_px"], first["height_levels"], images))
    return cards


def _rows(params: LithoParams, width_px: int, height_px: int) -> list[dict]:
    try:
        return preset_rows(params, width_px, height_px)
    except TampError:  # settings that cannot be laid out: show the printer's plain defaults
        return preset_rows(LithoParams(printer=params.printer), width_px, height_px)
