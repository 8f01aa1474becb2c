"""read.py and clean/: the decoded-bytes guard before decoding, preview pages skipped (Olympus SIS),
DigitalMicrograph TIFF tags, instrument facts, and the full-source mask."""

import struct
import tracemalloc
import zlib

import numpy as np
import pytest
import tifffile

from conftest import need
from tamp_os.errors import InputError
from tamp_os.read.image import read_image


def _zero_tiled_tiff(path, shape, dtype, tile=(512, 512)):
    """A deflate-compressed tiled TIFF of zeros, written without ever holding the image in memory."""
    tiles = -(-shape[0] // tile[0]) * -(-shape[1] // tile[1])
    packed = zlib.compress(bytes(tile[0] * tile[1] * np.dtype(dtype).itemsize), 9)
    tifffile.imwrite(path, (packed for _ in range(tiles)), shape=shape, dtype=dtype, tile=tile, compression="zlib")


def _refused_cheaply(path, **limits) -> str:
    """Read `path`, expecting InputError; assert it came quickly and with a small memory peak."""
    tracemalloc.start()
    try:
        with pytest.raises(InputError) as caught:
            read_image(path, **limits)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 64e6, f"peak {peak / 1e6:.0f} MB while refusing"
    return str(caught.value)


@pytest.mark.timeout(60)
def test_float64_tiff_under_the_megapixel_guard_is_refused_by_bytes(tmp_path):
    path = tmp_path / "bomb.tif"
    _zero_tiled_tiff(path, (19000, 20000), "float64")
    assert path.stat().st_size < 4e6  # about 3 MB on disk, 3 GB decoded; 380 Mpx < 400 Mpx
    message = _refused_cheaply(path, max_megapixels=400)  # the bytes guard, under a megapixel limit it passes
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
    message = _refused_cheaply(path, max_decoded_gb=0.5, max_megapixels=400)
    assert "max_decoded_gb" in message and "0.8 GB" in message


@pytest.mark.timeout(60)
def test_dm_plane_is_guarded_before_decoding(fixture):
    need(__import__("importlib").util.find_spec("rsciio") is not None, "rosettasciio (pip install 'tamp-os[dm]')")
    path = fixture("test_STEM_image.dm3")
    assert read_image(path).values.shape == (68, 68)
    with pytest.raises(InputError, match="max_decoded_gb"):
        read_image(path, max_decoded_gb=68 * 68 * 4 / 1e9 / 2)


# --- Olympus SIS: a JPEG preview on page 0, the 16-bit data on page 1 (issue 14.1) ---------------

def _sis_block(pixel_m: float, magnification: float) -> bytes:
    """An OlympusSIS (tag 33560) structure as tifffile parses it; the record offset is patched later."""
    head = struct.pack("<4s6xhhhhh6x32sH", b"SIS0", 30, 12, 5, 3, 120, b"synthetic".ljust(32, b"\0"), 1)
    entry = struct.pack("<hhI", 1, 1, 0)
    record = struct.pack("<10xhdd8xd2x34s32s", -9, pixel_m / 1e-9, pixel_m / 1e-9, magnification,
                         b"camera".ljust(34, b"\0"), b"TEM".ljust(32, b"\0"))
    return head + entry + record


def write_sis_like(path, data, *, pixel_m=2.5e-9, magnification=50000.0, shaped=False):
    """Page 0: a 4× smaller JPEG RGB preview with a white bar; page 1: `data` (uint16)."""
    need(__import__("importlib").util.find_spec("imagecodecs") is not None, "imagecodecs (JPEG in TIFF)")
    h, w = data.shape
    preview = np.zeros((h // 4, w // 4, 3), np.uint8)
    preview[-12:-6, -40:-8] = 255  # the burned-in scale bar of the preview
    block = _sis_block(pixel_m, magnification)
    with tifffile.TiffWriter(path) as writer:
        meta = {} if shaped else None  # real SIS files have no tifffile 'shaped' description
        writer.write(preview, photometric="rgb", compression="jpeg", metadata=meta,
                     extratags=[(33560, 7, len(block), block, True)])
        writer.write(data, metadata=meta)
    raw = bytearray(path.read_bytes())
    at = raw.find(b"SIS0")
    struct.pack_into("<I", raw, at + 64, at + 68)  # the type-1 record follows the one tag entry
    path.write_bytes(bytes(raw))


def _ramp(h=256, w=320):
    return (np.add.outer(np.arange(h) * 97, np.arange(w) * 13) % 60000).astype(np.uint16)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("shaped", [False, True])
def test_sis_data_page_is_read_by_default_with_a_note(tmp_path, shaped):
    path = tmp_path / "sis.tif"
    data = _ramp()
    write_sis_like(path, data, shaped=shaped)
    picture = read_image(path)
    assert picture.values.shape == data.shape
    np.testing.assert_array_equal(picture.values, data.astype(np.float32))
    assert picture.file.bit_depth == 16
    assert any("page 1" in n and "preview" in n and "page 0" in n for n in picture.file.notes)


@pytest.mark.timeout(60)
def test_sis_explicit_page_is_obeyed(tmp_path):
    path = tmp_path / "sis.tif"
    write_sis_like(path, _ramp())
    preview = read_image(path, page=0)
    assert preview.values.shape == (64, 80) and preview.file.bit_depth == 8
    assert not any("preview" in n for n in preview.file.notes)
    assert read_image(path, page=1).values.shape == (256, 320)


@pytest.mark.timeout(60)
def test_sis_pixel_size_is_read(tmp_path):
    from tamp_os.clean.stage import clean_picture

    path = tmp_path / "sis.tif"
    write_sis_like(path, _ramp(), pixel_m=0.37e-9)
    for page in (None, 1):
        size = clean_picture(read_image(path, page=page), pixel_size_m=None, remove_annotations=False).pixel_size
        assert size.provenance == "Olympus SIS pixelsizex"
        assert size.metres == pytest.approx(0.37e-9, rel=1e-9)


@pytest.mark.timeout(60)
def test_reduced_thumbnail_on_page_0_is_skipped(tmp_path):
    path = tmp_path / "thumb.tif"
    data = _ramp(128, 128).astype(np.uint8)
    with tifffile.TiffWriter(path) as writer:
        writer.write(data[::4, ::4], subfiletype=1, metadata=None)  # NewSubfileType bit 0: reduced
        writer.write(data, metadata=None)
    picture = read_image(path)
    assert picture.values.shape == (128, 128)
    assert any("flagged as reduced" in n for n in picture.file.notes)


@pytest.mark.timeout(60)
def test_a_plain_stack_still_starts_at_page_0(tmp_path):
    path = tmp_path / "stack.tif"
    stack = np.stack([np.full((32, 40), v, np.uint16) for v in (10, 20, 30)])
    tifffile.imwrite(path, stack, photometric="minisblack")
    picture = read_image(path)
    assert picture.values.mean() == 10 and not any("preview" in n for n in picture.file.notes)


# --- DigitalMicrograph TIFF tags (issue 14.2) ---------------------------------------------------

@pytest.mark.timeout(60)
@pytest.mark.parametrize(
    ("unit_tag", "unit", "scale", "metres"),
    [
        (65003, (2, "micrometer"), 0.0125, 12.5e-9),
        (65003, (7, b"\xb5m"), 0.5, 0.5e-6),  # µ as DM's single Latin-1 byte
        (65012, (7, "µm".encode()), 2.0, 2e-6),
        (65003, (2, "nm"), 0.2485, 0.2485e-9),
    ],
)
def test_dm_tiff_tags_give_the_scale(tmp_path, unit_tag, unit, scale, metres):
    from tamp_os.clean.stage import clean_picture

    path = tmp_path / "dm.tif"
    code, value = unit
    tags = [(65009, 12, 1, scale, True), (65010, 12, 1, scale, True), (unit_tag, code, len(value), value, True)]
    tifffile.imwrite(path, _ramp(64, 64), extratags=tags, metadata=None)
    size = clean_picture(read_image(path), pixel_size_m=None, remove_annotations=False).pixel_size
    assert size.provenance == "DigitalMicrograph TIFF tags"
    assert size.metres == pytest.approx(metres, rel=1e-9)


@pytest.mark.timeout(60)
def test_dm_tiff_tags_without_a_length_unit_give_no_scale_and_say_so(tmp_path):
    from tamp_os.clean.stage import clean_picture

    path = tmp_path / "dm.tif"
    tags = [(65009, 12, 1, 0.5, True), (65003, 2, len("1/nm"), "1/nm", True)]  # a diffraction pattern
    tifffile.imwrite(path, _ramp(64, 64), extratags=tags, metadata=None)
    size = clean_picture(read_image(path), pixel_size_m=None, remove_annotations=False).pixel_size
    assert size.metres is None
    assert any("DigitalMicrograph TIFF tags" in w and "1/nm" in w for w in size.warnings)


@pytest.mark.timeout(30)
@pytest.mark.parametrize(("text", "metres"), [("3 micrometer", 3e-6), ("2nanometres", 2e-9), ("1 millimeter", 1e-3)])
def test_spelled_out_units(text, metres):
    from tamp_os.units import parse_length_m

    assert parse_length_m(text) == pytest.approx(metres)


# --- Instrument facts (issue 14.8) --------------------------------------------------------------

@pytest.mark.timeout(60)
def test_zeiss_and_fei_instrument_facts(fixture):
    from tamp_os.clean.stage import clean_picture

    zeiss = clean_picture(read_image(fixture("test_tiff_Zeiss_SEM_1k.tif")), pixel_size_m=None, remove_annotations=False).instrument
    assert (zeiss.magnification, zeiss.kv, zeiss.detector, zeiss.signal) == (105, 25.0, "HE-SE2", "SE")
    fei = clean_picture(read_image(fixture("FEI-Helios-Ebeam-8bits.tif")), pixel_size_m=None, remove_annotations=False).instrument
    assert (fei.kv, fei.detector, fei.signal) == (5.0, "ETD", "SE")
    assert fei.magnification == pytest.approx(0.2072 / 0.00172667, rel=1e-6)  # canvas width ÷ field width


@pytest.mark.timeout(60)
def test_tescan_backscatter_and_no_facts(tmp_path):
    from tamp_os.clean.stage import clean_picture

    path = tmp_path / "tescan.tif"
    text = "[MAIN]\nPixelSizeX=2e-08\nHV=20000\nMagnification=5000\nDetector=BSE\n"
    tifffile.imwrite(path, _ramp(64, 64), extratags=[(50431, 2, len(text), text, True)], metadata=None)
    found = clean_picture(read_image(path), pixel_size_m=None, remove_annotations=False).instrument
    assert (found.magnification, found.kv, found.signal) == (5000, 20.0, "BSE")
    plain = tmp_path / "plain.tif"
    tifffile.imwrite(plain, _ramp(64, 64))
    assert clean_picture(read_image(plain), pixel_size_m=None, remove_annotations=False).instrument is None


@pytest.mark.timeout(30)
@pytest.mark.parametrize(("name", "signal"), [("HE-SE2", "SE"), ("InLens", "SE"), ("CBS", "BSE"), ("vCD BSE", "BSE"),
                                              ("HAADF", "STEM"), ("NSE-BSD", "BSE"), ("CCD", None), (None, None)])
def test_signal_from_detector_names(name, signal):
    from tamp_os.clean.instrument import signal_of

    assert signal_of(name) == signal


@pytest.mark.timeout(120)
def test_description_and_info_mention_the_detector(fixture, tmp_path, capsys):
    import json

    from tamp_os.cli.commands import main
    from tamp_os.lithograph.pipeline import make_lithograph
    from tamp_os.lithograph.report import describe

    path = fixture("test_tiff_Zeiss_SEM_1k.tif")
    litho = make_lithograph(path, preset="low", width_mm=40, scale_bar="off")
    assert litho.report.instrument["signal"] == "SE"
    text = describe(litho.report, litho.params, "zeiss.tif")
    assert "Recorded with a secondary-electron (SE) detector at 25 kV" in text and "not height" in text
    plain = tmp_path / "plain.tif"
    tifffile.imwrite(plain, _ramp(64, 64))
    other = make_lithograph(plain, preset="low", width_mm=40)
    assert other.report.instrument is None and "Recorded" not in describe(other.report, other.params, "plain.tif")
    capsys.readouterr()
    assert main(["info", "--json", str(path)]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["instrument"]["kv"] == 25.0 and facts["instrument"]["detector"] == "HE-SE2"


# --- save_masks shows the cropped band too (issue 14.7) ------------------------------------------

def _saved_mask(tmp_path, source) -> np.ndarray:
    from PIL import Image

    from tamp_os.lithograph.pipeline import make_lithograph

    litho = make_lithograph(source, preset="low", width_mm=60, scale_bar="off", save_masks=True)
    written = litho.save(tmp_path, ["stl"])
    png = next(p for p in written if str(p).endswith(".annotations.png"))
    with Image.open(png) as im:  # read back by Pillow, independently of how it was written
        return np.asarray(im.convert("L"))


@pytest.mark.timeout(120)
def test_mask_covers_the_source_with_the_band_in_grey(fixture, tmp_path):
    mask = _saved_mask(tmp_path, fixture("FEI-Helios-Ebeam-8bits.tif"))
    assert mask.shape == (471, 512)  # the whole source, not the cropped picture
    band = mask[442:]  # [Image] ResolutionY = 442: rows 442-470 are FEI's databar
    assert np.all((band > 100) & (band < 160))
    assert not np.any((mask[:442] > 100) & (mask[:442] < 160))


@pytest.mark.timeout(120)
def test_mask_shows_inpainted_boxes_in_white_where_they_were(fixture, tmp_path):
    mask = _saved_mask(tmp_path, fixture("fept_spheres_sem.png"))
    assert mask.shape == (768, 1024)
    white = mask == 255
    assert white.any()
    rows, cols = np.nonzero(white)
    assert rows.min() > 768 // 2 and cols.max() < 1024 // 2  # the "4 µm" box sits at the lower left
