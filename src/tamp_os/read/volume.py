"""A whole z-stack (Z, Y, X) for a 3-D model, read one plane at a time and reduced as it is read.

The 2-D readers reduce Z to one plane (a projection or a slice); here every slice of one channel
and time point is kept. Planes are decoded one at a time (TIFF pages, or a vendor reader's lazy
`Stack.plane`) and block-averaged by whole factors (`factors`, z y x) as they arrive, so a large
stack never sits in memory at full resolution: the peak is one source plane plus the reduced volume.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Decision, InputError, MissingDependencyError, ParameterError, Text
from .model import Limits, channel_choice


@dataclass
class StackShape:
    """The stack's size before reading: planes, rows, columns, and how to read a plane."""

    nz: int
    ny: int
    nx: int
    dtype: np.dtype
    format: str
    plane: object  # z -> (Y, X) array
    close: object = lambda: None
    notes: list[str] = field(default_factory=list)
    reader: str = ""


@dataclass
class VolumeArray:
    """The stack as read: (Z, Y, X) float32, averaged over blocks of `factors` source voxels."""

    values: np.ndarray
    source_shape: tuple[int, int, int]
    factors: tuple[int, int, int]
    format: str
    notes: list[str] = field(default_factory=list)
    reader: str = ""


def open_stack_shape(path, *, channel: str = "luminance", time: int | None = None, scene=None, limits: Limits) -> StackShape:
    """The stack in `path` (any reader: TIFF, or a vendor format), opened without decoding its planes."""
    from .image import vendor_kind

    path = Path(path)
    kind = vendor_kind(path)
    if kind:
        return _vendor_stack(path, kind, channel, time, scene, limits)
    return _tiff_stack(path, channel, time, scene)


def _tiff_stack(path: Path, channel, time, scene) -> StackShape:
    import tifffile

    try:
        tif = tifffile.TiffFile(path)
    except Exception as exc:
        raise InputError(f"{path}: a 3-D model is made from a z-stack (TIFF, OME-TIFF, ImageJ, CZI, LIF, ND2, MRC, OME-Zarr); "
                         f"this file cannot be read as one ({exc}).") from None
    try:
        series = tif.series[int(scene or 0)] if tif.series else None
        if series is None:
            raise InputError(f"{path}: a TIFF without any image in it.")
        axes, shape = series.axes, tuple(int(n) for n in series.shape)
        if "S" in axes:
            raise InputError(f"{path}: a colour (RGB) TIFF; a 3-D model needs a grey z-stack. Split the channels first.")
        if "Z" not in axes and "I" in axes:
            axes = axes.replace("I", "Z")  # ImageJ hyperstacks without a z label: the pages are the slices
        sizes = dict(zip(axes, shape))
        notes: list[str] = []
        meta = {"imagej_metadata": tif.imagej_metadata or {}, "ome_metadata": tif.ome_metadata or ""}
        c = channel_choice(path, sizes.get("C", 1), channel, meta=meta, notes=notes) if "C" in sizes else 0
        t = int(time or 0)
        if t >= sizes.get("T", 1):
            raise ParameterError(f"{path}: `time` must be 0–{sizes.get('T', 1) - 1} (time points in this file); got {t}.",
                                 parameter="time", value=t)
        if sizes.get("T", 1) > 1 and time is None:
            notes.append(Decision(f"time series of {sizes['T']} time points: using the first⟦ (choose another with `time`)⟧."))
        nz = sizes.get("Z", 1)
        lead = [a for a in axes if a not in "YX"]
        pages = list(series.pages)
        paged = len(pages) == int(np.prod([sizes[a] for a in lead])) and "".join(lead) == axes[: len(lead)]
        where = {"C": c, "T": t}
        cache = {}

        def plane(z: int) -> np.ndarray:
            index = {**where, "Z": z}
            if paged and pages and all(p is not None for p in pages):
                flat = int(np.ravel_multi_index([index.get(a, 0) for a in lead], [sizes[a] for a in lead])) if lead else 0
                return pages[flat].asarray()
            if "whole" not in cache:
                cache["whole"] = series.asarray()
            whole = cache["whole"]
            return whole[tuple(index.get(a, 0) if a in lead else slice(None) for a in axes)]

        return StackShape(nz, sizes["Y"], sizes["X"], np.dtype(series.dtype), "TIFF", plane, tif.close, notes,
                          f"tifffile {tifffile.__version__}")
    except Exception:
        tif.close()
        raise


