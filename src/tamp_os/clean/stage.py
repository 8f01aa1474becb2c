"""The microscopy stage between reading and preprocessing: find the physical scale, crop the data
band, remove burned-in annotations, and fall back to a scale bar's label when the file records
no scale. Used by the pipeline and by `tamp-os info`, so both report the same facts."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .annotations import Annotation, clean
from .scale import Scale, read_scale
from ..read import Picture
from .scalebar import scale_from_bar
from ..units import parse_length_m


@dataclass
class Cleaned:
    values: np.ndarray
    alpha: np.ndarray | None
    scale: Scale
    crop: dict
    annotations: list[Annotation]
    mask: np.ndarray | None


def clean_source(picture: Picture, *, pixel_size: str | None, remove_annotations: bool) -> Cleaned:
    src = picture.source
    override_m = parse_length_m(pixel_size, "pixel_size") if pixel_size else None
    scale = read_scale(src.metadata, src.path, src.width, src.height, override_m)
    values, alpha, crop, found, mask = clean(
        picture.values,
        picture.alpha,
        crop_top=scale.crop_top,
        crop_bottom=scale.crop_bottom,
        crop_source=scale.crop_source,
        remove=remove_annotations,
    )
    if scale.pixel_size_m is None and found:
        raw = picture.values[crop["top_rows"] : picture.values.shape[0] - crop["bottom_rows"]]
        size, where = scale_from_bar(raw, found)
        if size:
            scale.pixel_size_m, scale.source = size, where
        elif any(a.kind == "bar" for a in found):
            scale.warnings.append(where)
    return Cleaned(values, alpha, scale, crop, found, mask)
