"""From napari layers to what `convert()` reads: the file a layer came from (read again by our
readers, with its own metadata), or the layer's pixels with its scale; several layers of one
picture are its channels. No Qt and no napari import here: a layer is read by its attributes.

A layer keeps its file when it shows the file as read (napari's `source.path`, or our reader's
mark in `metadata["tamp_os"]`) with the scale the file gives: then the print is the one
`tamp-os convert FILE` makes, byte for byte. A layer with a scale of its own (units set in
napari) gives its pixel size; several layers not from one file are saved as one OME-TIFF beside
the print (NAME.layers.ome.tif), so the recipe can make the print again.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

READER_MARK = "tamp_os"  # layer.metadata key our reader sets: {"path", "channel", "channels", "pixel_size_m"}
METRES_PER_UNIT = {"meter": 1.0, "millimeter": 1e-3, "micrometer": 1e-6, "nanometer": 1e-9, "picometer": 1e-12,
                   "angstrom": 1e-10}
MIN_SIDE_PX = 2  # the pipeline's smallest picture (read.model.check_size)


@dataclass(frozen=True)
class LayerPicture:
    """What the widget reads from one napari layer."""

    name: str
    kind: str  # "image" or "labels"
    data: np.ndarray = field(repr=False)
    scale: tuple[float, ...] = (1.0, 1.0)
    units: tuple[str, ...] = ("pixel", "pixel")
    path: str | None = None  # the file napari or our reader opened it from
    mark: dict | None = None  # our reader's metadata["tamp_os"]
    rgb: bool = False


@dataclass(frozen=True)
class PrintSource:
    """What convert() reads, and how the widget says where it came from."""

    source: object  # a path, or an array
    stem: str | None  # names the files (None: after the file, as the command line names them)
    pixel_size_m: float | None = None  # from the layer's scale; None: the file's own
    channel: str | None = None  # one channel of a multi-channel file
    said: tuple[str, ...] = ()  # sentences for the description panel: where the picture and its scale came from


def layer_picture(layer) -> LayerPicture:
    """A napari Image or Labels layer as a LayerPicture (attributes only; no napari import)."""
    kind = type(layer).__name__.lower()
    source = getattr(layer, "source", None)
    path = getattr(source, "path", None)
    mark = (getattr(layer, "metadata", None) or {}).get(READER_MARK)
    units = tuple(str(u) for u in getattr(layer, "units", ()) or ("pixel",) * layer.ndim)
    return LayerPicture(str(layer.name), kind, np.asarray(layer.data), tuple(float(s) for s in layer.scale), units,
                        str(path) if path else None, dict(mark) if isinstance(mark, dict) else None, bool(getattr(layer, "rgb", False)))


def pixel_size_m(picture: LayerPicture) -> float | None:
    """The layer's pixel size in metres from its scale and units (the column step), or None when
    its units are pixels (napari's default: no physical scale)."""
    unit = picture.units[-1] if picture.units else "pixel"
    per_unit = METRES_PER_UNIT.get(unit)
    return picture.scale[-1] * per_unit if per_unit else None


def check_layer(picture: LayerPicture) -> None:
    """One clear message for a layer no print can be made of, naming the “Layers” control."""
    if picture.kind not in ("image", "labels"):
        raise InputError(f"“Layers”: “{picture.name}” is a {picture.kind} layer; choose an image or labels layer.")
    plane = plane_of(picture)
    h, w = plane.shape[:2]
    if min(h, w) < MIN_SIDE_PX:
        raise InputError(f"“Layers”: the {picture.kind} layer “{picture.name}” is {w} × {h} pixels; a print needs at least "
                         f"{MIN_SIDE_PX} × {MIN_SIDE_PX}. Choose a larger layer.")
    if picture.kind == "labels" and not np.any(plane):
        raise InputError(f"“Layers”: the labels layer “{picture.name}” has no objects (every pixel is 0, the background). "
                         "Paint or load labels first, or choose an image layer.")


def plane_of(picture: LayerPicture) -> np.ndarray:
    """The layer's picture as one plane: (H, W), or (H, W, 3|4) for RGB; the maximum over leading
    axes (z, time) as the command line projects a z-stack; a labels layer as its objects."""
    data = np.asarray(picture.data)
    keep = 3 if picture.rgb else 2
    if data.ndim > keep:
        data = data.reshape((-1, *data.shape[-keep:])).max(axis=0)
    return objects_of(data) if picture.kind == "labels" else data


def objects_of(labels: np.ndarray) -> np.ndarray:
    """A labels image as raised objects: 1 inside each object, 0 on the background and on a one-pixel
    seam where two objects touch (so neighbours stay apart on the print)."""
    from scipy import ndimage

    labels = np.asarray(labels)
    touching = (labels > 0) & (ndimage.maximum_filter(labels, size=3) > labels)
    return ((labels > 0) & ~touching).astype(np.float32)


def print_source(pictures: list[LayerPicture], out_dir) -> PrintSource:
    """What convert() should read for these layers (one picture, or one picture's channels)."""
    if not pictures:
        raise InputError("“Layers”: choose the image or labels layer to print (select it in the layer list).")
    for picture in pictures:
        check_layer(picture)
    if len(pictures) == 1:
        return _one_source(pictures[0])
    return _channels_source(pictures, Path(out_dir))


def _kept_file(picture: LayerPicture) -> str | None:
    """The file a layer shows as read, with the scale the file gives (None: use the layer's pixels)."""
    path = (picture.mark or {}).get("path") or picture.path
    if not path or not Path(path).is_file() or picture.kind != "image":
        return None
    own = (picture.mark or {}).get("pixel_size_m")
    given = pixel_size_m(picture)
    if given is not None and not (own and abs(given / own - 1) < 1e-6):
        return None  # the user set a scale of their own in napari: print the layer at that scale
    return str(path)


def _one_source(picture: LayerPicture) -> PrintSource:
    path = _kept_file(picture)
    if path is not None:
        mark = picture.mark or {}
        many = int(mark.get("channels") or 1) > 1
        channel = str(mark["channel"]) if many and mark.get("channel") is not None else None
        which = f", channel {channel} alone" if channel is not None else ""
        return PrintSource(path, None, None, channel, (f"Read from {Path(path).name}{which}, with the file's own scale.",))
    metres = pixel_size_m(picture)
    said = (f"Printed from the layer “{picture.name}”, with its scale of {picture.scale[-1]:g} {picture.units[-1]} per pixel."
            if metres else f"Printed from the layer “{picture.name}”; it has no physical scale (its units are pixels).",)
    return PrintSource(plane_of(picture), file_stem(picture.name), metres, None, said)


def _channels_source(pictures: list[LayerPicture], out_dir: Path) -> PrintSource:
    marks = [p.mark or {} for p in pictures]
    paths = {m.get("path") for m in marks}
    if len(paths) == 1 and None not in paths and all(_kept_file(p) for p in pictures):
        path = next(iter(paths))
        if sorted(m.get("channel") for m in marks) == list(range(int(marks[0].get("channels") or 0))):
            return PrintSource(path, None, None, None, (f"Read from {Path(path).name}: all its {len(pictures)} channels, "
                                                         "with the file's own scale.",))
    planes = [plane_of(p) for p in pictures]
    if any(p.rgb for p in pictures) or len({plane.shape for plane in planes}) > 1:
        sizes = ", ".join(f"“{p.name}” {q.shape[1]} × {q.shape[0]}" for p, q in zip(pictures, planes))
        raise InputError(f"“Layers”: the layers of one print are its channels, so they must be single-channel pictures of one size; "
                         f"these are {sizes}. Choose one layer, or the channels of one picture.")
    stem = file_stem(pictures[0].name)
    metres = pixel_size_m(pictures[0])
    path = write_channels(out_dir / f"{stem}.layers.ome.tif", planes, names=[p.name for p in pictures], metres=metres)
    return PrintSource(str(path), stem, None, None,
                       (f"Printed from the layers {', '.join(f'“{p.name}”' for p in pictures)} as the channels of one picture, "
                        f"saved as {path.name} beside the print (so its recipe can make it again).",))


def write_channels(path: Path, planes: list[np.ndarray], *, names: list[str], metres: float | None) -> Path:
    """The layers as one OME-TIFF (channels named after the layers, the scale in µm), written
    whole or not at all (export.files.write_atomic)."""
    import io

    import tifffile

    from ..export.files import write_atomic

    stack = np.stack([np.asarray(p, dtype=np.float32) for p in planes])
    meta = {"axes": "CYX", "Channel": {"Name": list(names)}}
    if metres:
        meta.update(PhysicalSizeX=metres * 1e6, PhysicalSizeXUnit="µm", PhysicalSizeY=metres * 1e6, PhysicalSizeYUnit="µm")
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()  # tifffile wants a named file or a buffer; write_atomic hands over a descriptor's file
    tifffile.imwrite(buffer, stack, ome=True, metadata=meta)
    write_atomic(path, lambda fh: fh.write(buffer.getvalue()))
    return path


def file_stem(name: str) -> str:
    """A layer's name as a file name: letters, digits, '-', '_' and '.' kept, the rest '_'."""
    cleaned = "".join(c if c.isalnum() or c in "-_." else "_" for c in name).strip("._")
    return cleaned[:80] or "layer"
