"""Reading by content at full precision: every fixture, every container, every pixel layout."""


import numpy as np
import pytest
import tifffile
from PIL import Image

from tamp_os.errors import InputError, ParameterError
from tamp_os.read.image import read_array, read_image


def save_pil(tmp_path, name, image, **kw):
    path = tmp_path / name
    image.save(path, **kw)
    return path


@pytest.mark.parametrize(
    "name, width, height, dtype",
    [
        ("fept_spheres_sem.png", 1024, 768, "float32"),  # JPEG bytes, RGB -> luminance
        ("test_tiff_Zeiss_SEM_1k.tif", 1024, 768, "uint8"),
        ("FEI-Helios-Ebeam-8bits.tif", 512, 471, "uint8"),
        ("FEI-Helios-Ebeam-16bits.tif", 512, 471, "uint16"),
        ("test_loading_image_saved_with_imageJ.tif", 68, 68, "float32"),
        ("JEOL-SightX-TEM-mag-dummy.tif", 556, 556, "uint16"),
        ("test_STEM_image.dm3", 68, 68, "uint32"),
    ],
)
def test_fixtures_load_with_size_and_depth(fixture, name, width, height, dtype):
    pic = read_image(fixture(name))
    assert (pic.file.width, pic.file.height) == (width, height)
    assert pic.values.shape == (height, width)
    if name.endswith(".png"):
        assert pic.file.format == "JPEG" and pic.file.dtype == "uint8" and pic.file.channels == 3
    else:
        assert pic.file.dtype == dtype


def test_fixture_values_are_kept_at_full_precision(fixture):
    raw16 = tifffile.imread(fixture("FEI-Helios-Ebeam-16bits.tif"))
    pic = read_image(fixture("FEI-Helios-Ebeam-16bits.tif"))
    np.testing.assert_array_equal(pic.values, raw16.astype(np.float32))
    assert pic.values.max() > 255  # not squeezed to 8 bits
    jeol = read_image(fixture("JEOL-SightX-TEM-mag-dummy.tif"))
    assert np.all(jeol.values == 513)
    ij = read_image(fixture("test_loading_image_saved_with_imageJ.tif"))
    np.testing.assert_array_equal(ij.values, tifffile.imread(fixture("test_loading_image_saved_with_imageJ.tif")))


def test_jpeg_named_png_is_read_as_jpeg_with_luminance(fixture):
    path = fixture("fept_spheres_sem.png")
    pic = read_image(path)
    rgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)
    expected = rgb @ np.array([0.299, 0.587, 0.114])
    np.testing.assert_allclose(pic.values, expected, atol=1e-3)


@pytest.mark.parametrize("fmt, ext", [("PNG", "png"), ("JPEG", "jpg"), ("BMP", "bmp"), ("GIF", "gif"), ("WEBP", "webp"), ("TIFF", "tif")])
def test_common_formats_by_content_even_with_a_wrong_extension(tmp_path, gradient_image, fmt, ext):
    path = save_pil(tmp_path, f"picture.{'dat' if ext != 'png' else 'jpg'}", Image.fromarray(gradient_image), format=fmt, **({"lossless": True} if fmt == "WEBP" else {}))
    pic = read_image(path)
    assert pic.values.shape == gradient_image.shape
    if fmt in ("PNG", "BMP", "GIF", "TIFF", "WEBP"):
        np.testing.assert_allclose(pic.values, gradient_image, atol=1.0)


def test_16bit_png_keeps_16_bits(tmp_path):
    data = (np.arange(64 * 32).reshape(32, 64) * 30).astype(np.uint16)
    path = tmp_path / "deep.png"
    Image.fromarray(data).save(path)
    pic = read_image(path)
    assert pic.values.max() > 255
    np.testing.assert_array_equal(pic.values, data)


def test_rgba_transparency_becomes_zero_weight(tmp_path):
    rgba = np.zeros((10, 12, 4), np.uint8)
    rgba[..., :3] = 200
    rgba[..., 3] = 255
    rgba[:, :4, 3] = 0
    pic = read_image(save_pil(tmp_path, "a.png", Image.fromarray(rgba, "RGBA")))
    assert pic.alpha is not None and np.all(pic.alpha[:, :4] == 0) and np.all(pic.alpha[:, 4:] == 1)
    assert pic.file.transparent_pixels == 40


