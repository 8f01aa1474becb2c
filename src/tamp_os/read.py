"""Load an image file by its content (never its extension) into float32 at full precision.

TIFF goes through tifffile (8/16/32-bit integer and float, multipage, OME); everything else
through Pillow. Colour becomes grayscale by luminance (ITU-R 601, as Pillow's "L") unless a
channel is chosen. Transparent pixels and NaN/inf pixels are carried as zero weight in `alpha`
so they end up at base level.
"""

from __future__ import annotations

import hashlib
import logging
import math
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import InputError, MissingDependencyError, ParameterError, Text
from .read_cost import (MAX_MEMORY_GB, Cost, check_memory, pillow_copies_bytes, tiff_chunk_bytes, tiff_jpeg_bytes,
                        working_bytes)

log = logging.getLogger(__name__)

LUMA_601 = np.array([0.299, 0.587, 0.114], dtype=np.float32)
CHANNEL_NAMES = {"red": 0, "green": 1, "blue": 2, "alpha": 3}
TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")
DM_MAGIC = (b"\x00\x00\x00\x03", b"\x00\x00\x00\x04")


@dataclass
class ImageFile:
    """What we know about an input image: where it came from and what it holds.

    `metadata` holds the vendor blocks tifffile or the DM reader found (public keys only);
    `tiff_tags` the raw tags of the first TIFF page, by tag code (empty for other formats).
    """

    name: str
    sha256: str
    format: str
    width: int
    height: int
    dtype: str
    bit_depth: int
    channels: int
    pages: int = 1
    path: str | None = None
    metadata: dict = field(default_factory=dict)
    tiff_tags: dict[int, object] = field(default_factory=dict)
    nonfinite_pixels: int = 0
    transparent_pixels: int = 0
    notes: list[str] = field(default_factory=list)
    # What the file holds beyond the plane read (vendor files, OME/ImageJ stacks); see vendor_read.
    axes: dict[str, int] = field(default_factory=dict)  # axes present and their lengths: scenes, T, C, Z
    channel_count: int = 0  # channels in the file (C axis, else colour samples); 0: as `channels`
    channel_names: list[str] | None = None  # None where the format names no channels
    wavelengths_nm: list[float | None] = field(default_factory=list)  # per channel: emission, else excitation
    z_step_m: float | None = None
    reader: str = ""  # the library (and version) that decoded the pixels, for provenance
    # A colour picture's colours, subsampled to at most COLOUR_SAMPLE_PX a side, 0..1 float32: what
    # the channel path (relief/channel_auto.py) decides by (a stain, a fluorescence composite, or neither).
    colour_sample: np.ndarray | None = field(default=None, repr=False, compare=False)


@dataclass
class Picture:
    """A grayscale image and what is known about the file it came from.

    values : (H, W) float32, NaN where unknown.
    alpha : (H, W) float32 opacity weights in 0..1, or None when fully opaque.
    file : the facts about the input file.
    colour : (H, W, 3) colour pixels at the file's own precision, or None. Only a panel cut from a
        colour figure carries them (figure.crop_picture): it has no file of its own for the
        channel path (relief/channel_stage.py) to read its colours from again.
    """

    values: np.ndarray
    alpha: np.ndarray | None
    file: ImageFile
    colour: np.ndarray | None = field(default=None, repr=False, compare=False)


@dataclass
class _Decoded:
    """One decoder's result, before it becomes a Picture."""

    format: str
    array: np.ndarray  # (H, W) or (H, W, S)
    metadata: dict
    pages: int
    tiff_tags: dict[int, object] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    channel_chosen: bool = False  # a channel was already picked among the file's planes
    facts: dict = field(default_factory=dict)  # ImageFile fields the reader knows (axes, channel_names, ...)


MAX_DECODED_GB = 2.0  # default decoded-bytes guard: pixels × samples × bytes per sample, before decoding


