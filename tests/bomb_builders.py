"""Small files that cost a lot to read (issue 51), built in a few milliseconds each: shared by the
tests (tests/read/test_guards_51.py) and benchmarks/bench_guards.py.

A compressed chunk of zeros is assembled from one deflate block repeated, not by compressing
gigabytes: after a full flush, deflate's output for the same input is the same bytes, so the
stream is the zlib header, that block K times, the tail, and the Adler-32 of N zeros (a = 1,
b = N mod 65521).
"""

from __future__ import annotations

import bz2
import functools
import re
import struct
import zlib
from pathlib import Path

import numpy as np

BLOCK_BYTES = 1 << 24  # zeros per repeated deflate block
ADLER_MOD = 65521


def zlib_zeros(n_bytes: int) -> bytes:
    """A zlib stream (RFC 1950, what HDF5's deflate filter and numcodecs' Zlib write) of `n_bytes` zeros."""
    packer = zlib.compressobj(9)
    header_and_first = packer.compress(bytes(BLOCK_BYTES)) + packer.flush(zlib.Z_FULL_FLUSH)
    repeated = packer.compress(bytes(BLOCK_BYTES)) + packer.flush(zlib.Z_FULL_FLUSH)
    blocks, tail = divmod(n_bytes, BLOCK_BYTES)
    if blocks == 0:
        return zlib.compress(bytes(n_bytes), 9)
    last = packer.compress(bytes(tail)) + packer.flush()
    adler = struct.pack(">I", ((n_bytes % ADLER_MOD) << 16) | 1)
    return header_and_first + repeated * (blocks - 1) + last[:-4] + adler


def ome_zarr_in_one_chunk(path: Path, side_px: int, shape=(1, 1, 64, 64)) -> Path:
    """An OME-Zarr (v2) folder whose small array sits in one written side_px² zlib chunk of zeros."""
    import json

    array = path / "0"
    array.mkdir(parents=True)
    chunks = [1] * (len(shape) - 2) + [side_px, side_px]
    (path / ".zgroup").write_text(json.dumps({"zarr_format": 2}))
    (path / ".zattrs").write_text(json.dumps({"multiscales": [{"version": "0.4", "axes": [
        {"name": "c", "type": "channel"}, {"name": "z", "type": "space", "unit": "micrometer"},
        {"name": "y", "type": "space", "unit": "micrometer"}, {"name": "x", "type": "space", "unit": "micrometer"}],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 0.5, 0.5]}]}]}]}))
    (array / ".zarray").write_text(json.dumps({
        "zarr_format": 2, "shape": list(shape), "chunks": chunks, "dtype": "|u1", "fill_value": 0, "order": "C",
        "filters": None, "dimension_separator": ".", "compressor": {"id": "zlib", "level": 9}}))
    (array / ".".join("0" * len(shape))).write_bytes(zlib_zeros(side_px * side_px))
    return path


def velox_in_one_chunk(path: Path, template: Path, side_px: int, shape=(64, 64, 1)) -> Path:
    """A copy of the Velox EMD `template` whose image is a small array in one written side_px² gzip
    (deflate) chunk of zeros: rosettasciio reads it as the real file, the chunk included."""
    import shutil

    import h5py

    shutil.copyfile(template, path)
    path.chmod(0o644)
    with h5py.File(path, "r+") as f:
        group = f[next(name for name in _datasets(f) if name.endswith("/Data"))].parent
        dtype = group["Data"].dtype
        del group["Data"]
        chunks = (side_px, side_px) + (1,) * (len(shape) - 2)
        data = group.create_dataset("Data", shape=shape, maxshape=(None,) * len(shape), dtype=dtype, chunks=chunks,
                                    compression="gzip")
        data.id.write_direct_chunk((0,) * len(shape), zlib_zeros(side_px * side_px * dtype.itemsize))
    return path


def _datasets(h5) -> list[str]:
    names: list[str] = []
    h5.visit(names.append)
    return [n for n in names if n.startswith("Data/Image/")]


BZ2_BLOCK_MAGIC = format(0x314159265359, "048b")  # π: a block starts here (bit-aligned)
BZ2_END_MAGIC = format(0x177245385090, "048b")  # √π: the stream ends, then its combined CRC
BZ2_FULL_BLOCK_ZEROS = 46_000_000  # more than one level-9 block holds (900 kB after run-length coding)


