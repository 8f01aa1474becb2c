"""Leica LIF through liffile: one frame at a time (liffile reads a frame without the rest).

Why liffile: it read all three images of the fixture with their coordinates in metres and
seconds, is small (0.3 MB, no compiled code) and reads single frames; readlif refused the XZ
images ("Atypical imaging experiment, use get_plane()") and gives scales only as px per µm.
A LIF frame is its two innermost spatial axes: for an XZ scan those are Z and X, so the image's
rows are depth, not Y; we say so. A spatial axis outside the frame (Y of an XZY stack, or Z of an
XYZ stack) is the stack axis, projected or sliced like Z.

A wavelength sweep (liffile's `λ`, emission, DimID 5; `Λ`, excitation, DimID 9: λYX, ΛYX, TλZYX…)
is read as channels, one per wavelength ("λ 520 nm"; with several detectors "HyD 1 λ 520 nm"), so
`channel` picks one by number or name; by default plan.py reads the emission peak (see there).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .model import Channel, Stack

KIND = "lif"
SPATIAL = "XYZ"
SPECTRAL = {"λ": "emission", "Λ": "excitation"}  # liffile's names of the wavelength axes


def _step_m(coords, axis: str, n: int) -> float | None:
    values = coords.get(axis)
    if values is None or n < 2 or len(values) < 2:
        return None
    step = abs(float(values[-1]) - float(values[0])) / (len(values) - 1)
    return step if step > 0 else None


def open_lif(path, scene: int | None) -> Stack:
    import liffile

    lif = liffile.LifFile(str(path))
    try:
        images, s = _chosen_image(lif, path, scene)
        im = images[s]
        ax = _axes(im)
        coords = {k: np.asarray(v) for k, v in im.coords.items()}
        sizes_all, spectral, stack_axis = ax.sizes_all, ax.spectral, ax.stack_axis
        sizes = {"T": sizes_all.get("T", 1), "C": len(ax.combos), "Z": sizes_all.get(stack_axis, 1) if stack_axis else 1}
        row_axis, col_axis = ax.row_axis, ax.col_axis
        px_x, px_y = _step_m(coords, col_axis, sizes_all[col_axis]), _step_m(coords, row_axis, sizes_all[row_axis])
        notes = _axis_notes(im.name, ax, sizes["Z"])
        channels = _channels(lif, im.name, sizes_all.get("C", 1))
        bands = {a: sizes_all[a] for a in spectral}
        if spectral:
            channels, band_notes = _wavelength_channels(im.name, channels, sizes_all.get("C", 1), ax.combos, spectral, coords)
            notes += band_notes
        t_step = _step_m(coords, "T", sizes["T"])
        dtype = np.dtype(im.dtype)
    except Exception:
        lif.close()
        raise

    def plane(t: int, c: int, z: int) -> np.ndarray:
        index = {}
        if "T" in sizes_all:
            index["T"] = t
        detector, *steps = ax.combos[c]
        if "C" in sizes_all:
            index["C"] = detector
        index.update(zip(spectral, steps))
        if stack_axis:
            index[stack_axis] = z
        return im.frame(**index)

    key = f"image {im.name!r} coordinates of {col_axis} and {row_axis} (Dimensions)"
    return Stack(
        format="Leica LIF", reader=f"liffile {liffile.__version__}", sizes=sizes, dtype=dtype,
        height=sizes_all[row_axis], width=sizes_all[col_axis], plane=plane, scenes=len(images), scene=s,
        scene_name=im.name, channels=channels, pixel_size_m=(px_x, px_y or px_x) if px_x else None,
        pixel_size_key=key if px_x else "", z_step_m=_step_m(coords, stack_axis, sizes["Z"]) if stack_axis else None,
        z_key=f"coordinates of {stack_axis}" if stack_axis else "", time_step_s=t_step,
        samples=sizes_all.get("S", 1), metadata={"lif_images": [i.name for i in images], "lif_axes": "".join(ax.dims),
                  "picture_axes": {"rows": row_axis, "columns": col_axis}},  # an XZ scan: rows along Z
        notes=notes, close=lif.close, scene_names=[i.name for i in images], bands=bands,
        band_key=f"image {im.name!r} coordinates of {', '.join(spectral)} (Dimensions)" if spectral else "",
    )


def _chosen_image(lif, path, scene: int | None) -> tuple[list, int]:
    """The file's images and the index of the one `scene` names; a cut-short file is refused whichever is read."""
    from .plan import check_index

    images = list(lif.images)
    if not images:
        raise ValueError("no images in the file")
    file_bytes = Path(path).stat().st_size
    for each in images:  # a cut-short file loses the images stored last: say so, whichever is read
        block = each.memory_block
        if block is not None and int(block.offset) + int(block.size) > file_bytes:
            raise EOFError(f"image {each.name!r} runs to byte {int(block.offset) + int(block.size):,}, past the end of the file ({file_bytes:,} bytes)")
    return images, check_index(path, "scene", scene, count=len(images), what="image", names=[i.name for i in images])