def read_image(
    path, *, page: int | None = None, channel: str = "luminance", max_megapixels: float = 100.0, z_slice: int | None = None,
    max_decoded_gb: float = MAX_DECODED_GB, max_memory_gb: float = MAX_MEMORY_GB, time: int | None = None,
    scene: int | str | None = None, target_px: int | None = None, keep_colour: bool = False,
) -> Picture:
    """Read an image file by its content into a Picture.

    Parameters
    ----------
    path : the file (TIFF, DM3/DM4, or anything Pillow reads).
    page : the TIFF series, plane or frame to read (0-based); None: the first, or the data page
        when page 0 is a preview of it (Olympus SIS, thumbnails), with a note.
    channel : "luminance", a channel number, a colour name or an OME channel name.
    max_megapixels : refuse images above this many pixels (checked from the header).
    z_slice : one z slice instead of the maximum-intensity projection.
    max_decoded_gb : refuse files whose decoded pixels (every plane read, all samples, at their
        own bit depth) would exceed this many GB (1e9 bytes), checked from the header before decoding.
        The largest tile in flight and palette/RGBA conversion copies count as decoded bytes.
    max_memory_gb : refuse files whose estimated peak while converting (decoded pixels, tiles,
        copies and the pipeline's float32 working arrays, see read_cost.py) would exceed this.
    time : the time point of a time series (0-based); None: the first, with a note.
    scene : the scene, series, image or position of a multi-scene file (CZI, LIF, ND2, EMD...): its
        number, or its name where the file names them (a LIF series); None: the first, with a note.
        TIFF files choose their series with `page`.
    target_px : of a pyramid (SVS, pyramidal TIFF, OME-Zarr), read the smallest level at least this
        wide (default 2048), never the full-resolution slide when a smaller level fits the print.
    keep_colour : keep an RGB(A) file's colour pixels (H, W, 3, the array decoded, no copy) in
        `Picture.colour`, so that a figure's panels need not read the file again for them
        (figure.figure_colour); files read by the vendor readers never keep them.
    """
    limits = _Limits(max_megapixels, max_decoded_gb, max_memory_gb)
    path = Path(path)
    if path.is_dir() and _vendor_kind(path):  # an OME-Zarr folder
        from .vendor_read.picture import read_vendor

        return read_vendor(path, _vendor_kind(path), page, channel, limits, z_slice, time, scene, target_px)
    _refuse_special(path)
    try:
        with path.open("rb") as fh:  # only the head: the file is hashed by streaming, never held whole
            head = fh.read(1024)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file; check the name and folder.") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror}); check its permissions.") from None
    if not head:
        raise InputError(f"{path}: the file is empty (0 bytes); it is not an image. Export it again.")
    kind = None if head[:4] in TIFF_MAGIC or head[:4] in DM_MAGIC else _vendor_kind(path)
    if kind:
        from .vendor_read.picture import read_vendor

        return read_vendor(path, kind, page, channel, limits, z_slice, time, scene, target_px)
    for name, value in (("time", time), ("scene", scene)):
        if value:
            raise ParameterError(f"{path}: `{name}` {value} asked for, but this file has no {name} axis; leave `{name}` out "
                                 f"(TIFF series: `page`).", parameter=name, value=value)
    if head[:4] in TIFF_MAGIC:
        decoded = _read_tiff(path, page, limits, z_slice, channel, target_px or DEFAULT_TARGET_PX)
    elif head[:4] in DM_MAGIC:
        decoded = _read_dm(path, limits, path.stat().st_size)
    else:
        if z_slice:  # PNG, JPEG, GIF, WebP, BMP hold no z-stack: a slice asked for would be ignored silently
            raise ParameterError(f"{path}: `z_slice` {z_slice} asked for, but this file has no z-stack (it is a "
                                 f"single picture); leave `z_slice` out.", parameter="z_slice", value=z_slice)
        decoded = _read_pillow(path, head, page, limits)
    sha = _sha256_of(path)  # after the header checks: a refused file costs no read of its bytes
    if decoded.channel_chosen:
        channel = "luminance"  # the channel was chosen among the TIFF's planes
    return _to_picture(decoded, channel, name=path.name, sha=sha, path=str(path),
                       keep_colour=keep_colour and channel == "luminance" and not decoded.channel_chosen)


DEFAULT_TARGET_PX = 2048  # pyramid level: the smallest at least this wide (prints use at most ~1000 grid points)


def _vendor_kind(path: Path) -> str | None:
    from .vendor_read import detect

    try:
        return detect(path)
    except OSError:
        return None  # the regular path reports it


def _sha256_of(path: Path) -> str:
    """SHA-256 of a file read by blocks (a 5 GB file with a small image never sits in memory), or
    of a folder's files (name and bytes, sorted: an OME-Zarr folder)."""
    files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
    digest = hashlib.sha256()
    try:
        for file in files:
            if path.is_dir():
                digest.update(file.relative_to(path).as_posix().encode() + b"\0")
            with file.open("rb") as fh:
                for block in iter(lambda: fh.read(1 << 20), b""):
                    digest.update(block)
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror}); check its permissions.") from None
    return digest.hexdigest()


def _refuse_special(path: Path) -> None:
    """Refuse folders, FIFOs, devices and sockets before opening: reading them hangs or never ends."""
    import stat

    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise InputError(f"{path}: no such file; check the name and folder.") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror}); check its permissions.") from None
    if stat.S_ISDIR(mode):
        raise InputError(f"{path}: is a folder, not an image file; give an image file (folders are converted in a batch).")
    if not stat.S_ISREG(mode):
        kind = "a named pipe (FIFO)" if stat.S_ISFIFO(mode) else "a device or socket"
        raise InputError(f"{path}: is {kind}, not a regular file; save the image to a file and give that file.")


