"""What reading and converting an image will really cost in memory, priced from its header.

A header's pixel count is not the cost: a TIFF may declare a 16×16 image stored in one
65520×65520 tile (the decoder allocates the whole tile), a palette PNG becomes an RGBA copy,
Pillow's pixels are copied once more into NumPy, and the pipeline keeps float32 working arrays
of the full image. Each of those is priced here, before any pixel is decoded, so an image that
would not fit is refused with one message instead of a MemoryError (or a swapping machine).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

from ..errors import InputError

# Peak bytes per source pixel that the pipeline holds after reading (the float32 grey values,
# the alpha weights, and the full-resolution copies made while cleaning and stretching), measured
# with the real process peak (ru_maxrss) on 16 and 36 Mpx grey and RGB PNGs: 26–29 bytes per
# pixel above the decoded pixels. Rounded up so the estimate errs on the safe side.
WORKING_BYTES_PER_PX = 32
# The reader's own objects (parsed pages and tags, Python objects): measured under 1 MB for a
# one-page TIFF whose tile alone costs 1.6 GB; priced so the estimate covers the whole read.
READER_BYTES = 4e6
MAX_MEMORY_GB = 4.0  # default: the whole conversion's estimated peak


@dataclass
class Cost:
    """The memory a read (and the conversion after it) is expected to need, in bytes, by part."""

    parts: dict[str, float] = field(default_factory=dict)

    def add(self, what: str, n_bytes: float) -> None:
        if n_bytes > 0:
            self.parts[what] = self.parts.get(what, 0.0) + float(n_bytes)

    @property
    def total(self) -> float:
        return sum(self.parts.values())

    def words(self) -> str:
        return ", ".join(f"{what} {n / 1e9:.2f} GB" for what, n in self.parts.items())


def working_bytes(height_px: int, width_px: int) -> float:
    """The pipeline's float32 working arrays for an image of this size."""
    return float(height_px) * float(width_px) * WORKING_BYTES_PER_PX


def check_memory(path, size_words: str, cost: Cost, *, max_memory_gb: float) -> None:
    """Refuse, before decoding, a read whose estimated peak exceeds `max_memory_gb`."""
    if cost.total > max_memory_gb * 1e9:
        raise InputError(
            f"{path}: converting this {size_words} would need about {cost.total / 1e9:.1f} GB of memory "
            f"({cost.words()}), above the limit of {max_memory_gb:g} GB that guards this computer. Make the image smaller.",
            hint=f"If the computer has the memory, raise the limit, for example `max_memory_gb` {math.ceil(cost.total / 1e9)}."
        )


def tiff_chunk_bytes(page) -> float:
    """Bytes of the tiles (or strips) tifffile decodes at once for `page`: one chunk as declared
    (not clipped to the image), and the largest compressed chunk it reads to decode it, per
    decoding thread."""
    chunks = getattr(page, "chunks", None)
    if not chunks:
        return 0.0
    try:
        compressed = max((int(n) for n in page.databytecounts), default=0) if int(page.compression) != 1 else 0
    except Exception:  # a broken byte-count tag: tifffile reports it when it reads
        compressed = 0
    one = math.prod(int(n) for n in chunks) * page.dtype.itemsize + compressed
    try:
        count = math.prod(int(n) for n in page.chunked)
    except Exception:  # a broken strip count: at least one chunk is decoded
        count = 1
    threads = max(1, min(count, int(getattr(page, "maxworkers", 1) or 1), os.cpu_count() or 1))
    return float(one) * threads


def pillow_copies_bytes(mode: str, pixels: int) -> float:
    """Bytes of the copies made of a Pillow image before it becomes float32: the RGB/RGBA
    conversion of palette and colour-model images, and the NumPy copy of Pillow's pixels."""
    from PIL import ImageMode

    if mode in ("P", "PA", "CMYK", "YCbCr", "LAB", "HSV", "1"):
        converted = 4 if mode in ("P", "PA") else 3 if mode != "1" else 1
        return float(pixels) * converted * 2  # the converted image, then its NumPy copy
    info = ImageMode.getmode(mode)
    import numpy as np

    return float(pixels) * len(info.bands) * np.dtype(info.typestr).itemsize  # the NumPy copy


JPEG_CODES = (6, 7, 34892)  # TIFF compressions whose chunks are JPEG streams
SOF_MARKERS = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}  # start-of-frame: baseline, progressive, lossless…
JPEG_FIRST_BYTES = 4096  # a frame header usually sits within the first kilobyte, after the tables
JPEG_HEAD_BYTES = 65536  # ... and within this when APP segments come first
MAX_STREAMS_LOOKED_AT = 4096


