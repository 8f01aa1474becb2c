"""Issue 12 §2 and the rest of issue 14: decoded-bytes guard before decoding, preview pages
skipped (Olympus SIS), DigitalMicrograph TIFF tags, instrument facts, and the full-source mask."""

import struct
import time
import tracemalloc
import zlib

import numpy as np
import pytest
import tifffile

from conftest import need
from tamp_os.errors import InputError
from tamp_os.read import read_image


def _zero_tiled_tiff(path, shape, dtype, tile=(512, 512)):
    """A deflate-compressed tiled TIFF of zeros, written without ever holding the image in memory."""
    tiles = -(-shape[0] // tile[0]) * -(-shape[1] // tile[1])
    packed = zlib.compress(bytes(tile[0] * tile[1] * np.dtype(dtype).itemsize), 9)
    tifffile.imwrite(path, (packed for _ in range(tiles)), shape=shape, dtype=dtype, tile=tile, compression="zlib")


def _refused_cheaply(path, **limits) -> str:
    """Read `path`, expecting InputError; assert it came quickly and with a small memory peak."""
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(InputError) as caught:
            read_image(path, **limits)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert time.perf_counter() - start < 5.0
    assert peak < 64e6, f"peak {peak / 1e6:.0f} MB while refusing"
    return str(caught.value)


@pytest.mark.timeout(60)
def test_float64_tiff_under_the_megapixel_guard_is_refused_by_bytes(tmp_path):
    path = tmp_path / "bomb.tif"
    _zero_tiled_tiff(path, (19000, 20000), "float64")
    assert path.stat().st_size < 4e6  # about 3 MB on disk, 3 GB decoded; 380 Mpx < 400 Mpx
    message = _refused_cheaply(path)
    assert "max_decoded_gb" in message and "3.0 GB" in message and str(path) in message
    assert "--" not in message  # a parameter name, not a CLI flag


@pytest.mark.timeout(60)
def test_limit_can_be_raised_and_small_files_pass(tmp_path):
    path = tmp_path / "small.tif"
    tifffile.imwrite(path, np.arange(64 * 80, dtype=np.float64).reshape(64, 80))
    assert read_image(path).values.shape == (64, 80)
    with pytest.raises(InputError, match="max_decoded_gb"):
        read_image(path, max_decoded_gb=64 * 80 * 8 / 1e9 * 0.99)
    assert read_image(path, max_decoded_gb=64 * 80 * 8 / 1e9 * 1.01).values.shape == (64, 80)


@pytest.mark.timeout(60)
def test_every_plane_of_a_stack_counts(tmp_path):
    path = tmp_path / "stack.tif"
    tifffile.imwrite(path, np.zeros((10, 100, 100), np.uint16))  # 200 kB decoded, 20 kB per plane
    with pytest.raises(InputError, match="max_decoded_gb"):
        read_image(path, max_decoded_gb=100e3 / 1e9)


def _png_header_only(path, width, height, bit_depth, colour_type):
    """A PNG whose header claims width × height but holds one empty compressed row: a bomb's shape."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, colour_type, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b""))


@pytest.mark.timeout(60)
def test_pillow_images_are_guarded_by_bytes_from_the_header(tmp_path):
    path = tmp_path / "bomb.png"
    _png_header_only(path, 20000, 19000, 16, 0)  # 16-bit grey: 380 Mpx × 2 bytes = 0.76 GB
    message = _refused_cheaply(path, max_decoded_gb=0.5)
    assert "max_decoded_gb" in message and "0.8 GB" in message


@pytest.mark.timeout(60)
def test_dm_plane_is_guarded_before_decoding(fixture):
    need(__import__("importlib").util.find_spec("rsciio") is not None, "rosettasciio (pip install 'tamp-os[dm]')")
    path = fixture("test_STEM_image.dm3")
    assert read_image(path).values.shape == (68, 68)
    with pytest.raises(InputError, match="max_decoded_gb"):
        read_image(path, max_decoded_gb=68 * 68 * 4 / 1e9 / 2)