def read_array(array, *, channel: str = "luminance", name: str = "array") -> Picture:
    """Wrap an in-memory array (H×W, H×W×3 or H×W×4) the same way a file is read."""
    array = np.asarray(array)
    if array.dtype == bool:
        array = array.astype(np.uint8)
    if array.dtype.kind not in "uif":
        raise InputError(f"{name}: arrays must hold numbers, got dtype {array.dtype}.")
    sha = hashlib.sha256(np.ascontiguousarray(array).tobytes() + str(array.shape).encode()).hexdigest()
    return _to_picture(_Decoded("array", array, {}, 1), channel, name=name, sha=sha, path=None)


def _bits(dtype: np.dtype) -> int:
    return 1 if dtype == bool else dtype.itemsize * 8


@dataclass(frozen=True)
class _Limits:
    """The decompression-bomb guards: pixels in one plane, and decoded bytes of all planes read."""

    max_megapixels: float
    max_decoded_gb: float
    max_memory_gb: float = MAX_MEMORY_GB


def _check_bytes(path, shape, dtype, limits: _Limits, what: str = "image", chunk_bytes: float = 0.0) -> None:
    """Refuse, before decoding, an array of `shape` and `dtype` above the decoded-bytes limit.

    shape : every axis that will be decoded (planes, rows, columns, samples).
    chunk_bytes : the tiles or strips decoded at once, as declared (a tile may be far larger than the image).
    """
    itemsize = np.dtype(dtype).itemsize
    total = int(np.prod([int(n) for n in shape], dtype=np.float64)) * itemsize
    if chunk_bytes > total:  # a tile larger than the image: the decoder allocates the whole tile
        if chunk_bytes > limits.max_decoded_gb * 1e9:
            raise InputError(
                f"{path}: this {what} is stored in tiles (or strips) that decode to {chunk_bytes / 1e9:.1f} GB, far larger than "
                f"its {'×'.join(str(int(n)) for n in shape)} pixels; that exceeds the limit of {limits.max_decoded_gb:g} GB that "
                f"guards against decompression bombs. The file is malformed or hostile; re-export it from the microscope software."
            )
    if total > limits.max_decoded_gb * 1e9:
        dims = "×".join(str(int(n)) for n in shape)
        raise InputError(
            f"{path}: decoding this {what} ({dims} values × {itemsize} bytes = {_gb_words(total)}) would exceed "
            f"the limit of {limits.max_decoded_gb:g} GB that guards against decompression bombs.",
            hint=f"If you trust the file and the computer has the memory (about 3× that), raise the limit, "
                 f"for example `max_decoded_gb` {math.ceil(total / 1e9)}.",
        )


def _gb_words(n_bytes: float) -> str:
    """Bytes in GB with one decimal, or two significant digits below 0.1 GB (never '0.0 GB' for a small file)."""
    gb = n_bytes / 1e9
    return f"{gb:.1f} GB" if gb >= 0.1 else f"{gb:.2g} GB"


def _check_cost(path, plane_hw, shape, dtype, limits: _Limits, chunk_bytes: float = 0.0, copies_bytes: float = 0.0) -> None:
    """Refuse, before decoding, a file whose conversion would need more than max_memory_gb in all."""
    cost = Cost()
    cost.add("decoded pixels", float(np.prod([int(n) for n in shape], dtype=np.float64)) * np.dtype(dtype).itemsize)
    cost.add("tiles being decoded", chunk_bytes)
    cost.add("converted copies", copies_bytes)
    cost.add("float32 working arrays", working_bytes(*plane_hw))
    check_memory(path, f"{int(plane_hw[1])}×{int(plane_hw[0])} image", cost, limits.max_memory_gb)


def _check_size(path, shape, limits: _Limits) -> None:
    h, w = shape[0], shape[1]
    max_megapixels = limits.max_megapixels
    if h * w > max_megapixels * 1e6:
        raise InputError(
            f"{path}: the image claims {w}×{h} pixels ({h * w / 1e6:.0f} Mpx), above the limit of "
            f"{max_megapixels:g} Mpx that guards against decompression bombs.",
            hint=f"If you trust the file, raise the limit, for example `max_megapixels` {int(h * w / 1e6) + 1}.",
        )