def jpeg_frame_bytes(head: bytes) -> float:
    """Decoded bytes (height × width × components, at least one byte each) that a JPEG stream's
    frame header declares, or 0 when `head` holds none. Walks the marker segments; never decodes."""
    frame = jpeg_frame(head)
    if frame is None:
        return 0.0
    height, width, components, precision = frame
    return float(height) * width * max(1, components) * (2 if precision > 8 else 1)


def jpeg_frame(head: bytes) -> tuple[int, int, int, int] | None:
    """(height, width, components, precision) from a JPEG stream's frame header (SOF), or None."""
    at = 2 if head[:2] == b"\xff\xd8" else 0
    while at + 4 <= len(head):
        if head[at] != 0xFF:
            return None
        marker = head[at + 1]
        if marker == 0xFF:  # fill byte
            at += 1
            continue
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:  # markers without a length
            at += 2
            continue
        length = int.from_bytes(head[at + 2:at + 4], "big")
        if marker in SOF_MARKERS and at + 10 <= len(head):
            height = int.from_bytes(head[at + 5:at + 7], "big")
            width = int.from_bytes(head[at + 7:at + 9], "big")
            return height, width, head[at + 9], head[at + 4]
        if length < 2:
            return None
        at += 2 + length
    return None


JPEGXR_WIDTH, JPEGXR_HEIGHT = 0xBC80, 0xBC81  # tags of the JPEG XR container's (TIFF-like) IFD


def jpegxr_frame(head: bytes) -> tuple[int, int] | None:
    """(height, width) from a JPEG XR container's IFD ('II\\xbc\\x01', then the IFD offset), or None."""
    import struct

    if head[:4] != b"II\xbc\x01" or len(head) < 8:
        return None
    at = struct.unpack("<I", head[4:8])[0]
    if at + 2 > len(head):
        return None
    found = {}
    for i in range(min(struct.unpack("<H", head[at:at + 2])[0], 256)):
        entry = head[at + 2 + 12 * i:at + 14 + 12 * i]
        if len(entry) < 12:
            break
        tag, kind, _count, value = struct.unpack("<HHII", entry)
        if tag in (JPEGXR_WIDTH, JPEGXR_HEIGHT):
            found[tag] = value & 0xFFFF if kind == 3 else value  # SHORT values sit in the low half
    if len(found) < 2:
        return None
    return found[JPEGXR_HEIGHT], found[JPEGXR_WIDTH]


def tiff_jpeg_bytes(path, page) -> float:
    """The largest frame that any JPEG-compressed chunk of `page` declares, in decoded bytes: a
    16×16 tile may hold a JPEG stream of 65000×65000, which the decoder decodes whole.
    `path` is the TIFF file, or a binary file object holding it (a TIFF embedded in another file)."""
    import contextlib

    if int(getattr(page, "compression", 0)) not in JPEG_CODES:
        return 0.0
    offsets, counts = page.dataoffsets, page.databytecounts
    largest = 0.0
    with contextlib.ExitStack() as stack:
        fh = path if hasattr(path, "read") else stack.enter_context(open(path, "rb"))
        for offset, count in list(zip(offsets, counts))[:MAX_STREAMS_LOOKED_AT]:
            if not count:
                continue
            fh.seek(offset)
            found = jpeg_frame_bytes(fh.read(min(int(count), JPEG_FIRST_BYTES)))
            if not found and count > JPEG_FIRST_BYTES:  # tables or padding before the frame: look further
                fh.seek(offset)
                found = jpeg_frame_bytes(fh.read(min(int(count), JPEG_HEAD_BYTES)))
            largest = max(largest, found)
    return largest


# Copies of one chunk a decoder holds at its peak, measured (VmHWM above the process before the read)
# on a 64×64 array stored in one 10000² chunk of zeros: zarr 1.9× the decoded chunk (numcodecs' decoded
# buffer, then the array it is copied into), HDF5 0.95× (the deflate filter's output buffer, from which
# the selection is copied). Each also holds the compressed chunk it read, up to the decoded size for
# data that does not compress: one copy more. The price is the decoded chunk times these.
ZARR_CHUNK_COPIES = 3
HDF5_CHUNK_COPIES = 2
# A chunk may be larger than its array (a pyramid's small levels keep the writer's chunk size; h5py
# may round a chunk up), but a chunk far larger than the data it holds is never needed: past both of
# these, its bytes are a decompression bomb's, whatever the cap.
CHUNK_PAST_DATA_RATIO = 8.0
CHUNK_PAST_DATA_FREE_BYTES = 64e6


def chunk_bytes(shape, chunks, itemsize: int, *, copies: int = 1) -> float:
    """Bytes a decoder holds for the chunks (HDF5, Zarr) decoded at once: one chunk as declared, not
    clipped to the array (a decoder allocates it whole, even when it is far larger than the array),
    times the `copies` of it the decoder holds, once per thread that may decode one at the same time
    (at most one per chunk)."""
    if not chunks:
        return 0.0
    one = math.prod(float(n) for n in chunks) * itemsize
    count = math.prod(max(1, math.ceil(int(s) / max(1, int(c)))) for s, c in zip(shape, chunks)) if shape else 1
    return one * copies * max(1, min(count, os.cpu_count() or 1))


