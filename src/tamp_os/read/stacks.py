"""Large TIFF stacks, pyramids and page-level vendor tags: what read.py's TIFF reader needs beyond
one series read whole.

- a series larger than STREAM_BYTES, stored one plane per page, is reduced page by page (a
  running maximum over Z), never decoded whole;
- of a pyramid (SVS, OME-TIFF with sub-resolutions), the smallest level at least target_px wide;
- the z step of ImageJ and OME stacks; Olympus SIS tags from the data page behind a preview.
"""

from __future__ import annotations

import numpy as np

from ..errors import Decision, ParameterError


def sis_of_page(tif, index: int) -> dict | None:
    """Olympus SIS blocks (tags 33471 and 33560) of one page, as tifffile parses them."""
    try:
        tags = tif.pages[index].tags
        result = {}
        ini = tags.valueof(33471)
        if isinstance(ini, dict):
            result.update(ini)
        sis = tags.valueof(33560)
        if isinstance(sis, dict):
            result.update(sis)
        return result or None
    except Exception:  # a broken vendor block must not stop the image from loading
        return None


def pyramid_level(source, target_px: int) -> tuple[list[str], dict]:
    """Of a pyramidal series (SVS, OME-TIFF pyramid), switch `source` to the smallest level at least
    `target_px` wide, so a whole slide's full resolution is never decoded for a print."""
    levels = getattr(source.chosen, "levels", None) or []
    if len(levels) < 2:
        return [], {}
    xi = source.chosen.axes.index("X")
    widths = [int(lv.shape[lv.axes.index("X")]) for lv in levels]
    wide = [i for i, w in enumerate(widths) if w >= target_px]
    index = min(wide, key=lambda i: widths[i]) if wide else 0
    if index == 0:
        return [], {}
    full = int(source.chosen.shape[xi])
    source.chosen = levels[index]
    note = (f"pyramidal TIFF: read level {index} ({widths[index]} px wide, {full / widths[index]:.3g}× smaller than the "
            f"full {full} px), enough for the print.")
    return [note], {"pyramid_level": index, "pyramid_downsample": full / widths[index]}


def tiff_z_step_m(meta) -> float | None:
    """The z step of an ImageJ (spacing + unit) or OME (PhysicalSizeZ) stack, in metres."""
    import re

    from ..units import unit_factor_m

    ij = meta.get("imagej_metadata") or {}
    if "spacing" in ij:
        factor = unit_factor_m(str(ij.get("unit", "")).replace("\\u00B5", "µ"))
        try:
            return float(ij["spacing"]) * factor if factor else None
        except (TypeError, ValueError):
            return None
    match = re.search(r'PhysicalSizeZ="([^"]+)"', meta.get("ome_metadata") or "")
    if match:
        unit = re.search(r'PhysicalSizeZUnit="([^"]+)"', meta["ome_metadata"])
        factor = unit_factor_m(unit.group(1) if unit else "µm")
        try:
            return float(match.group(1)) * factor if factor else None
        except ValueError:
            return None
    return None


STREAM_BYTES = 64e6  # series larger than this are reduced page by page, never decoded whole


def reduce_by_pages(path, series, axes, *, shape, page, z_slice, channel, meta):
    """Like _reduce_axes, but decoding one page at a time (a running maximum over Z), for a series
    stored one plane per page with its other axes first; None when it is small or not laid out so."""
    from .model import channel_choice, Plane

    if int(np.prod([int(n) for n in shape])) * np.dtype(series.dtype).itemsize <= STREAM_BYTES:
        return None
    lead = [(a, int(n)) for a, n in zip(axes, shape) if a not in "YXS"]
    names, dims = [a for a, _ in lead], [n for _, n in lead]
    pages = list(getattr(series, "pages", []) or [])
    count = int(np.prod(dims)) if dims else 1
    if count < 2 or len(pages) != count or any(p is None for p in pages) or "".join(names) != axes[: len(names)]:
        return None
    notes: list[str] = []
    fixed = {}
    if "C" in names:
        fixed["C"] = channel_choice(path, dims[names.index("C")], channel, meta=meta, notes=notes)
    zs = [0]
    if "Z" in names:
        nz = dims[names.index("Z")]
        if z_slice is None:
            zs = list(range(nz))
            if nz > 1:
                notes.append(Decision(f"z-stack of {nz} slices: maximum-intensity projection⟦ (choose one slice with `z_slice`)⟧."))
        elif not 0 <= z_slice < nz:
            raise ParameterError(f"{path}: `z_slice` must be 0–{nz - 1} (slices in this stack); got {z_slice}.")
        else:
            zs = [z_slice]
    others = [a for a in names if a not in "CZ"]
    planes = int(np.prod([dims[names.index(a)] for a in others])) if others else 1
    page = page or 0
    if not others and page:
        raise ParameterError(f"{path}: page {page} asked for, but the file has a single image plane.")
    if page >= planes:
        raise ParameterError(f"{path}: `page` must be 0–{planes - 1} (planes in this file); got {page}.")
    fixed.update(zip(others, np.unravel_index(page, [dims[names.index(a)] for a in others]) if others else []))
    out = None
    for z in zs:
        where = {**fixed, "Z": z}
        flat = int(np.ravel_multi_index([int(where.get(a, 0)) for a in names], dims))
        plane = pages[flat].asarray()
        out = plane if out is None else np.maximum(out, plane, out=out)
    rest = axes[len(names):]
    if "S" in rest and rest.index("S") < rest.index("Y"):
        out = np.moveaxis(out, 0, -1)
    return Plane(out, planes, notes, "C" in names)