def test_la_and_palette_with_transparency(tmp_path):
    la = np.dstack([np.full((8, 8), 100, np.uint8), np.full((8, 8), 255, np.uint8)])
    la[0, 0, 1] = 0
    pic = read_image(save_pil(tmp_path, "la.png", Image.fromarray(la, "LA")))
    assert pic.alpha[0, 0] == 0 and np.all(pic.values == 100)
    pal = Image.new("P", (8, 8), 1)
    pal.putpalette([0, 0, 0, 255, 255, 255] + [0] * 762)
    pal.info["transparency"] = 0
    pal.putpixel((0, 0), 0)
    pic = read_image(save_pil(tmp_path, "p.png", pal, transparency=0))
    assert pic.alpha[0, 0] == 0 and pic.alpha[1, 1] == 1
    assert pic.values[1, 1] == pytest.approx(255, abs=0.01)


def test_cmyk_jpeg_and_chosen_channel(tmp_path):
    rgb = np.zeros((16, 16, 3), np.uint8)
    rgb[..., 0] = 250
    cmyk = Image.fromarray(rgb).convert("CMYK")
    pic = read_image(save_pil(tmp_path, "c.jpg", cmyk, format="JPEG", quality=100))
    assert 60 < pic.values.mean() < 90  # red's luminance ≈ 0.299 × 250
    pic = read_image(save_pil(tmp_path, "rgb.png", Image.fromarray(rgb)), channel="red")
    assert np.all(pic.values == 250)
    pic = read_image(tmp_path / "rgb.png", channel="2")
    assert np.all(pic.values == 0)
    with pytest.raises(ParameterError, match="channel"):
        read_image(tmp_path / "rgb.png", channel="7")


def test_animated_gif_first_frame_and_page_choice(tmp_path):
    frames = [Image.fromarray(np.full((8, 8), v, np.uint8)) for v in (10, 200)]
    path = tmp_path / "anim.gif"
    frames[0].save(path, save_all=True, append_images=frames[1:])
    assert read_image(path).values.mean() == pytest.approx(10, abs=1)
    assert read_image(path, page=1).values.mean() == pytest.approx(200, abs=1)
    assert read_image(path).file.pages == 2


def test_multipage_and_ome_tiff_page_choice(tmp_path):
    stack = np.stack([np.full((6, 9), i * 1000, np.uint16) for i in range(3)])
    path = tmp_path / "stack.tif"
    tifffile.imwrite(path, stack, photometric="minisblack")
    assert read_image(path).values.mean() == 0
    assert read_image(path, page=2).values.mean() == 2000
    ome = tmp_path / "s.ome.tif"
    tifffile.imwrite(ome, stack, ome=True, photometric="minisblack", metadata={"axes": "ZYX"})
    pic = read_image(ome)  # a z-stack: maximum-intensity projection by default
    assert pic.values.mean() == 2000 and "ome_metadata" in pic.file.metadata
    assert any("maximum-intensity projection" in n for n in pic.file.notes)
    assert read_image(ome, z_slice=1).values.mean() == 1000
    with pytest.raises(ParameterError, match="z_slice must be 0–2"):
        read_image(ome, z_slice=3)
    with pytest.raises(ParameterError, match="page"):
        read_image(path, page=3)


def test_float_tiff_with_nan_and_inf_is_reported(tmp_path):
    data = np.linspace(0, 1, 100, dtype=np.float32).reshape(10, 10)
    data[0, 0], data[1, 1] = np.nan, np.inf
    path = tmp_path / "f.tif"
    tifffile.imwrite(path, data)
    pic = read_image(path)
    assert pic.file.nonfinite_pixels == 2
    assert pic.alpha[0, 0] == 0 and pic.alpha[1, 1] == 0 and pic.alpha[2, 2] == 1
    assert any("NaN" in n for n in pic.file.notes)


def test_bomb_guard_reads_only_the_header(tmp_path):
    path = tmp_path / "big.png"
    Image.new("L", (5000, 5000)).save(path)
    with pytest.raises(InputError, match="max_megapixels"):
        read_image(path, max_megapixels=1)
    assert read_image(path, max_megapixels=30).file.width == 5000


def test_arrays_are_read_like_files():
    pic = read_array(np.arange(12, dtype=np.int32).reshape(3, 4))
    assert pic.values.dtype == np.float32 and pic.values[2, 3] == 11
    with pytest.raises(InputError, match="2×2"):
        read_array(np.zeros((1, 5)))


def test_multichannel_tiff_channel_by_number_or_name(tmp_path):
    data = np.stack([np.full((2, 6, 9), v, np.uint16) for v in (100, 200, 300)], axis=1)  # Z C Y X
    path = tmp_path / "czyx.ome.tif"
    tifffile.imwrite(path, data, ome=True, photometric="minisblack",
                     metadata={"axes": "ZCYX", "Channel": {"Name": ["DAPI", "GFP", "RFP"]}})
    pic = read_image(path)
    assert pic.values.mean() == 100 and any("3 channels (DAPI, GFP, RFP)" in n for n in pic.file.notes)
    assert read_image(path, channel="GFP").values.mean() == 200
    assert read_image(path, channel="2").values.mean() == 300
    with pytest.raises(ParameterError, match="DAPI"):
        read_image(path, channel="Cy5")