def _vendor_blocks(tif, data_page: int = 0) -> dict:
    """The metadata blocks tifffile decodes for microscope vendors and ImageJ/OME.

    Olympus SIS keeps its tags on the data page behind the JPEG preview: those are read from
    `data_page` (tifffile's `sis_metadata` looks at page 0 only), falling back to page 0.
    """
    meta = {}
    from .read_stacks import sis_of_page

    sis = sis_of_page(tif, data_page) if data_page else None
    if sis:
        meta["sis_metadata"] = sis
    for attr in ("fei_metadata", "sem_metadata", "sis_metadata", "tvips_metadata", "imagej_metadata", "ome_metadata"):
        if attr in meta:
            continue
        try:
            value = getattr(tif, attr, None)
        except Exception:  # a broken vendor block must not stop the image from loading
            value = None
        if value:
            meta[attr] = value
    if getattr(tif, "is_svs", False):
        try:
            from tifffile.tifffile import svs_description_metadata

            meta["svs_metadata"] = svs_description_metadata(tif.pages[0].description)
        except Exception:  # a broken description only loses the scale
            pass
    return meta


def _read_tiff(path, page, limits: _Limits, z_slice=None, channel="luminance", target_px=DEFAULT_TARGET_PX) -> _Decoded:
    """One 2-D plane (or Y X S colour plane) from a TIFF series, or from the data page beside a preview.

    Axes other than Y, X and S (colour samples) are reduced: Z by a maximum-intensity projection
    (or `z_slice`), C by `channel` (a number or an OME channel name; default the first),
    anything else (T, pages…) by `page`. `page` None means the data page (previews skipped).
    """
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            from .read_stacks import pyramid_level, reduce_by_pages, tiff_z_step_m

            source = _tiff_source(path, tif, page)
            level_notes, level_meta = pyramid_level(source, target_px)
            chosen, axes, shape = source.chosen, source.chosen.axes, source.chosen.shape
            if "Y" not in axes or "X" not in axes:
                raise InputError(f"{path}: TIFF series with axes {axes!r} has no 2-D image plane.")
            plane_hw = (shape[axes.index("Y")], shape[axes.index("X")])
            _check_size(path, plane_hw, limits)
            chunk = max(tiff_chunk_bytes(chosen.keyframe), tiff_jpeg_bytes(path, chosen.keyframe))  # as the file declares
            _check_bytes(path, shape, chosen.dtype, limits, f"TIFF series ({axes})", chunk)
            _check_cost(path, plane_hw, shape, chosen.dtype, limits, chunk)
            meta = {"tiff_series_axes": axes, "tiff_series": source.series, **_vendor_blocks(tif, source.tag_page), **level_meta}
            tags = {tag.code: tag.value for tag in tif.pages[0].tags}
            tags.update({tag.code: tag.value for tag in tif.pages[source.tag_page].tags} if source.tag_page else {})
            plane = reduce_by_pages(path, chosen, axes, shape, source.page, z_slice, channel, meta)
            if plane is None:
                plane = _reduce_axes(path, chosen.asarray(), axes, source.page, z_slice, channel, meta)
            if chosen.keyframe.photometric == tifffile.PHOTOMETRIC.SEPARATED and plane.array.ndim == 3:
                plane.array = _cmyk_to_rgb(plane.array)
                plane.notes.append("CMYK (separated) TIFF: converted to RGB, then to luminance.")
            notes = source.notes + level_notes + plane.notes
            facts = {"axes": {a: int(n) for a, n in zip(axes, shape) if a not in "YXS" and n > 1}}
            if "C" in axes:
                names = _channel_names(meta)
                facts.update(channel_count=int(shape[axes.index("C")]), channel_names=names or None)
            if "Z" in axes:
                facts["z_step_m"] = tiff_z_step_m(meta)
            decoded = _Decoded("TIFF", plane.array, meta, max(source.count, plane.planes), tags, notes, plane.channel_chosen)
            decoded.facts = facts
            return decoded
    except (InputError, ParameterError):
        raise
    except MemoryError:
        raise InputError(f"{path}: not enough memory to read this TIFF; try a smaller image.") from None
    except Exception as exc:
        raise InputError(f"{path}: a damaged or unsupported TIFF ({exc}); re-export it from the microscope software.") from None


@dataclass
class _TiffSource:
    chosen: object  # a tifffile series or page: axes, shape, dtype, asarray(), keyframe
    page: int  # the page index left for _reduce_axes within `chosen`
    count: int  # series or pages the page parameter chooses among
    tag_page: int = 0  # the page whose tags describe the data
    series: int = 1  # series tifffile found (not asked when previews make its series wrong)
    notes: list[str] = field(default_factory=list)


