"""Load an image file by its content (never its extension) into float32 at full precision.

TIFF goes through tifffile (8/16/32-bit integer and float, multipage, OME); everything else
through Pillow. Colour becomes grayscale by luminance (ITU-R 601, as Pillow's "L") unless a
channel is chosen. Transparent pixels and NaN/inf pixels are carried as zero weight in `alpha`
so they end up at base level.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import logging
import struct
from contextvars import ContextVar
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Decision, InputError, MissingDependencyError, ParameterError
from .cost import (MAX_MEMORY_GB, READER_BYTES, Cost, check_memory, pillow_copies_bytes, tiff_chunk_bytes, tiff_jpeg_bytes,
                        working_bytes)
from .model import (DEFAULT_TARGET_PX, Decoded, Limits, Picture, Plane, alpha_scale, channel_choice, check_bytes, check_size,
                    file_channel_names, sha256_of, to_picture)

log = logging.getLogger(__name__)

TIFF_MAGIC = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")
DM_MAGIC = (b"\x00\x00\x00\x03", b"\x00\x00\x00\x04")








MAX_DECODED_GB = 2.0  # default decoded-bytes guard: pixels × samples × bytes per sample, before decoding

# Within `decoded_once()`: the last TIFF plane decoded, {key: (channel asked, Decoded)}.
_DECODED: ContextVar[dict | None] = ContextVar("tamp_decoded_tiff", default=None)


@contextlib.contextmanager
def decoded_once():
    """Within this block (one conversion), a TIFF plane is decoded once: the later reads of the
    same file, plane and pyramid level (the figure's look at the picture, the print's, each colour
    channel's) share its pixels. A whole slide's level decoded six times cost 0.6 s. Only the last
    plane is kept, and nothing outlives the block."""
    token = _DECODED.set({}) if _DECODED.get() is None else None
    try:
        yield
    finally:
        if token is not None:
            _DECODED.reset(token)


def _read_tiff_once(path: Path, page, limits: Limits, z_slice, channel, target_px) -> Decoded:
    cache = _DECODED.get()
    if cache is None:
        return _read_tiff(path, page, limits, z_slice, channel, target_px)
    st = path.stat()
    key = (str(path), st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns, page, limits, z_slice, target_px)
    asked, decoded = cache.get(key, (None, None))
    if decoded is None or (decoded.channel_chosen and asked != channel):  # a channel picked among planes: its own read
        decoded = _read_tiff(path, page, limits, z_slice, channel, target_px)
        decoded.array.flags.writeable = False  # shared by every read in the block: nobody may change it
        cache.clear()
        cache[key] = (channel, decoded)
    # The pixels shared; the containers each reader may add to are its own.
    return dataclasses.replace(decoded, metadata=dict(decoded.metadata), tiff_tags=dict(decoded.tiff_tags), notes=list(decoded.notes),
                               facts=dict(decoded.facts))


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

    Returns
    -------
    Picture
        `values`: (H, W) float32 at full precision (never squeezed to 8 bits); `file`: an
        ImageFile with the format, size, bit depth, axes, channels and the vendor metadata the
        scale is read from; `notes`: what was chosen for the user (a page, a channel, a plane).

    Examples
    --------
    >>> import numpy as np, tempfile, tifffile
    >>> path = tempfile.mkdtemp() + "/ramp.tif"
    >>> tifffile.imwrite(path, np.arange(12000, dtype=np.uint16).reshape(100, 120))
    >>> picture = read_image(path)
    >>> picture.values.shape, picture.values.dtype, float(picture.values.max())  # 16 bits kept
    ((100, 120), dtype('float32'), 11999.0)
    """
    limits = Limits(max_megapixels, max_decoded_gb, max_memory_gb)
    path = Path(path)
    if path.is_dir() and vendor_kind(path):  # an OME-Zarr folder
        from .vendor.picture import read_vendor

        return read_vendor(path, vendor_kind(path), page, channel=channel, limits=limits, z_slice=z_slice, time=time, scene=scene, target_px=target_px)
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
    kind = None if head[:4] in TIFF_MAGIC or head[:4] in DM_MAGIC else vendor_kind(path)
    if kind:
        from .vendor.picture import read_vendor

        return read_vendor(path, kind, page, channel=channel, limits=limits, z_slice=z_slice, time=time, scene=scene, target_px=target_px)
    for name, value in (("time", time), ("scene", scene)):
        if value:
            raise ParameterError(f"{path}: `{name}` {value} asked for, but this file has no {name} axis; leave `{name}` out "
                                 f"(TIFF series: `page`).", parameter=name, value=value)
    if head[:4] in TIFF_MAGIC:
        decoded = _read_tiff_once(path, page, limits, z_slice, channel, target_px or DEFAULT_TARGET_PX)
    elif head[:4] in DM_MAGIC:
        decoded = _read_dm(path, limits, path.stat().st_size)
    else:
        if z_slice:  # PNG, JPEG, GIF, WebP, BMP hold no z-stack: a slice asked for would be ignored silently
            raise ParameterError(f"{path}: `z_slice` {z_slice} asked for, but this file has no z-stack (it is a "
                                 f"single picture); leave `z_slice` out.", parameter="z_slice", value=z_slice)
        decoded = _read_pillow(path, head, page, limits)
    sha = sha256_of(path)  # after the header checks: a refused file costs no read of its bytes
    if decoded.channel_chosen:
        channel = "luminance"  # the channel was chosen among the TIFF's planes
    return to_picture(decoded, channel, name=path.name, sha=sha, path=str(path),
                       keep_colour=keep_colour and channel == "luminance" and not decoded.channel_chosen)




def vendor_kind(path: Path) -> str | None:
    from .vendor import detect

    try:
        return detect(path)
    except OSError:
        return None  # the regular path reports it




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
    return to_picture(Decoded("array", array, {}, 1), channel, name=name, sha=sha, path=None)










def _check_cost(path, plane_hw, shape, dtype, limits: Limits, chunk_bytes: float = 0.0, copies_bytes: float = 0.0) -> None:
    """Refuse, before decoding, a file whose conversion would need more than max_memory_gb in all."""
    cost = Cost()
    cost.add("decoded pixels", float(np.prod([int(n) for n in shape], dtype=np.float64)) * np.dtype(dtype).itemsize)
    cost.add("tiles being decoded", chunk_bytes)
    cost.add("converted copies", copies_bytes)
    cost.add("float32 working arrays", working_bytes(*plane_hw))
    cost.add("the reader's own objects", READER_BYTES)
    check_memory(path, f"{int(plane_hw[1])}×{int(plane_hw[0])} image", cost, max_memory_gb=limits.max_memory_gb)




def _vendor_blocks(tif, data_page: int = 0) -> dict:
    """The metadata blocks tifffile decodes for microscope vendors and ImageJ/OME.

    Olympus SIS keeps its tags on the data page behind the JPEG preview: those are read from
    `data_page` (tifffile's `sis_metadata` looks at page 0 only), falling back to page 0.
    """
    meta = {}
    from .stacks import sis_of_page

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


def _read_tiff(path, page, limits: Limits, z_slice=None, channel="luminance", target_px=DEFAULT_TARGET_PX) -> Decoded:
    """One 2-D plane (or Y X S colour plane) from a TIFF series, or from the data page beside a preview.

    Axes other than Y, X and S (colour samples) are reduced: Z by a maximum-intensity projection
    (or `z_slice`), C by `channel` (a number or an OME channel name; default the first),
    anything else (T, pages…) by `page`. `page` None means the data page (previews skipped).
    """
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            from .stacks import pyramid_level, reduce_by_pages, tiff_z_step_m

            source = _tiff_source(path, tif, page)
            level_notes, level_meta = pyramid_level(source, target_px)
            chosen, axes, shape = source.chosen, source.chosen.axes, source.chosen.shape
            if "Y" not in axes or "X" not in axes:
                raise InputError(f"{path}: TIFF series with axes {axes!r} has no 2-D image plane.")
            plane_hw = (shape[axes.index("Y")], shape[axes.index("X")])
            check_size(path, plane_hw, limits)
            chunk = max(tiff_chunk_bytes(chosen.keyframe), tiff_jpeg_bytes(path, chosen.keyframe))  # as the file declares
            check_bytes(path, shape, chosen.dtype, limits=limits, what=f"TIFF series ({axes})", chunk_bytes=chunk)
            _check_cost(path, plane_hw, shape, chosen.dtype, limits, chunk)
            meta = {"tiff_series_axes": axes, "tiff_series": source.series, **_vendor_blocks(tif, source.tag_page), **level_meta}
            tags = {tag.code: tag.value for tag in tif.pages[0].tags}
            tags.update({tag.code: tag.value for tag in tif.pages[source.tag_page].tags} if source.tag_page else {})
            plane = reduce_by_pages(path, chosen, axes, shape=shape, page=source.page, z_slice=z_slice, channel=channel, meta=meta)
            if plane is None:
                plane = _reduce_axes(path, chosen.asarray(), axes, source.page, z_slice, channel, meta)
            if chosen.keyframe.photometric == tifffile.PHOTOMETRIC.SEPARATED and plane.array.ndim == 3:
                plane.array = _cmyk_to_rgb(plane.array)
                plane.notes.append("CMYK (separated) TIFF: converted to RGB, then to luminance.")
            notes = source.notes + level_notes + plane.notes
            facts = {"axes": {a: int(n) for a, n in zip(axes, shape) if a not in "YXS" and n > 1}}
            if "C" in axes:
                names = file_channel_names(meta)
                facts.update(channel_count=int(shape[axes.index("C")]), channel_names=names or None)
            if "Z" in axes:
                facts["z_step_m"] = tiff_z_step_m(meta)
            decoded = Decoded("TIFF", plane.array, meta, max(source.count, plane.planes), tags, notes, plane.channel_chosen)
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
    from .pages import find_data_page

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
    top = alpha_scale(cmyk.dtype)
    inks = cmyk[..., :4].astype(np.float32) / np.float32(top)
    rgb = (1 - inks[..., :3]) * (1 - inks[..., 3:4])
    return rgb * np.float32(top)






def _reduce_axes(path, array, axes, page, z_slice, channel, meta) -> Plane:
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
    return Plane(array, planes, notes, chosen)


def _pick_channel(path, array, axes, channel, meta, notes):
    index = channel_choice(path, array.shape[axes.index("C")], channel, meta=meta, notes=notes)
    return np.take(array, index, axis=axes.index("C")), axes.replace("C", "")




def _pick_z(path, array, axes, z_slice, notes):
    n = array.shape[axes.index("Z")]
    if z_slice is None:
        array = array.max(axis=axes.index("Z"))
        if n > 1:
            notes.append(Decision(f"z-stack of {n} slices: maximum-intensity projection⟦ (choose one slice with `z_slice`)⟧."))
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


def _read_dm(path, limits: Limits, file_bytes: int) -> Decoded:
    """The first 2-D plane of a DM3/DM4 file, its size checked before any pixel is decoded."""
    try:
        from rsciio.digitalmicrograph import file_reader
    except ImportError:
        from ..errors import install_hint

        raise MissingDependencyError(
            f"{path}: is a Gatan DigitalMicrograph (DM3/DM4) file; reading it needs rosettasciio, which comes with "
            f"the 'dm' extra: {install_hint('dm')}."
        ) from None
    try:
        item = file_reader(str(path), lazy=True)[0]  # lazy: the header's shape and dtype, no pixels yet
        data = item["data"]
        plane = data[(0,) * (data.ndim - 2)] if data.ndim > 2 else data
        check_size(path, plane.shape, limits)
        check_bytes(path, plane.shape, data.dtype, limits=limits, what="DigitalMicrograph plane")
        _check_cost(path, plane.shape, plane.shape, data.dtype, limits)
        array = np.asarray(plane)
    except (InputError, ParameterError):
        raise
    except Exception as exc:
        raise InputError(f"{path}: a damaged DM3/DM4 file ({exc}).") from None
    if array.ndim != 2:
        raise InputError(f"{path}: the DM3/DM4 image has shape {array.shape}; expected a 2-D image.")
    return Decoded("DM", array, {"dm_axes": item.get("axes", []), "dm_metadata": item.get("metadata", {})}, 1)


def _open_pillow(stream):
    """Open an image with Pillow's format plugins, reading only its header.

    `Image.open` checks the size against the process-wide `Image.MAX_IMAGE_PIXELS`; changing
    that per call would race between the web app's conversion threads. Calling the registered
    plugin factories directly skips that check, and `check_size` applies ours instead.
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


def _read_pillow(path, head, page, limits: Limits) -> Decoded:
    from PIL import UnidentifiedImageError

    fmt = "image"
    stream = None
    try:
        stream = open(path, "rb")  # Pillow reads the file as it decodes; its bytes are never held twice
        im = _open_pillow(stream)
        fmt = im.format or "image"
        hw = (im.size[1], im.size[0])
        check_size(path, hw, limits)
        check_bytes(path, (*hw, *_pillow_samples(im.mode)), np.uint8, limits=limits, what=f"{fmt} image")
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
    return Decoded(fmt, array, meta, frames, notes=notes)


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
