def _vendor_stack(path: Path, kind: str, channel, time, scene, limits) -> StackShape:
    from .vendor import open_stack
    from .vendor.errors import damaged, missing
    from .vendor.plan import channel_index, check_index
    from .vendor import PACKAGES

    try:
        stack = open_stack(path, kind, scene, limits=limits)
    except (InputError, ParameterError, MissingDependencyError):
        raise
    except ImportError as exc:
        raise missing(path, kind, PACKAGES.get(kind, str(exc.name))) from None
    except Exception as exc:
        raise damaged(path, kind, exc) from None
    try:
        t = check_index(path, "time", time, count=stack.size("T"), what="time point")
        c = channel_index(path, stack, channel) or 0
        if stack.samples > 1:
            raise InputError(f"{path}: the planes are colour (RGB); a 3-D model needs a grey z-stack.")
        notes = list(stack.notes)
        if stack.size("C") > 1 and channel == "luminance":
            notes.append(Text(f"{stack.size('C')} channels; the model shows channel 0 (choose another with `channel`)."))
    except Exception:
        stack.close()
        raise

    def plane(z: int) -> np.ndarray:
        return np.asarray(stack.plane(t, c, z))

    return StackShape(stack.size("Z"), stack.height, stack.width, np.dtype(stack.dtype), stack.format, plane, stack.close, notes,
                      stack.reader)


def read_volume(shape: StackShape, factors: tuple[int, int, int], path="stack") -> VolumeArray:
    """Every plane of `shape`, block-averaged by `factors` (z, y, x) as it is read; NaN counts as the minimum."""
    fz, fy, fx = (max(1, int(f)) for f in factors)
    nz, ny, nx = -(-shape.nz // fz), -(-shape.ny // fy), -(-shape.nx // fx)
    out = np.zeros((nz, ny, nx), dtype=np.float32)
    counts = np.zeros(nz, dtype=np.float32)
    try:
        for z in range(shape.nz):
            plane = np.asarray(shape.plane(z), dtype=np.float32)
            if plane.shape != (shape.ny, shape.nx):
                raise InputError(f"{path}: slice {z} is {plane.shape[1]}×{plane.shape[0]} pixels, the others "
                                 f"{shape.nx}×{shape.ny}; a z-stack's slices must all have one size.")
            if not np.isfinite(plane).all():
                finite = plane[np.isfinite(plane)]
                plane = np.where(np.isfinite(plane), plane, finite.min() if finite.size else 0.0).astype(np.float32)
            out[z // fz] += _block_mean(plane, fy, fx)
            counts[z // fz] += 1
    except MemoryError:
        raise InputError(f"{path}: not enough memory to read this stack; lower `max_memory_gb` to have it read coarser.") from None
    finally:
        shape.close()
    out /= counts[:, None, None]
    return VolumeArray(out, (shape.nz, shape.ny, shape.nx), (fz, fy, fx), shape.format, list(shape.notes), shape.reader)


def _block_mean(plane: np.ndarray, fy: int, fx: int) -> np.ndarray:
    if fy == 1 and fx == 1:
        return plane
    h, w = plane.shape
    hh, ww = -(-h // fy) * fy, -(-w // fx) * fx
    padded = np.pad(plane, ((0, hh - h), (0, ww - w)), mode="edge")
    return padded.reshape(hh // fy, fy, ww // fx, fx).mean(axis=(1, 3))