def _tiff_source(path, tif, page: int | None) -> _TiffSource:
    """The series (or, beside a preview, the page) to read; `page` None picks the data page."""
    from .read_pages import find_data_page

    data_page = find_data_page(tif)
    if data_page is not None:  # pages of different kinds: tifffile's series would mix them
        index = data_page.index if page is None else page
        if not 0 <= index < len(tif.pages):
            raise ParameterError(f"{path}: `page` must be 0–{len(tif.pages) - 1} (pages in this file); got {index}.")
        notes = [data_page.note()] if page is None else []
        return _TiffSource(tif.pages[index], 0, len(tif.pages), index, notes=notes)
    page, series = page or 0, tif.series
    if not series:
        raise InputError(f"{path}: a TIFF without any image in it.")
    if len(series) > 1:
        if page >= len(series):
            raise ParameterError(f"{path}: `page` must be 0–{len(series) - 1} (series in this file); got {page}.")
        return _TiffSource(series[page], 0, len(series), series=len(series))
    return _TiffSource(series[0], page, 1)


def _cmyk_to_rgb(cmyk: np.ndarray) -> np.ndarray:
    """(H, W, 4+) ink amounts C, M, Y, K -> (H, W, 3) float32 RGB on the same scale.

    The naive conversion (no colour profile) that Pillow also uses: R = (1 − C)(1 − K).
    Without it, K would be read as an alpha channel.
    """
    top = _alpha_scale(cmyk.dtype)
    inks = cmyk[..., :4].astype(np.float32) / np.float32(top)
    rgb = (1 - inks[..., :3]) * (1 - inks[..., 3:4])
    return rgb * np.float32(top)


_GENERIC_LABEL = re.compile(r"^\s*(?:c:\d+/\d+\b.*|channel\s*\d+|ch\s*\d+|c\d+)?\s*$", re.IGNORECASE)
_INFO_KEY = re.compile(r"^\s*Information\|Image\|Channel\|(Name|ExcitationWavelength|EmissionWavelength) #(\d+)\s*=\s*(.+?)\s*$")


def imagej_info_channels(ij: dict) -> list[tuple[str, float | None, float | None]]:
    """[(name, excitation nm, emission nm)] of each channel that a ZEN (Bio-Formats) export keeps
    in the ImageJ Info text (`Information|Image|Channel|Name #1 = DAPI`); [] when there is none."""
    info = ij.get("Info") if isinstance(ij, dict) else None
    if not isinstance(info, str) or "Information|Image|Channel|" not in info:
        return []
    found: dict[int, dict[str, str]] = {}
    for line in info.splitlines():
        m = _INFO_KEY.match(line) if len(line) < 400 else None
        if m:
            found.setdefault(int(m.group(2)), {})[m.group(1)] = m.group(3)

    def nm(text):
        try:
            v = float(text)
        except (TypeError, ValueError):
            return None
        return v if 200 <= v <= 2000 else None

    return [(d["Name"], nm(d.get("ExcitationWavelength")), nm(d.get("EmissionWavelength")))
            for _, d in sorted(found.items()) if d.get("Name")]


def _channel_names(meta) -> list[str]:
    xml = meta.get("ome_metadata")
    if not xml:
        ij = meta.get("imagej_metadata") or {}
        labels = ij.get("Labels")
        labels = [str(x) for x in labels] if isinstance(labels, (list, tuple)) else []
        info = [c[0] for c in imagej_info_channels(ij)]
        # Fiji's labels of a converted file ("c:1/2 - Snap-03.czi #1") name only the position:
        # the original's channel names, kept in the ImageJ Info text, name the dye
        if info and (not labels or all(_GENERIC_LABEL.match(x) for x in labels)):
            return info
        return labels
    from .xmltext import ome_channel_names  # a parser, not a regex: linear in the text's length

    return ome_channel_names(xml)


@dataclass
class _Plane:
    array: np.ndarray  # (H, W) or (H, W, S)
    planes: int = 1  # planes the page index chose among
    notes: list[str] = field(default_factory=list)
    channel_chosen: bool = False


def _reduce_axes(path, array, axes, page, z_slice, channel, meta) -> _Plane:
    """Reduce an n-D TIFF series to one (H, W) or (H, W, S) plane: channel, then Z, then page."""
    notes: list[str] = []
    chosen = "C" in axes
    if chosen:
        array, axes = _pick_channel(path, array, axes, channel, meta, notes)
    if "Z" in axes:
        array, axes = _pick_z(path, array, axes, z_slice, notes)
    array, axes, planes = _pick_page(path, array, axes, page)
    if "S" in axes and axes.index("S") < axes.index("Y"):
        array = np.moveaxis(array, 0, -1)  # planar RGB -> Y X S
    return _Plane(array, planes, notes, chosen)


def _pick_channel(path, array, axes, channel, meta, notes):
    index = _channel_choice(path, array.shape[axes.index("C")], channel, meta, notes)
    return np.take(array, index, axis=axes.index("C")), axes.replace("C", "")