def chunk_data_bytes(shape, chunks, itemsize: int) -> float:
    """Bytes of data one chunk can hold: the chunk clipped to the array along each axis."""
    return math.prod(float(min(int(c), max(int(s), 1))) for s, c in zip(shape, chunks)) * itemsize


def chunk_past_data(shape, chunks, itemsize: int) -> bool:
    """Whether one chunk is far larger than the data it can hold (check_chunk_fits refuses it)."""
    if not chunks or len(chunks) != len(shape):
        return False
    one = math.prod(float(n) for n in chunks) * itemsize
    return one > CHUNK_PAST_DATA_FREE_BYTES and one > CHUNK_PAST_DATA_RATIO * chunk_data_bytes(shape, chunks, itemsize)


def check_chunk_fits(path, what: str, shape, *, chunks, itemsize: int, todo: str, whole: str = "file") -> None:
    """Refuse, before decoding, a chunk far larger than the array it holds (a 64×64 image in one
    40000×40000 chunk): it costs its whole size to decode, under the cap or not, for data a chunk
    the array's size would hold."""
    if chunk_past_data(shape, chunks, itemsize):
        one, data = math.prod(float(n) for n in chunks) * itemsize, chunk_data_bytes(shape, chunks, itemsize)
        dims = "×".join(str(int(n)) for n in shape) or "scalar"
        raise InputError(
            f"{path}: {what} is a {dims} array stored in chunks of {'×'.join(str(int(n)) for n in chunks)} values: "
            f"each decodes to {_gb(one)} for {_gb(data)} of data ({one / max(data, 1.0):,.0f} times as much; a chunk larger "
            f"than its array is never needed, and a decoder allocates all of it). The {whole} is malformed or hostile; {todo}."
        )


def _gb(n_bytes: float) -> str:
    return f"{n_bytes / 1e9:.2g} GB" if n_bytes >= 1e8 else f"{n_bytes / 1e6:.2g} MB" if n_bytes >= 1e5 else f"{n_bytes:,.0f} bytes"


def check_chunk(path, what: str, shape, *, chunks, itemsize: int, n_bytes: float, max_decoded_gb: float, todo: str,
                whole: str = "file") -> None:
    """Refuse, before decoding, a store whose chunks cost more than `max_decoded_gb` to decode at once
    (`n_bytes`: chunk_bytes, the copies the decoder holds and its threads included)."""
    if n_bytes > max_decoded_gb * 1e9:
        dims = "×".join(str(int(n)) for n in shape) or "scalar"
        one = math.prod(float(n) for n in chunks) * itemsize
        raise InputError(
            f"{path}: {what} is stored in chunks of {'×'.join(str(int(n)) for n in chunks)} values, {_gb(one)} each decoded; "
            f"decoding them holds {_gb(n_bytes)} (a decoder allocates a whole chunk, whatever the {dims} size of the data, and "
            f"keeps copies of it), above the limit of {max_decoded_gb:g} GB that guards against decompression bombs. The {whole} "
            f"is malformed or hostile; {todo}.",
            hint="The limit is `max_decoded_gb`; raise it only for a file you trust.",
        )


def check_declared(path, what: str, declared_words: str, *, declared_bytes: float, file_bytes: int, max_decoded_gb: float,
                   todo: str, capped: bool = True, holds: str = "") -> None:
    """Refuse, before reading, a header that declares more bytes than the file holds or (when
    `capped`: the bytes are decoded whole) more than the decoded-bytes cap allows. `holds` says
    what `file_bytes` counts ("the file holds (1,280 bytes)" by default)."""
    size = f"{declared_bytes / 1e9:,.1f} GB" if declared_bytes >= 1e8 else f"{declared_bytes / 1e9:.2g} GB"
    holds = holds or f"the file holds ({file_bytes:,} bytes)"
    if declared_bytes > file_bytes:
        raise InputError(
            f"{path}: {what} whose header declares {declared_words}, {size} in all, more than "
            f"{holds} (the limit for decoded data is {max_decoded_gb:g} GB): the file is damaged, truncated or "
            f"hostile; {todo}."
        )
    if capped and declared_bytes > max_decoded_gb * 1e9:
        raise InputError(
            f"{path}: {what} whose header declares {declared_words}, {size} in all, above the limit of "
            f"{max_decoded_gb:g} GB that guards against decompression bombs; {todo}.",
            hint=f"If you trust the file and the computer has the memory, raise the limit, for example `max_decoded_gb` "
                 f"{math.ceil(declared_bytes / 1e9)}.",
        )
