"""The types the readers share (ImageFile, Picture, what a decoder hands over, the read's
limits and its checks) and the step from decoded pixels to a grey Picture: every reader (read/image.py,
read/stacks.py, read/vendor/) builds on these, and none of them imports another reader."""

from __future__ import annotations

import functools
import hashlib
import math
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Decision, InputError, ParameterError, Text
from .cost import CHUNK_PAST_DATA_FREE_BYTES, CHUNK_PAST_DATA_RATIO, MAX_MEMORY_GB


LUMA_601 = np.array([0.299, 0.587, 0.114], dtype=np.float32)


CHANNEL_NAMES = {"red": 0, "green": 1, "blue": 2, "alpha": 3}


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
class Decoded:
    """One decoder's result, before it becomes a Picture."""

    format: str
    array: np.ndarray  # (H, W) or (H, W, S)
    metadata: dict
    pages: int
    tiff_tags: dict[int, object] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    channel_chosen: bool = False  # a channel was already picked among the file's planes
    facts: dict = field(default_factory=dict)  # ImageFile fields the reader knows (axes, channel_names, ...)


DEFAULT_TARGET_PX = 2048  # pyramid level: the smallest at least this wide (prints use at most ~1000 grid points)


def sha256_of(path: Path) -> str:
    """SHA-256 of a file read by blocks (a 5 GB file with a small image never sits in memory), or
    of a folder's files (name and bytes, sorted: an OME-Zarr folder).

    A regular file's hash is remembered for as long as its identity, size and change times stay
    the same: one conversion reads a file several times (its picture, each colour channel, the
    recipe), and hashing a 44 MB slide costs 40 ms each time."""
    try:
        st = path.stat()
    except OSError:
        st = None  # reported by the reading below
    if st is not None and stat.S_ISREG(st.st_mode):
        return _file_sha256(str(path), (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns))
    return _sha256_uncached(path)


@functools.lru_cache(maxsize=64)
def _file_sha256(path: str, identity: tuple) -> str:
    return _sha256_uncached(Path(path))


def _sha256_uncached(path: Path) -> str:
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


def _bits(dtype: np.dtype) -> int:
    return 1 if dtype == bool else dtype.itemsize * 8


@dataclass(frozen=True)
class Limits:
    """The decompression-bomb guards: pixels in one plane, and decoded bytes of all planes read."""

    max_megapixels: float
    max_decoded_gb: float
    max_memory_gb: float = MAX_MEMORY_GB