def _channel_choice(path, n: int, channel, meta, notes) -> int:
    """The C index `channel` names among `n` (a number, an OME/ImageJ name, or luminance: 0 with a note)."""
    names = _channel_names(meta)
    if channel.isdigit():
        index = int(channel)
    elif channel in names:
        index = names.index(channel)
    elif channel == "luminance":
        index = 0
        if n > 1:
            named = f" ({', '.join(names)})" if names else ""
            notes.append(Text(f"{n} channels{named}; using channel 0. Choose another with `channel` (a number or a name)."))
    else:
        raise ParameterError(f"{path}: `channel` {channel!r} is not one of 0–{n - 1}{' or ' + ', '.join(names) if names else ''}.")
    if not 0 <= index < n:
        raise ParameterError(f"{path}: `channel` must be 0–{n - 1}; got {index}.")
    return index


def _pick_z(path, array, axes, z_slice, notes):
    n = array.shape[axes.index("Z")]
    if z_slice is None:
        array = array.max(axis=axes.index("Z"))
        if n > 1:
            notes.append(Text(f"z-stack of {n} slices: maximum-intensity projection (choose one slice with `z_slice`)."))
    else:
        if not 0 <= z_slice < n:
            raise ParameterError(f"{path}: `z_slice` must be 0–{n - 1} (slices in this stack); got {z_slice}.")
        array = np.take(array, z_slice, axis=axes.index("Z"))
    return array, axes.replace("Z", "")


def _pick_page(path, array, axes, page):
    leading = [i for i, a in enumerate(axes) if a not in "YXS"]
    if not leading:
        if page:
            raise ParameterError(f"{path}: page {page} asked for, but the file has a single image plane.")
        return array, axes, 1
    planes = int(np.prod([array.shape[i] for i in leading]))
    if page >= planes:
        raise ParameterError(f"{path}: `page` must be 0–{planes - 1} (planes in this file); got {page}.")
    keep = [a for a in axes if a in "YXS"]
    shape = (planes,) + tuple(array.shape[axes.index(a)] for a in keep)
    array = np.moveaxis(array, leading, range(len(leading))).reshape(shape)[page]
    return array, "".join(keep), planes


def _read_dm(path, limits: _Limits, file_bytes: int) -> _Decoded:
    """The first 2-D plane of a DM3/DM4 file, its size checked before any pixel is decoded."""
    try:
        from rsciio.digitalmicrograph import file_reader
    except ImportError:
        raise MissingDependencyError(
            f"{path}: is a Gatan DigitalMicrograph (DM3/DM4) file; reading it needs the optional "
            f"extra: pip install 'tamp-os[dm]' (rosettasciio)."
        ) from None
    try:
        item = file_reader(str(path), lazy=True)[0]  # lazy: the header's shape and dtype, no pixels yet
        data = item["data"]
        plane = data[(0,) * (data.ndim - 2)] if data.ndim > 2 else data
        _check_size(path, plane.shape, limits)
        _check_bytes(path, plane.shape, data.dtype, limits, "DigitalMicrograph plane")
        _check_cost(path, plane.shape, plane.shape, data.dtype, limits)
        array = np.asarray(plane)
    except (InputError, ParameterError):
        raise
    except Exception as exc:
        raise InputError(f"{path}: a damaged DM3/DM4 file ({exc}).") from None
    if array.ndim != 2:
        raise InputError(f"{path}: the DM3/DM4 image has shape {array.shape}; expected a 2-D image.")
    return _Decoded("DM", array, {"dm_axes": item.get("axes", []), "dm_metadata": item.get("metadata", {})}, 1)


def _open_pillow(stream):
    """Open an image with Pillow's format plugins, reading only its header.

    `Image.open` checks the size against the process-wide `Image.MAX_IMAGE_PIXELS`; changing
    that per call would race between the web app's conversion threads. Calling the registered
    plugin factories directly skips that check, and `_check_size` applies ours instead.
    """
    from PIL import Image, UnidentifiedImageError

    prefix = stream.read(16)
    tried: set[str] = set()
    # The common formats first, in the order Image.open tries them; only when none of them opens the
    # file, every other plugin too (as Image.open does: importing all ~45 plugins costs 0.05-0.2 s).
    # init() only appends to Image.ID, so the formats are tried in the same order either way.
    for load_plugins in (Image.preinit, Image.init):
        load_plugins()
        for fmt in [f for f in Image.ID if f not in tried]:
            tried.add(fmt)
            factory, accept = Image.OPEN[fmt]
            accepted = True if accept is None else accept(prefix)
            if not accepted or isinstance(accepted, str):  # a str explains a refusal
                continue
            stream.seek(0)
            try:
                return factory(stream, "")
            except (SyntaxError, IndexError, TypeError, struct.error):
                continue
    raise UnidentifiedImageError("cannot identify image file")


