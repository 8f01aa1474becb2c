"""A minimal valid Zeiss CZI (ZISRAW) written from an array, for tests that need a CZI of a kind
the real fixtures are not: LZW, zstd or JPEG subblocks, or a hostile header.

Layout (ZISRAW: every segment is a 16-byte id, its allocated and used sizes, then its data, each
segment starting at a multiple of 32): the file header segment, one subblock per channel plane,
the subblock directory, then the metadata XML. The same layout czifile and libCZI read.
"""

from __future__ import annotations

import struct

import numpy as np

PIXEL_TYPES = {np.dtype("u1"): 0, np.dtype("<u2"): 1, np.dtype("<f4"): 2}
BGR24 = 3
COMPRESSION = {"none": 0, "jpeg": 1, "lzw": 2, "jpegxr": 4, "zstd0": 5, "zstd1": 6}


def _segment(sid: bytes, data: bytes) -> bytes:
    padded = data + bytes(-len(data) % 32)
    return sid.ljust(16, b"\0") + struct.pack("<qq", len(padded), len(data)) + padded


def _entry(pixel_type: int, position: int, compression: int, dims: list[tuple[str, int, int]]) -> bytes:
    """DirectoryEntryDV: 'DV', pixel type, file position, part, compression, pyramid, spare, dimensions."""
    out = struct.pack("<2siqiiB5si", b"DV", pixel_type, position, 0, compression, 0, bytes(5), len(dims))
    for name, start, size in dims:
        out += struct.pack("<4siifi", name.encode().ljust(4, b"\0"), start, size, float(start), size)
    return out


def encode(plane: np.ndarray, compression: str) -> bytes:
    import imagecodecs

    raw = np.ascontiguousarray(plane).tobytes()
    if compression == "lzw":
        return imagecodecs.lzw_encode(raw)
    if compression == "zstd0":
        return imagecodecs.zstd_encode(raw)
    if compression == "zstd1":  # a 3-byte header: its size, then chunk 1 (hi-lo byte packing) off
        return b"\x03\x01\x00" + imagecodecs.zstd_encode(raw)
    if compression == "jpeg":
        return imagecodecs.jpeg8_encode(plane)
    return raw


def write_czi(path, planes: np.ndarray, compression: str = "lzw", names=("DAPI", "GFP"), pixel_m: float | None = 2e-7,
              data: list[bytes] | None = None, data_sizes: list[int] | None = None, stored: tuple[int, int] | None = None):
    """Write `planes` (C, Y, X) or (C, Y, X, 3) as a CZI with axes C Y X, each channel one subblock.

    data : the subblocks' bytes as stored (default: `planes` encoded by `compression`).
    data_sizes : the data sizes the subblock headers declare (default: the true ones).
    stored : the (Y, X) the directory declares for each subblock (default: the planes' own).
    """
    planes = np.asarray(planes)
    colour = planes.ndim == 4
    pixel_type = BGR24 if colour else PIXEL_TYPES[planes.dtype]
    height, width = planes.shape[1:3]
    sy, sx = stored or (height, width)
    def dims(c):
        return [("X", 0, sx), ("Y", 0, sy), ("C", c, 1)]

    streams = data or [encode(p[..., ::-1] if colour else p, compression) for p in planes]  # CZI stores BGR
    code = COMPRESSION[compression]
    out = bytearray(_segment(b"ZISRAWFILE", bytes(512)))  # filled in at the end
    positions = []
    for c, stream in enumerate(streams):
        positions.append(len(out))
        entry = _entry(pixel_type, len(out), code, dims(c))
        size = len(stream) if data_sizes is None else data_sizes[c]
        head = struct.pack("<iiq", 0, 0, size) + entry
        out += _segment(b"ZISRAWSUBBLOCK", head + bytes(max(256 - len(head), 0)) + stream)
    directory = len(out)
    entries = b"".join(_entry(pixel_type, p, code, dims(c)) for c, p in enumerate(positions))
    out += _segment(b"ZISRAWDIRECTORY", struct.pack("<i", len(positions)) + bytes(124) + entries)
    metadata = len(out)
    out += _segment(b"ZISRAWMETADATA", struct.pack("<ii", len(_xml(names, pixel_m)), 0) + bytes(248) + _xml(names, pixel_m))
    header = struct.pack("<iiii16s16siqqiq", 1, 0, 0, 0, bytes(16), bytes(16), 0, directory, metadata, 0, 0)
    out[32:32 + len(header)] = header
    path.write_bytes(bytes(out))
    return path


def _xml(names, pixel_m) -> bytes:
    channels = "".join(f'<Channel Id="Channel:{i}" Name="{name}"/>' for i, name in enumerate(names))
    scaling = (f'<Scaling><Items><Distance Id="X"><Value>{pixel_m}</Value></Distance>'
               f'<Distance Id="Y"><Value>{pixel_m}</Value></Distance></Items></Scaling>') if pixel_m else ""
    return (f"<ImageDocument><Metadata><Information><Image><Dimensions><Channels>{channels}</Channels></Dimensions>"
            f"</Image></Information>{scaling}</Metadata></ImageDocument>").encode()


def four_channel_czi(path):
    """A CZI of four channels, three with structure (nuclei, lines, spots) and one flat: three are printed."""
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[:160, :200]
    planes = np.zeros((4, 160, 200), np.uint16)
    for cy, cx in ((40, 40), (50, 120), (110, 70), (120, 160)):
        planes[0] += (((yy - cy) ** 2 + (xx - cx) ** 2) < 200).astype(np.uint16) * 3000
    for k in range(5):
        planes[1][np.abs(yy - (20 + 30 * k)) < 2] = 2500
    for _ in range(60):
        y, x = rng.integers(5, 155), rng.integers(5, 195)
        planes[2][y - 1:y + 2, x - 1:x + 2] = 2000
    planes[3] = (rng.random((160, 200)) * 300 + 500).astype(np.uint16)
    write_czi(path, planes + 100, names=("DAPI", "GFP", "Cy5", "Mono"))
    return path
