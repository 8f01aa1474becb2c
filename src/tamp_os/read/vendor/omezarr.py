"""OME-Zarr (NGFF 0.4 and 0.5) from a local folder, through zarr: chunks are read on demand.

Axes and their units come from `multiscales[0].axes`, pixel sizes from the chosen level's
`coordinateTransformations` scale, channel names from `omero.channels[].label`. Of a pyramid, the
smallest level at least `target_px` wide is read (never a larger one than the print can use),
and the pixel size is that level's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...units import unit_factor_m
from .model import Channel, Stack

KIND = "omezarr"


def is_ome_zarr(path: Path) -> bool:
    return path.is_dir() and any((path / name).is_file() for name in (".zattrs", "zarr.json", ".zgroup"))


def _multiscales(attrs: dict) -> list:
    return attrs.get("multiscales") or (attrs.get("ome") or {}).get("multiscales") or []


def open_omezarr(path, scene: int | None, target_px: int = 2048, *, limits=None) -> Stack:
    import zarr

    from .bounds import check_array_paths, check_folder
    from .plan import check_index

    check_folder(path, KIND)  # before zarr reads a byte: no symlink may lead out of the folder
    group = zarr.open_group(str(path), mode="r")
    attrs = dict(group.attrs)
    multiscales = _multiscales(attrs)
    if not multiscales:
        raise ValueError("no 'multiscales' in the folder's attributes")
    check_index(path, "scene", scene, count=1, what="image")
    ms = multiscales[0]
    axes = [a["name"].upper() if isinstance(a, dict) else str(a).upper() for a in ms.get("axes", [])]
    units = [a.get("unit", "") if isinstance(a, dict) else "" for a in ms.get("axes", [])]
    datasets = ms["datasets"]
    check_array_paths(path, KIND, [d["path"] for d in datasets])
    arrays = [group[d["path"]] for d in datasets]
    if not axes:
        axes = list("TCZYX"[-arrays[0].ndim:])
    if "Y" not in axes or "X" not in axes or len(axes) != arrays[0].ndim:
        raise ValueError(f"axes {axes} do not fit the array's {arrays[0].ndim} dimensions")
    xi, yi = axes.index("X"), axes.index("Y")
    wide = [i for i, a in enumerate(arrays) if a.shape[xi] >= target_px]
    level = min(wide, key=lambda i: arrays[i].shape[xi]) if wide else 0
    array = arrays[level]
    if limits is not None:  # the level read is decoded chunk by chunk, each chunk whole
        _check_chunks(path, array, datasets[level]["path"], limits)
    scale = _scale(ms, datasets[level], len(axes))
    fx, fy = unit_factor_m(units[xi] or ""), unit_factor_m(units[yi] or "")
    pixel = (scale[xi] * fx, scale[yi] * (fy or fx)) if fx and scale[xi] > 0 else None
    zi = axes.index("Z") if "Z" in axes else None
    fz = unit_factor_m(units[zi]) if zi is not None and units[zi] else None
    sizes = {a: int(array.shape[axes.index(a)]) for a in "TCZ" if a in axes}
    labels = [c.get("label", f"channel {i}") for i, c in enumerate((attrs.get("omero") or {}).get("channels", []))]
    channels = [Channel(str(name)) for name in labels][: sizes.get("C", 1)]
    notes = [f"OME-Zarr pyramid: read level {level} ({array.shape[xi]} px wide) of {len(arrays)}; level 0 is {arrays[0].shape[xi]} px wide."] if level else []

    def plane(t: int, c: int, z: int) -> np.ndarray:
        where = {"T": t, "C": c, "Z": z}
        index = tuple(where.get(a, slice(None)) if a not in ("X", "Y") else slice(None) for a in axes)
        return np.asarray(array[index])

    return Stack(
        format="OME-Zarr", reader=f"zarr {zarr.__version__}", sizes=sizes, dtype=np.dtype(array.dtype),
        height=int(array.shape[yi]), width=int(array.shape[xi]), plane=plane, channels=channels,
        pixel_size_m=pixel, pixel_size_key=f"multiscales[0].datasets[{level}] scale × axes unit ({units[xi]})" if pixel else "",
        z_step_m=scale[zi] * fz if fz and zi is not None and sizes.get("Z", 1) > 1 else None,
        z_key=f"multiscales[0].datasets[{level}] scale (z)", metadata={"ome_zarr_axes": "".join(axes), "ome_zarr_level": level}, notes=notes,
    )


def _check_chunks(path, array, name: str, limits) -> None:
    """Refuse the array's chunks, from its metadata: one far larger than the array, or chunks that
    cost more than the cap to decode (numcodecs holds three copies of each: ZARR_CHUNK_COPIES)."""
    from ..cost import ZARR_CHUNK_COPIES, check_chunk, check_chunk_fits, chunk_bytes
    from .errors import KINDS

    what, todo = KINDS[KIND]
    chunks, itemsize = tuple(array.chunks), np.dtype(array.dtype).itemsize
    label = f"{what} whose array {name!r}"
    check_chunk_fits(path, label, array.shape, chunks=chunks, itemsize=itemsize, todo=todo, whole="folder")
    check_chunk(path, label, array.shape, chunks=chunks, itemsize=itemsize, max_decoded_gb=limits.max_decoded_gb, todo=todo,
                whole="folder", n_bytes=chunk_bytes(array.shape, chunks, itemsize, copies=ZARR_CHUNK_COPIES))


def _scale(ms: dict, dataset: dict, n: int) -> list[float]:
    """The level's scale, times the multiscale's own scale where NGFF puts one."""
    out = [1.0] * n
    for transforms in (dataset.get("coordinateTransformations", []), ms.get("coordinateTransformations", [])):
        for t in transforms:
            if t.get("type") == "scale" and len(t.get("scale", [])) == n:
                out = [a * float(b) for a, b in zip(out, t["scale"])]
    return out