def _read_pillow(path, head, page, limits: _Limits) -> _Decoded:
    from PIL import UnidentifiedImageError

    fmt = "image"
    stream = None
    try:
        stream = open(path, "rb")  # Pillow reads the file as it decodes; its bytes are never held twice
        im = _open_pillow(stream)
        fmt = im.format or "image"
        hw = (im.size[1], im.size[0])
        _check_size(path, hw, limits)
        _check_bytes(path, (*hw, *_pillow_samples(im.mode)), np.uint8, limits, f"{fmt} image")
        _check_cost(path, hw, (*hw, _mode_bytes(im.mode)), np.uint8, limits,
                    copies_bytes=pillow_copies_bytes(im.mode, hw[0] * hw[1]))
        frames = getattr(im, "n_frames", 1)
        if page:
            if page >= frames:
                raise ParameterError(f"{path}: `page` must be 0–{frames - 1} (frames in this file); got {page}.")
            im.seek(page)
        im.load()
    except UnidentifiedImageError:
        what = "it holds text, not pixels" if head[:512].isascii() and b"\0" not in head[:512] else "its contents match no image format"
        raise InputError(  # the file's bytes are never echoed: they may be private and mean nothing to a reader
            f"{path}: not an image that can be read ({what}); "
            f"supported: PNG, JPEG, TIFF, BMP, GIF, WebP, DM3/DM4."
        ) from None
    except (InputError, ParameterError):
        raise
    except (OSError, SyntaxError, ValueError, EOFError) as exc:
        raise InputError(f"{path}: the {fmt} file is damaged or truncated ({exc}).") from None
    except MemoryError:
        raise InputError(f"{path}: not enough memory to decode this {fmt} image; make it smaller and try again.") from None
    finally:
        if stream is not None:
            stream.close()  # load() has read every pixel the image needs
    meta = {"pillow_mode": im.mode}
    if "dpi" in im.info:
        meta["dpi_not_physical"] = im.info["dpi"]
    im, notes = _apply_orientation(im)
    array = _pillow_array(im)
    if im.mode == "I" and array.size and array.min() >= 0 and array.max() <= 65535:
        meta["note_int32"] = "32-bit integer pixels"
    return _Decoded(fmt, array, meta, frames, notes=notes)


def _pillow_samples(mode: str) -> tuple[int]:
    """Bytes per pixel Pillow will hold for `mode`, after the conversions `_pillow_array` makes."""
    from PIL import ImageMode

    if mode in ("P", "PA", "CMYK", "YCbCr", "LAB", "HSV"):
        return (4,)  # palette -> RGBA, colour models -> RGB (4 bytes is an upper bound)
    info = ImageMode.getmode(mode)
    return (len(info.bands) * np.dtype(info.typestr).itemsize,)


def _mode_bytes(mode: str) -> int:
    """Bytes per pixel Pillow itself holds for `mode` (a palette image: one index a pixel)."""
    from PIL import ImageMode

    info = ImageMode.getmode(mode)
    return len(info.bands) * np.dtype(info.typestr).itemsize


EXIF_ORIENTATION = 0x0112
ORIENTATION_WORDS = {2: "mirrored left to right", 3: "turned 180°", 4: "flipped top to bottom", 5: "transposed",
                     6: "turned 90° clockwise", 7: "transversed", 8: "turned 90° counter-clockwise"}


def _apply_orientation(im):
    """Turn the picture upright as its EXIF orientation tag says (as every viewer does), and say so."""
    from PIL import ImageOps

    orientation = im.getexif().get(EXIF_ORIENTATION, 1)
    if orientation not in ORIENTATION_WORDS:
        return im, []
    turned = ImageOps.exif_transpose(im)
    note = f"EXIF orientation {orientation}: the picture was {ORIENTATION_WORDS[orientation]} to stand upright, as viewers show it."
    return turned, [note]


def _pillow_array(im) -> np.ndarray:
    """(H, W) or (H, W, S) pixels at the image's own precision, colour models turned into RGB."""
    mode = im.mode
    if mode == "P" or mode == "PA":
        im = im.convert("RGBA" if ("transparency" in im.info or mode == "PA") else "RGB")
    elif mode == "1":
        im = im.convert("L")
    elif mode in ("CMYK", "YCbCr", "LAB", "HSV"):
        im = im.convert("RGB")
    elif mode == "I;16B" or mode == "I;16L" or mode == "I;16N":
        im = im.convert("I;16")
    return np.asarray(im)