def _bz2_blocks(data: bytes) -> list[str]:
    """The blocks of bzip2(data) as bit strings (magic, CRC, body): bzip2 blocks are bit-aligned."""
    packed = bz2.compress(data, 9)
    bits = format(int.from_bytes(packed[4:], "big"), f"0{8 * (len(packed) - 4)}b")
    starts = [m.start() for m in re.finditer(BZ2_BLOCK_MAGIC, bits)]
    return [bits[a:b] for a, b in zip(starts, starts[1:] + [bits.rfind(BZ2_END_MAGIC)])]


def _bz2_stream(blocks: list[str]) -> bytes:
    combined = 0
    for block in blocks:  # the stream CRC: rotate left by one, then xor each block's CRC
        combined = (((combined << 1) | (combined >> 31)) & 0xFFFFFFFF) ^ int(block[48:80], 2)
    bits = "".join(blocks) + BZ2_END_MAGIC + format(combined, "032b")
    bits += "0" * (-len(bits) % 8)
    return b"BZh9" + int(bits, 2).to_bytes(len(bits) // 8, "big")


@functools.lru_cache(maxsize=1)
def _bz2_zero_block() -> tuple[str, int]:
    """One full bzip2 block of zeros and the number of zeros it holds (about 1 s, once)."""
    block = _bz2_blocks(bytes(BZ2_FULL_BLOCK_ZEROS))[0]
    return block, len(bz2.decompress(_bz2_stream([block])))


def bzip2_zeros(prefix: bytes, n_zeros: int) -> tuple[bytes, int]:
    """A bzip2 stream of `prefix`, then about `n_zeros` zeros (a whole number of blocks, at most one
    block fewer), and its decompressed size: one block of zeros repeated, so 2 GB takes a millisecond."""
    block, per_block = _bz2_zero_block()
    count = max(1, n_zeros // per_block)
    return _bz2_stream(_bz2_blocks(prefix) + [block] * count), len(prefix) + count * per_block


def elid_zero_bomb(n_bytes: int = 2 * 10**9) -> bytes:
    """An ELID project (bzip2 of 'EID2', version 4, then zeros) that decompresses to about n_bytes: its
    header declares no image, so a reader that follows the declared layout reads 20 bytes of it."""
    return bzip2_zeros(b"EID2" + struct.pack("<i", 4), n_bytes)[0]


def checkerboard_png(path: Path, side_px: int = 1024, square_px: int = 4) -> Path:
    """A 1-bit checkerboard PNG (tens of kB): (side_px / square_px)² squares, each a region of its own."""
    from PIL import Image

    squares = (np.indices((side_px, side_px)) // square_px).sum(axis=0) % 2
    Image.fromarray((squares * 255).astype(np.uint8)).convert("1").save(path, optimize=True)
    return path


def czi_many_channels(path: Path, channels: int = 100, side_px: int = 64) -> Path:
    """A CZI of `channels` small noise planes, one named subblock each (uncompressed: cheap to build)."""
    from czi_builder import write_czi

    planes = np.random.default_rng(0).integers(0, 255, (channels, side_px, side_px), dtype=np.uint8)
    write_czi(path, planes, compression="none", names=[f"ch{i}" for i in range(channels)])
    return path


def tiff_in_one_tile(path: Path, tile_px: int, shape=(16, 16)) -> Path:
    """A small TIFF whose header declares one tile_px² zlib tile, and whose tile holds that many zeros."""
    import tifffile

    tifffile.imwrite(path, np.zeros(shape, np.uint8), tile=(16, 16), compression="zlib")
    with tifffile.TiffFile(path) as tif:
        tags, order = tif.pages[0].tags, tif.byteorder
        spots = {code: (tags[code].valueoffset, int(tags[code].dtype)) for code in (322, 323, 324, 325)}
    blob = zlib_zeros(tile_px * tile_px)
    with open(path, "r+b") as fh:
        end = fh.seek(0, 2)
        fh.write(blob)
        for code, value in ((322, tile_px), (323, tile_px), (324, end), (325, len(blob))):
            offset, dtype = spots[code]
            fh.seek(offset)
            fh.write(struct.pack(order + {3: "H", 4: "I", 16: "Q"}[dtype], value))
    return path


def elid_declaring_a_tiff(n_bytes: int, n_zeros: int = 0) -> bytes:
    """An ELID project declaring one image whose TIFF record is n_bytes long, followed by n_zeros zeros
    (not a TIFF): a reader that trusts the length decompresses all of it before tifffile says so."""
    head = b"EID2" + struct.pack("<iII", 4, 1, n_bytes)
    if not n_zeros:
        return bz2.compress(head, 9)
    return bzip2_zeros(head, n_zeros)[0]