def test_a_slice_asked_of_a_single_picture_is_refused_naming_it(tmp_path):
    # a PNG has no z-stack: --slice 3 was ignored silently (the print was the whole picture)
    path = tmp_path / "flat.png"
    Image.fromarray(np.arange(64 * 48, dtype=np.uint32).reshape(48, 64).astype(np.uint8)).save(path)
    with pytest.raises(ParameterError, match="z_slice") as info:
        read_image(path, z_slice=3)
    assert "no z-stack" in str(info.value) and info.value.parameter == "z_slice" and info.value.value == 3
    assert read_image(path, z_slice=0).values.shape == (48, 64)  # the first (only) plane is there


def test_the_decoded_size_refused_is_said_with_its_digits(tmp_path):
    # 40×150×150 bytes is 0.0009 GB: the message said "= 0.0 GB would exceed the limit of 0.0001 GB"
    path = tmp_path / "stack.tif"
    tifffile.imwrite(path, np.zeros((40, 150, 150), np.uint8), metadata={"axes": "ZYX"})
    with pytest.raises(InputError) as info:
        read_image(path, max_decoded_gb=0.0001)
    text = str(info.value)
    assert "= 0.0009 GB" in text and "0.0 GB" not in text, text
    assert "0.0001 GB" in text


def test_a_channel_not_in_the_file_is_refused_naming_the_option(tmp_path):
    from tamp_os.cli.commands import cli_words

    path = tmp_path / "two.ome.tif"
    tifffile.imwrite(path, np.zeros((2, 20, 30), np.uint16), ome=True, photometric="minisblack", metadata={"axes": "CYX"})
    with pytest.raises(ParameterError) as info:
        read_image(path, channel="nope")
    assert "'nope'" in str(info.value) and "0–1" in str(info.value)
    assert "--channel 'nope'" in cli_words(info.value), cli_words(info.value)  # it said "channel 'nope'"
    note = " ".join(cli_words(n) for n in read_image(path).file.notes)
    assert "using channel 0" in note and "--channel" in note, note


def test_the_limits_hints_say_the_option_as_it_is_typed(tmp_path):
    # the hints read "raise the limit: --max-decoded-gb = 1" (an '=' the option does not take)
    from tamp_os.cli.commands import cli_words

    path = tmp_path / "stack.tif"
    tifffile.imwrite(path, np.zeros((40, 150, 150), np.uint8), metadata={"axes": "ZYX"})
    with pytest.raises(InputError) as info:
        read_image(path, max_decoded_gb=0.0001)
    assert "--max-decoded-gb 1." in cli_words(info.value) and "= 1" not in cli_words(info.value), cli_words(info.value)
    png = tmp_path / "big.png"
    Image.fromarray(np.zeros((1000, 1200), np.uint8)).save(png)
    with pytest.raises(InputError) as info:
        read_image(png, max_megapixels=0.5)
    assert "--max-megapixels 2." in cli_words(info.value) and "= " not in cli_words(info.value), cli_words(info.value)


def test_a_tiff_is_decoded_once_within_a_conversion_and_again_when_it_changes(tmp_path):
    """decoded_once(): the reads of one conversion share the decoded pixels (read-only), give what
    separate reads give, and a file rewritten in between is read anew; its hash follows its bytes."""
    import os

    from tamp_os.read.image import decoded_once

    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, (40, 50, 3), dtype=np.uint8)
    path = tmp_path / "rgb.tif"
    tifffile.imwrite(path, rgb, photometric="rgb")
    alone = [read_image(path, keep_colour=True), read_image(path, channel="red")]
    with decoded_once():
        first, red = read_image(path, keep_colour=True), read_image(path, channel="red")
        again = read_image(path, keep_colour=True)
        assert np.shares_memory(first.colour, again.colour) and not np.shares_memory(alone[0].colour, first.colour)
        with pytest.raises(ValueError):
            first.colour[0, 0, 0] = 1  # shared: nobody may change it
        assert np.array_equal(first.values, alone[0].values) and np.array_equal(red.values, alone[1].values)
        assert first.file.sha256 == alone[0].file.sha256
        changed = rgb.copy()
        changed[0, 0] ^= 255
        tifffile.imwrite(path, changed, photometric="rgb")  # the same size, other bytes
        os.utime(path, ns=(1, 1))  # even with an older time stamp
        after = read_image(path, keep_colour=True)
    assert np.array_equal(after.colour, changed) and after.file.sha256 != first.file.sha256
    assert read_image(path).file.sha256 == after.file.sha256