def _to_picture(decoded: _Decoded, channel, *, name, sha, path, keep_colour: bool = False) -> Picture:
    array = np.asarray(decoded.array)
    if array.ndim == 3 and array.shape[-1] == 1:
        array = array[..., 0]
    if array.ndim not in (2, 3) or (array.ndim == 3 and array.shape[-1] not in (2, 3, 4)):
        raise InputError(f"{name}: expected a 2-D image (optionally with 2–4 colour channels); got shape {array.shape}.")
    h, w = array.shape[:2]
    if h < 2 or w < 2:
        raise InputError(
            f"{name}: the image is {w}×{h} pixels; at least 2×2 is needed to make a relief."
        )
    file = ImageFile(
        name=name,
        sha256=sha,
        format=decoded.format,
        width=w,
        height=h,
        dtype=str(array.dtype),
        bit_depth=_bits(array.dtype),
        channels=1 if array.ndim == 2 else array.shape[-1],
        pages=decoded.pages,
        path=path,
        metadata=decoded.metadata,
        tiff_tags=decoded.tiff_tags,
        notes=list(decoded.notes),
        **decoded.facts,
    )
    file.channel_count = file.channel_count or file.channels
    if array.ndim == 3 and array.shape[-1] >= 3:
        file.colour_sample = colour_sample(array)
    values, alpha = _grayscale(array, channel, name)
    values, alpha = _weigh_unknown(file, values, alpha)
    if file.nonfinite_pixels == h * w:
        raise InputError(f"{name}: every pixel is NaN or infinite; there is no image to print.")
    colour = array[..., :3] if keep_colour and array.ndim == 3 and array.shape[-1] >= 3 else None
    return Picture(values=values, alpha=alpha, file=file, colour=colour)


COLOUR_SAMPLE_PX = 512


def colour_sample(array: np.ndarray) -> np.ndarray:
    """Every k-th pixel of the colour samples (not alpha), at most COLOUR_SAMPLE_PX a side, 0..1."""
    step = max(1, -(-max(array.shape[:2]) // COLOUR_SAMPLE_PX))
    rgb = np.nan_to_num(array[::step, ::step, :3].astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0)
    # 8 bits: full scale; 16-bit and float colour often fills only part of its range (12-bit cameras)
    top = 255.0 if array.dtype == np.uint8 else float(rgb.max()) if rgb.size else 1.0
    return np.clip(rgb / np.float32(top if top > 0 else 1.0), 0, 1)


def _weigh_unknown(file: ImageFile, values, alpha):
    """Give NaN/inf pixels zero weight; count them and the transparent ones in `file`."""
    bad = ~np.isfinite(values)
    file.nonfinite_pixels = int(bad.sum())
    if file.nonfinite_pixels:
        file.notes.append(f"{file.nonfinite_pixels} pixels were NaN or infinite; they are printed at base level.")
        values = np.where(bad, np.nan, values).astype(np.float32)
        alpha = np.where(bad, 0.0, 1.0 if alpha is None else alpha).astype(np.float32)
    if alpha is not None:
        file.transparent_pixels = int((alpha < 1.0).sum())
        if file.transparent_pixels:
            file.notes.append(f"{file.transparent_pixels} pixels are (partly) transparent; transparent means base level.")
    return values, alpha


LUMA_ROWS = 512  # rows converted at a time: the (rows, W, 3) float32 copy stays small


def _luminance(colour: np.ndarray) -> np.ndarray:
    """(H, W) float32 luminance of (H, W, 3) colour, a block of rows at a time.

    float32 keeps 16-bit sources exact to ~1e-3 of a grey level, at a third of float64's cost;
    converting by blocks avoids a full (H, W, 3) float32 copy (12 bytes a pixel).
    """
    out = np.empty(colour.shape[:2], np.float32)
    for r in range(0, colour.shape[0], LUMA_ROWS):
        np.matmul(colour[r:r + LUMA_ROWS].astype(np.float32), LUMA_601, out=out[r:r + LUMA_ROWS])
    return out


def _alpha_scale(dtype) -> float:
    return float(np.iinfo(dtype).max) if np.dtype(dtype).kind in "ui" else 1.0


def _grayscale(array, channel: str, name: str):
    """(values, alpha) from any pixel layout; values keep their full source precision in float."""
    if array.ndim == 2:
        if channel not in ("luminance", "0"):
            raise ParameterError(f"{name}: channel {channel} asked for, but the image has a single channel; use luminance.")
        return array.astype(np.float32), None
    n = array.shape[-1]
    has_alpha = n in (2, 4)
    alpha = array[..., -1].astype(np.float32) / _alpha_scale(array.dtype) if has_alpha else None
    colour = array[..., : n - 1] if has_alpha else array
    if channel == "luminance":
        if colour.shape[-1] == 1:
            values = colour[..., 0].astype(np.float32)
        else:
            values = _luminance(colour)
        return values, alpha
    index = CHANNEL_NAMES.get(channel.lower()) if not channel.isdigit() else int(channel)
    if index is None or index >= n:
        raise ParameterError(
            f"{name}: `channel` must be luminance, a number 0–{n - 1} or a colour name the image has; got {channel!r}."
        )
    return array[..., index].astype(np.float32), (None if index == n - 1 and has_alpha else alpha)