@dataclass(frozen=True)
class _Axes:
    """How one LIF image's dimensions become a stack: the frame's rows and columns, the axis stacked
    along, and the wavelength axes flattened with C into channels."""

    dims: tuple[str, ...]
    sizes_all: dict[str, int]
    row_axis: str
    col_axis: str
    stack_axis: str | None
    spectral: list[str]
    combos: list[tuple[int, ...]]  # (detector, wavelength steps…) per channel


def _axes(im) -> _Axes:
    dims, shape = tuple(im.dims), tuple(int(n) for n in im.shape)
    sizes_all = dict(zip(dims, shape))
    frame_axes = dims[-3:-1] if dims[-1] == "S" else dims[-2:]
    stack_axes = [a for a in dims if a in SPATIAL and a not in frame_axes]
    spectral = [a for a in dims if a in SPECTRAL and a not in frame_axes]
    others = [a for a in dims if a not in SPATIAL and a not in SPECTRAL and a not in ("C", "T", "S")]
    if len(stack_axes) > 1 or others or any(a in SPECTRAL for a in frame_axes):
        raise NotImplementedError(f"image {im.name!r} has axes {''.join(dims)}")
    # C × each wavelength axis, flattened into channels (detector outermost, as LAS X lists them)
    combos = list(itertools.product(range(sizes_all.get("C", 1)), *(range(sizes_all[a]) for a in spectral)))
    return _Axes(dims, sizes_all, frame_axes[0], frame_axes[1], stack_axes[0] if stack_axes else None, spectral, combos)


def _axis_notes(name: str, ax: _Axes, z_count: int) -> list[str]:
    """What the reader should know of a side view or a stack along another axis than Z."""
    notes = []
    if ax.row_axis != "Y":
        notes.append(f"image {name!r} is an {ax.col_axis}{ax.row_axis} scan: the picture's rows run along {ax.row_axis} "
                     f"(depth), not Y; the print shows a side view.")
    if ax.stack_axis and ax.stack_axis != "Z" and z_count > 1:
        notes.append(f"image {name!r} is stacked along {ax.stack_axis} ({z_count} steps); that axis is used as the z-stack.")
    return notes


def _wavelength_channels(name, detectors, n_detectors, combos, spectral, coords) -> tuple[list[Channel], list[str]]:
    """A Channel per (detector, wavelength…) combination, named by its wavelengths in nm, and a note
    that says the sweep (its range and step) in words."""
    from ...errors import Text

    nm = {}
    for axis in spectral:
        values = coords.get(axis)
        nm[axis] = [round(float(v) * 1e9, 1) for v in values] if values is not None and len(values) else None
    out = []
    for detector, *steps in combos:
        prefix = ""
        if n_detectors > 1:
            prefix = (detectors[detector].name if detector < len(detectors) else f"detector {detector}") + " "
        parts, em, ex = [], None, None
        for axis, k in zip(spectral, steps):
            value = nm[axis][k] if nm[axis] and k < len(nm[axis]) else None
            parts.append(f"{axis} {value:g} nm" if value is not None else f"{axis} step {k}")
            em, ex = (value, ex) if SPECTRAL[axis] == "emission" else (em, value)
        out.append(Channel(prefix + " ".join(parts), ex, em))
    notes = []
    for axis in spectral:
        values = nm[axis]
        if values and len(values) > 1:
            step = (values[-1] - values[0]) / (len(values) - 1)
            notes.append(Text(f"image {name!r} is an {SPECTRAL[axis]} wavelength sweep ({axis}): {len(values)} steps from "
                              f"{values[0]:g} to {values[-1]:g} nm, {step:.3g} nm apart, read as channels named by wavelength."))
        else:
            notes.append(Text(f"image {name!r} sweeps the {SPECTRAL[axis]} wavelength ({axis}); the file gives no wavelengths."))
    return out, notes


def _channels(lif, name: str, count: int) -> list[Channel]:
    """Active detectors of the image, in order, with their dye and emission band (LAS X settings)."""
    try:
        root = lif.xml_element
        element = next(e for e in root.iter("Element") if e.get("Name") == name)
        detectors = [d for d in element.iter("Detector") if d.get("IsActive") == "1"]
        bands = {b.get("Channel"): b for b in element.iter("MultiBand")}
    except (StopIteration, AttributeError):
        return []
    seen, out = set(), []
    for det in detectors:
        if det.get("Channel") in seen:
            continue  # the settings repeat per sequential scan
        seen.add(det.get("Channel"))
        band = bands.get(det.get("Channel"))
        dye = band.get("DyeName", "") if band is not None else ""
        em = None
        if band is not None:
            try:
                em = round((float(band.get("LeftWorld")) + float(band.get("RightWorld"))) / 2, 1)
            except (TypeError, ValueError):
                em = None
        out.append(Channel(f"{det.get('Name')} {dye}".strip(), None, em))
    return out[:count] if len(out) >= count else []
