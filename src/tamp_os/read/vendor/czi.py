"""Zeiss CZI through czifile: one plane at a time, from the subblocks that hold it.

Why czifile: it read all three fixtures correctly (Gray8, Gray16, T×C and mosaic layouts), is
pure Python over imagecodecs (already a dependency; 0.2 MB installed), and lets us decode only
the subblocks of the chosen plane. pylibCZIrw (libCZI) reads planes natively too but needs
12 MB and an extra dependency (`validators`); bioio + bioio-czi resolve to 61 packages here
(pandas, xarray, aiohttp, cmake, and both pylibCZIrw and aicspylibczi).
Subblocks are decoded here, not by czifile: czifile 2019 fails on LZW under NumPy 2 (it calls the
removed `numpy.fromstring`) and knows no zstd; its releases from 2026 need Python 3.12. Both libCZI
readers (pylibCZIrw 6.1, aicspylibczi 4.0) refuse LZW ("not implemented", measured on the LZW CZI
that tests/czi_builder.py writes; they read its zstd files alike, and pylibCZIrw brings cmake, 86 MB,
as a run-time dependency), so czifile keeps parsing the directory and the XML and imagecodecs decodes
each stream: LZW, zstd (both Zeiss variants), JPEG and JPEG XR, every one priced from its
declared data size and shape (and a JPEG from its own frame header) before any byte is decoded.
Metadata is read from the CZI's XML: pixel size only from `Scaling/Items/Distance` (metres), never
from the `Pixel` items some files hold (value 1, no unit); channel names from
`Information/Image/Dimensions/Channels` or else `DisplaySetting/Channels`.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .model import Channel, Stack

KIND = "czi"


def open_czi(path, scene: int | None, limits=None) -> Stack:
    import czifile

    from .plan import check_index

    czi = czifile.CziFile(str(path))
    try:
        axes, start = czi.axes, [int(s) for s in czi.start]
        blocks = [b for b in czi.filtered_subblock_directory if tuple(b.shape) == tuple(b.stored_shape)]  # no pyramid copies
        if not blocks:
            raise ValueError("no image subblocks")
        file_bytes, end = Path(path).stat().st_size, _segments_end(path, czi.filtered_subblock_directory)
        if end > file_bytes:  # the directory lists image data beyond the end: the file was cut short
            raise EOFError(f"the file ends at byte {file_bytes:,} but its image data runs to byte {end:,}")
        scenes = czi.shape[axes.index("S")] if "S" in axes else 1
        s = check_index(path, "scene", scene, count=scenes, what="scene")

        def index(block, axis):
            return int(block.start[axes.index(axis)]) - start[axes.index(axis)] if axis in axes else 0

        mine = [b for b in blocks if index(b, "S") == s]
        y0 = min(index(b, "Y") for b in mine)
        x0 = min(index(b, "X") for b in mine)
        height = max(index(b, "Y") + b.shape[axes.index("Y")] for b in mine) - y0
        width = max(index(b, "X") + b.shape[axes.index("X")] for b in mine) - x0
        samples = int(czi.shape[axes.index("0")]) if "0" in axes else 1
        sizes = {a: int(czi.shape[axes.index(a)]) for a in "TCZ" if a in axes}
        segments = _subblocks(path, mine, file_bytes)
        if limits is not None:
            _price(path, mine, segments, (height, width), samples, limits)
        xml = czi.metadata()
    except Exception:
        czi.close()
        raise
    root = ET.fromstring(xml)
    pixel, key = _pixel_size(root)
    z_step = _distance(root, "Z")
    dtype = np.dtype(czi.dtype).base  # Bgr24 is '<3u1' in czifile: one sample's type, the samples are an axis

    def plane(t: int, c: int, z: int) -> np.ndarray:
        out = np.zeros((height, width) + ((samples,) if samples > 1 else ()), dtype)
        hits = [b for b in mine if index(b, "T") == t and index(b, "C") == c and index(b, "Z") == z]
        if not hits:
            raise ValueError(f"no subblock holds t={t}, c={c}, z={z}")
        for block in hits:
            data = decode(block, segments[id(block)])
            tile = data.reshape(data.shape[axes.index("Y")], data.shape[axes.index("X")], -1)
            if samples >= 3 and block.compression != JPEGXR:  # JPEG XR decodes to RGB (as czifile reads it)
                tile = tile[..., 2::-1] if samples == 3 else tile[..., [2, 1, 0, 3]]  # CZI stores BGR
            y, x = index(block, "Y") - y0, index(block, "X") - x0
            out[y : y + tile.shape[0], x : x + tile.shape[1]] = tile if samples > 1 else tile[..., 0]
        return out

    return Stack(
        format="Zeiss CZI", reader=f"czifile {czifile.__version__}", sizes=sizes, dtype=dtype, height=height,
        width=width, plane=plane, scenes=scenes, scene=s, channels=_channels(root, sizes.get("C", 1)),
        pixel_size_m=pixel, pixel_size_key=key, z_step_m=z_step if sizes.get("Z", 1) > 1 else None,
        z_key="Scaling/Items/Distance[@Id='Z']/Value" if z_step else "", samples=samples,
        metadata={"czi_document_name": _text(root, ".//Information/Document/Name")}, close=czi.close,
    )


# DirectoryEntryDV.compression: 0 none, 1 JPEG, 2 LZW, 4 JPEG XR, 5 zstd, 6 zstd with a header
# (libCZI's "zstd0" and "zstd1"); 100 and up are camera-specific raw formats nobody documents.
JPEG, LZW, JPEGXR, ZSTD0, ZSTD1 = 1, 2, 4, 5, 6
COMPRESSIONS = {0: "uncompressed", JPEG: "JPEG", LZW: "LZW", JPEGXR: "JPEG XR", ZSTD0: "zstd", ZSTD1: "zstd"}


def _subblocks(path, blocks, file_bytes: int) -> dict:
    """Each block's subblock segment header (czifile's SubBlockSegment: data offset and declared data size),
    checked against the file: a size that runs past the end is damage, not a reason to allocate."""
    segments = {}
    for i, block in enumerate(blocks):
        seg = block.data_segment()
        end = int(seg.data_offset) + int(seg.data_size)
        if seg.data_size < 0 or end > file_bytes:
            raise EOFError(f"subblock {i} declares {int(seg.data_size):,} bytes of image data from byte {int(seg.data_offset):,}, "
                           f"but the file ends at byte {file_bytes:,}")
        segments[id(block)] = seg
    return segments


def _stored_bytes(block) -> float:
    """Bytes of a subblock as the directory declares it (stored shape × sample bytes)."""
    return float(np.prod([float(n) for n in block.stored_shape])) * np.dtype(block.dtype).base.itemsize


def _price(path, blocks, segments, plane_hw, samples, limits) -> None:
    """Refuse, before decoding, a subblock whose stream would decode to more than `max_decoded_gb`: its
    compressed bytes (read whole) plus what it decodes to, from its declared shape or, for JPEG, the larger
    of that and its frame header (a 16×16 subblock may hold a 30000×30000 JPEG, which the decoder decodes whole)."""
    from ...errors import InputError
    from ..cost import (JPEG_HEAD_BYTES, MAX_STREAMS_LOOKED_AT, Cost, check_memory, jpeg_frame, jpeg_frame_bytes,
                             jpegxr_frame, working_bytes)

    largest, which, why = 0.0, 0, ""
    with open(path, "rb") as fh:
        for i, block in enumerate(blocks):
            seg = segments[id(block)]
            decoded, frame = _stored_bytes(block), ""
            if block.compression in (JPEG, JPEGXR) and i < MAX_STREAMS_LOOKED_AT:
                fh.seek(int(seg.data_offset))
                head = fh.read(min(int(seg.data_size), JPEG_HEAD_BYTES))
                if block.compression == JPEG and jpeg_frame_bytes(head) > decoded:
                    h, w = jpeg_frame(head)[:2]
                    decoded, frame = jpeg_frame_bytes(head), f"a JPEG stream whose frame header says {w}×{h} pixels"
                xr = jpegxr_frame(head) if block.compression == JPEGXR else None
                pixel_bytes = decoded / max(float(np.prod([float(n) for n in block.stored_shape[:-1]])), 1.0)
                if xr and xr[0] * xr[1] * pixel_bytes > decoded:  # the container's own size, at the block's bytes per pixel
                    decoded, frame = xr[0] * xr[1] * pixel_bytes, f"a JPEG XR stream whose header says {xr[1]}×{xr[0]} pixels"
            in_flight = decoded + (float(seg.data_size) if block.compression else 0.0)  # the stream is read whole first
            if in_flight > largest:
                largest, which, why = in_flight, i, frame
    if largest > limits.max_decoded_gb * 1e9:
        block = blocks[which]
        shape = "×".join(str(int(n)) for n in block.stored_shape[:-1] if int(n) > 1) or "1"
        declared = why or f"a {shape} {COMPRESSIONS.get(block.compression, 'compressed')} stream"
        raise InputError(
            f"{path}: subblock {which} of this Zeiss CZI declares {declared}, {int(segments[id(block)].data_size):,} bytes stored; "
            f"decoding it would take {largest / 1e9:.1f} GB, above the limit of {limits.max_decoded_gb:g} GB (`max_decoded_gb`) "
            f"that guards against decompression bombs. The file is malformed or hostile, or a very large tile: re-export it "
            f"from ZEN; if you trust it and the computer has the memory, raise `max_decoded_gb` to {int(largest / 1e9) + 1}.",
        )
    cost = Cost()
    cost.add("decoded pixels", float(plane_hw[0]) * plane_hw[1] * samples * np.dtype(blocks[0].dtype).base.itemsize)
    cost.add("subblock being decoded", largest)
    cost.add("float32 working arrays", working_bytes(*plane_hw))
    check_memory(path, f"{plane_hw[1]}×{plane_hw[0]} image", cost, max_memory_gb=limits.max_memory_gb)


def decode(block, seg) -> np.ndarray:
    """One subblock's pixels, shaped as stored, from its stream (priced and bounds-checked at open).

    LZW and zstd decode into a buffer of the declared size, never more; a stream that decodes to
    another size than the directory declares is damaged."""
    import imagecodecs

    dtype = np.dtype(block.dtype).base
    expected = int(_stored_bytes(block))
    raw = seg.data(raw=True)
    kind = block.compression
    if kind == 0:
        buffer = raw
    elif kind == LZW:
        buffer = imagecodecs.lzw_decode(raw, out=expected)
    elif kind in (ZSTD0, ZSTD1):
        buffer = _zstd(raw, kind, expected, dtype)
    elif kind == JPEG:
        buffer = imagecodecs.jpeg8_decode(raw)
    elif kind == JPEGXR:
        buffer = imagecodecs.jpegxr_decode(raw)
    else:
        raise NotImplementedError(f"subblock compression {kind}, a camera-specific raw format")
    if isinstance(buffer, np.ndarray):  # JPEG, JPEG XR: an image; its bytes are the subblock's
        buffer = np.ascontiguousarray(buffer).reshape(-1).view(np.uint8)
    data = np.frombuffer(buffer, np.uint8)
    if data.nbytes == expected:
        data = data.view(dtype)
    if data.nbytes != expected:
        raise ValueError(f"a {COMPRESSIONS.get(kind, kind)} subblock decodes to {data.nbytes:,} bytes, its directory says {expected:,}")
    return data.reshape(block.stored_shape)


def _zstd(raw: bytes, kind: int, expected: int, dtype: np.dtype):
    """Zeiss zstd: 'zstd0' is a plain zstd stream; 'zstd1' starts with a header (its size in the first byte,
    then chunks: type 1 = one byte, whether 16-bit pixels were split into all low bytes, then all high)."""
    import imagecodecs

    hilo, start = False, 0
    if kind == ZSTD1:
        start = raw[0] if raw else 0
        at = 1
        while at < start:
            if raw[at] == 1 and at + 1 < start:
                hilo, at = bool(raw[at + 1] & 1), at + 2
            else:
                raise ValueError(f"unknown zstd header chunk {raw[at]}")
    buffer = imagecodecs.zstd_decode(raw[start:], out=expected)
    if hilo and dtype.itemsize == 2 and len(buffer) == expected:
        half = np.frombuffer(buffer, np.uint8)
        n = half.size // 2
        return (half[:n].astype(np.uint16) | (half[n:].astype(np.uint16) << 8)).astype("<u2").tobytes()
    return buffer


def number(text) -> float | None:
    """A finite float from the XML text, else None (read comes before clean: no import from there)."""
    try:
        value = float(str(text).strip())
    except (TypeError, ValueError):
        return None
    return value if np.isfinite(value) else None


SEGMENT_HEADER = 32  # 16-byte id, then allocated and used sizes (int64 each)


def _segments_end(path, entries) -> int:
    """Where the last subblock segment ends, from each segment's own header (sizes are not in the directory)."""
    import struct

    end = 0
    with open(path, "rb") as fh:
        for entry in entries:
            fh.seek(int(entry.file_position))
            head = fh.read(SEGMENT_HEADER)
            if len(head) < SEGMENT_HEADER:
                return int(entry.file_position) + SEGMENT_HEADER
            _allocated, used = struct.unpack("<qq", head[16:32])
            end = max(end, int(entry.file_position) + SEGMENT_HEADER + used)
    return end