def check_bytes(path, shape, dtype, *, limits: Limits, what: str = "image", chunk_bytes: float = 0.0) -> None:
    """Refuse, before decoding, an array of `shape` and `dtype` above the decoded-bytes limit.

    shape : every axis that will be decoded (planes, rows, columns, samples).
    chunk_bytes : the tiles or strips decoded at once, as declared (a tile may be far larger than the image).
    """
    itemsize = np.dtype(dtype).itemsize
    total = int(np.prod([int(n) for n in shape], dtype=np.float64)) * itemsize
    if chunk_bytes > total:  # a tile larger than the image: the decoder allocates the whole tile
        # far larger than the image, it is refused under the cap too: a tile the image's size holds it all
        past = chunk_bytes > CHUNK_PAST_DATA_FREE_BYTES and chunk_bytes > CHUNK_PAST_DATA_RATIO * total
        if past or chunk_bytes > limits.max_decoded_gb * 1e9:
            limit = (f"{chunk_bytes / max(total, 1):,.0f} times the image's own bytes, and a tile larger than its image is never "
                     f"needed" if past else f"that exceeds the limit of {limits.max_decoded_gb:g} GB that guards against "
                     f"decompression bombs")
            raise InputError(
                f"{path}: this {what} is stored in tiles (or strips) that decode to {chunk_bytes / 1e9:.1f} GB, far larger than "
                f"its {'×'.join(str(int(n)) for n in shape)} pixels; {limit}. The file is malformed or hostile; re-export it from "
                f"the microscope software."
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


def check_size(path, shape, limits: Limits) -> None:
    h, w = shape[0], shape[1]
    max_megapixels = limits.max_megapixels
    if h * w > max_megapixels * 1e6:
        raise InputError(
            f"{path}: the image claims {w}×{h} pixels ({h * w / 1e6:.0f} Mpx), above the limit of "
            f"{max_megapixels:g} Mpx that guards against decompression bombs.",
            hint=f"If you trust the file, raise the limit, for example `max_megapixels` {int(h * w / 1e6) + 1}.",
        )


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


def file_channel_names(meta) -> list[str]:
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
class Plane:
    array: np.ndarray  # (H, W) or (H, W, S)
    planes: int = 1  # planes the page index chose among
    notes: list[str] = field(default_factory=list)
    channel_chosen: bool = False


def channel_choice(path, n: int, channel, *, meta, notes) -> int:
    """The C index `channel` names among `n` (a number, an OME/ImageJ name, or luminance: 0 with a note)."""
    names = file_channel_names(meta)
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


def to_picture(decoded: Decoded, channel, *, name, sha, path, keep_colour: bool = False) -> Picture:
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
    array = within_float32(array, file.notes)
    if array.ndim == 3 and array.shape[-1] >= 3:
        file.colour_sample = colour_sample(array)
    values, alpha = grayscale(array, channel, name)
    values, alpha = _weigh_unknown(file, values, alpha)
    if file.nonfinite_pixels == h * w:
        raise InputError(f"{name}: every pixel is NaN or infinite; there is no image to print.")
    colour = array[..., :3] if keep_colour and array.ndim == 3 and array.shape[-1] >= 3 else None
    return Picture(values=values, alpha=alpha, file=file, colour=colour)


COLOUR_SAMPLE_PX = 512
FLOAT32_MAX = float(np.finfo(np.float32).max)


def within_float32(array: np.ndarray, notes: list) -> np.ndarray:
    """A float picture whose finite values reach past float32's range (±3.4e38), scaled by a power
    of two to a largest value of about 1 (exact: brightness is relative, the stretch undoes any
    scale); the values are read as float32 from here on, and ±1e299 became ±inf, then a plate
    refused as 'every pixel is NaN or infinite' (issue 51.6). Any other array is returned as it is."""
    if array.dtype.kind != "f" or array.dtype.itemsize <= 4:
        return array
    low, high = float(np.fmin.reduce(array, axis=None)), float(np.fmax.reduce(array, axis=None))  # NaN skipped, no copy
    if -FLOAT32_MAX <= low and high <= FLOAT32_MAX:  # the usual case ends here
        return array
    finite = np.abs(array[np.isfinite(array)])
    if not finite.size:
        return array
    _, exponent = np.frexp(float(finite.max()))
    notes.append(Decision(f"The values reach {float(finite.max()):.3g}, past what is read in single precision; they were all "
                 f"divided by 2^{int(exponent)} (brightness is relative, so the print is the same)."))
    return np.ldexp(array, -int(exponent))


def colour_sample(array: np.ndarray) -> np.ndarray:
    """Every k-th pixel of the colour samples (not alpha), at most COLOUR_SAMPLE_PX a side, 0..1."""
    step = max(1, -(-max(array.shape[:2]) // COLOUR_SAMPLE_PX))
    # One array, changed in place: the same numbers as a new array per step, without three more
    # fresh megabytes to fault in (4 ms of a 5 ms sample on an 8-bit RGB picture).
    rgb = array[::step, ::step, :3].astype(np.float32)
    np.nan_to_num(rgb, copy=False, nan=0.0, posinf=0.0, neginf=0.0)
    # 8 bits: full scale; 16-bit and float colour often fills only part of its range (12-bit cameras)
    top = 255.0 if array.dtype == np.uint8 else float(rgb.max()) if rgb.size else 1.0
    rgb /= np.float32(top if top > 0 else 1.0)
    return np.clip(rgb, 0, 1, out=rgb)


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


def alpha_scale(dtype) -> float:
    return float(np.iinfo(dtype).max) if np.dtype(dtype).kind in "ui" else 1.0


def grayscale(array, channel: str, name: str):
    """(values, alpha) from any pixel layout; values keep their full source precision in float."""
    if array.ndim == 2:
        if channel not in ("luminance", "0"):
            raise ParameterError(f"{name}: channel {channel} asked for, but the image has a single channel; use luminance.")
        return array.astype(np.float32), None
    n = array.shape[-1]
    has_alpha = n in (2, 4)
    alpha = array[..., -1].astype(np.float32) / alpha_scale(array.dtype) if has_alpha else None
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
