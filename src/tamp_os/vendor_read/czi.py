"""Zeiss CZI through czifile: one plane at a time, from the subblocks that hold it.

Why czifile: it read all three fixtures correctly (Gray8, Gray16, T×C and mosaic layouts), is
pure Python over imagecodecs (already a dependency; 0.2 MB installed), and lets us decode only
the subblocks of the chosen plane. pylibCZIrw (libCZI) reads planes natively too but needs
12 MB and an extra dependency (`validators`); bioio + bioio-czi resolve to 61 packages here
(pandas, xarray, aiohttp, cmake, and both pylibCZIrw and aicspylibczi).
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


def open_czi(path, scene: int | None) -> Stack:
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
        s = check_index(path, "scene", scene, scenes, "scene")

        def index(block, axis):
            return int(block.start[axes.index(axis)]) - start[axes.index(axis)] if axis in axes else 0

        mine = [b for b in blocks if index(b, "S") == s]
        y0 = min(index(b, "Y") for b in mine)
        x0 = min(index(b, "X") for b in mine)
        height = max(index(b, "Y") + b.shape[axes.index("Y")] for b in mine) - y0
        width = max(index(b, "X") + b.shape[axes.index("X")] for b in mine) - x0
        samples = int(czi.shape[axes.index("0")]) if "0" in axes else 1
        sizes = {a: int(czi.shape[axes.index(a)]) for a in "TCZ" if a in axes}
        xml = czi.metadata()
    except Exception:
        czi.close()
        raise
    root = ET.fromstring(xml)
    pixel, key = _pixel_size(root)
    z_step = _distance(root, "Z")
    dtype = np.dtype(czi.dtype)

    def plane(t: int, c: int, z: int) -> np.ndarray:
        out = np.zeros((height, width) + ((samples,) if samples > 1 else ()), dtype)
        hits = [b for b in mine if index(b, "T") == t and index(b, "C") == c and index(b, "Z") == z]
        if not hits:
            raise ValueError(f"no subblock holds t={t}, c={c}, z={z}")
        for block in hits:
            data = block.data_segment().data()
            tile = data.reshape(data.shape[axes.index("Y")], data.shape[axes.index("X")], -1)
            if samples >= 3:
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