def _text(root, path: str) -> str:
    el = root.find(path)
    return (el.text or "").strip() if el is not None else ""


def _distance(root, axis: str) -> float | None:
    for el in root.iterfind(".//Scaling/Items/Distance"):
        if el.get("Id") == axis:
            value = number(_text(el, "Value"))
            return value if value and value > 0 else None
    return None


def _pixel_size(root) -> tuple[tuple[float, float] | None, str]:
    x, y = _distance(root, "X"), _distance(root, "Y")
    if x is None:
        return None, ""
    return (x, y or x), "Scaling/Items/Distance[@Id='X'/'Y']/Value"


def _channels(root, count: int) -> list[Channel]:
    dims = list(root.iterfind(".//Information/Image/Dimensions/Channels/Channel"))
    shown = list(root.iterfind(".//DisplaySetting/Channels/Channel"))
    out = []
    for i in range(count):
        d = dims[i] if i < len(dims) else None
        name = (d.get("Name") if d is not None else None) or (shown[i].get("Name") if i < len(shown) else None) or f"channel {i}"
        ex = number(_text(d, "ExcitationWavelength")) if d is not None else None
        em = number(_text(d, "EmissionWavelength")) if d is not None else None
        out.append(Channel(name, round(ex, 1) if ex else None, round(em, 1) if em else None))
    return out
