"""Hostile input: each case gives one clear error naming the problem and leaves no partial file."""

import struct
import zlib

import numpy as np
import pytest
import tifffile
from PIL import Image

from conftest import run_cli as run
from tamp_os.errors import ExportError
from tamp_os.export.files import write_atomic


def png_claiming(width, height) -> bytes:
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\x00" * 10)) + chunk(b"IEND", b"")


def good_png_bytes() -> bytes:
    import io

    buf = io.BytesIO()
    Image.fromarray((np.random.default_rng(0).random((40, 50)) * 255).astype(np.uint8)).save(buf, "PNG")
    return buf.getvalue()


def good_tiff_bytes() -> bytes:
    import io

    buf = io.BytesIO()
    tifffile.imwrite(buf, (np.random.default_rng(0).random((40, 50)) * 65535).astype(np.uint16))
    return buf.getvalue()


FILE_CASES = {
    "zero_bytes.png": (b"", "empty"),
    "truncated.png": (good_png_bytes()[:200], "damaged or truncated"),
    "truncated.tif": (good_tiff_bytes()[:300], "damaged"),
    "text.png": (b"hello, this is not an image\n", "not an image"),
    "random_after_png_magic.png": (b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4, "not an image"),
    "huge_header.png": (png_claiming(100000, 100000), "decompression bombs"),
}


def write_case(tmp_path, name):
    path = tmp_path / name
    data, _ = FILE_CASES[name]
    path.write_bytes(data)
    return path


def assert_one_clear_error(err, *needles):
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, err
    for needle in needles:
        assert needle in errors[0], (needle, errors[0])
    assert "Traceback" not in err


def assert_no_output(folder):
    leftovers = [p.name for p in folder.iterdir()] if folder.exists() else []
    assert leftovers == [], leftovers


@pytest.mark.parametrize("name", sorted(FILE_CASES))
def test_bad_files(tmp_path, capsys, name):
    path = write_case(tmp_path, name)
    out = tmp_path / "out"
    code, _, err = run(capsys, "convert", path, "-o", out, "--formats", "stl,3mf,glb")
    assert code == 1
    assert_one_clear_error(err, name, FILE_CASES[name][1])
    assert_no_output(out)


@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1)])
def test_too_small_images(tmp_path, capsys, shape):
    path = tmp_path / "small.png"
    Image.fromarray(np.zeros(shape, np.uint8)).save(path)
    code, _, err = run(capsys, "convert", path, "-o", tmp_path / "out")
    assert code == 1
    assert_one_clear_error(err, "small.png", "at least 2×2")
    assert_no_output(tmp_path / "out")


def test_all_nan_float_tiff(tmp_path, capsys):
    path = tmp_path / "nan.tif"
    tifffile.imwrite(path, np.full((8, 8), np.nan, np.float32))
    code, _, err = run(capsys, "convert", path, "-o", tmp_path / "out")
    assert code == 1
    assert_one_clear_error(err, "nan.tif", "NaN")


@pytest.mark.parametrize(
    "option, value, needle",
    [
        ("--width-mm", "0", "--width-mm"),
        ("--depth-mm", "-5", "--depth-mm"),
        ("--height-mm", "-5", "--depth-mm"),  # the old name of the option
        ("--relief-mm", "0", "--relief-mm: must be > 0"),
        ("--base-mm", "-1", "--base-mm"),
        ("--formats", "stl,docx", "formats"),
        ("--preset", "ultra", "preset"),
        ("--printer", "nosuch", "unknown profile"),
        ("--nozzle-mm", "5", "--nozzle-mm"),
        ("--resolution-px", "1", "--resolution-px"),
        ("--stretch-low-pct", "99", "--stretch-low-pct must be below"),
    ],
)
def test_bad_parameters_are_usage_errors(tmp_path, capsys, option, value, needle):
    img = tmp_path / "ok.png"
    img.write_bytes(good_png_bytes())
    code, _, err = run(capsys, "convert", img, "-o", tmp_path / "out", option, value)
    assert code == 2
    assert_one_clear_error(err, needle)
    assert_no_output(tmp_path / "out")


def test_blur_given_twice(tmp_path, capsys):
    img = tmp_path / "ok.png"
    img.write_bytes(good_png_bytes())
    code, _, err = run(capsys, "convert", img, "--blur-px", "1", "--blur-mm", "1", "-o", tmp_path / "o")
    assert code == 2
    assert_one_clear_error(err, "--blur-px and --blur-mm")


def test_missing_file_and_folder_as_input(tmp_path, capsys):
    code, _, err = run(capsys, "convert", tmp_path / "nope.tif", "-o", tmp_path / "out")
    assert code == 1
    assert_one_clear_error(err, "nope.tif", "no such file")
    code, _, err = run(capsys, "convert", tmp_path, "-o", tmp_path / "out")
    assert code == 1
    assert_one_clear_error(err, "is a folder")


def test_output_folder_that_cannot_be_created(tmp_path, capsys):
    img = tmp_path / "ok.png"
    img.write_bytes(good_png_bytes())
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    code, _, err = run(capsys, "convert", img, "-o", blocker / "sub")
    assert code == 1
    assert_one_clear_error(err, "cannot create the output folder")
    code, _, err = run(capsys, "convert", img, "-o", "/proc/tamp-os-cannot-write-here")
    assert code == 1
    assert_one_clear_error(err, "/proc/tamp-os-cannot-write-here")


def test_output_path_that_is_a_folder(tmp_path):
    (tmp_path / "print.stl").mkdir()
    with pytest.raises(ExportError, match="is a folder"):
        write_atomic(tmp_path / "print.stl", lambda fh: fh.write(b"x"))


def test_a_crash_while_writing_leaves_nothing(tmp_path):
    def half_then_crash(fh):
        fh.write(b"solid but not finished")
        raise RuntimeError("disk gone")

    with pytest.raises(RuntimeError):
        write_atomic(tmp_path / "print.stl", half_then_crash)
    assert list(tmp_path.iterdir()) == []
    # An existing good file is not replaced by a failed write.
    (tmp_path / "print.stl").write_bytes(b"good")
    with pytest.raises(RuntimeError):
        write_atomic(tmp_path / "print.stl", half_then_crash)
    assert (tmp_path / "print.stl").read_bytes() == b"good"


def test_one_bad_file_does_not_stop_the_others(tmp_path, capsys):
    good = tmp_path / "good.png"
    good.write_bytes(good_png_bytes())
    bad = write_case(tmp_path, "text.png")
    code, out, err = run(capsys, "convert", bad, good, "-o", tmp_path / "out")
    assert code == 1
    assert "good.png:" in out and (tmp_path / "out" / "good.stl").is_file()
    assert "1 of 2 failed" in err


@pytest.mark.parametrize("kind", ["cmyk", "palette_transparent", "animated_gif"])
def test_unusual_but_legal_images_convert(tmp_path, capsys, kind):
    rng = np.random.default_rng(1)
    arr = (rng.random((30, 40, 3)) * 255).astype(np.uint8)
    if kind == "cmyk":
        path = tmp_path / "c.jpg"
        Image.fromarray(arr).convert("CMYK").save(path, "JPEG")
    elif kind == "palette_transparent":
        path = tmp_path / "p.png"
        Image.fromarray(arr).convert("P").save(path, transparency=0)
    else:
        path = tmp_path / "a.gif"
        frames = [Image.fromarray(arr), Image.fromarray(arr[::-1])]
        frames[0].save(path, save_all=True, append_images=frames[1:])
    code, out, err = run(capsys, "convert", path, "-o", tmp_path / "out", "--preset", "low")
    assert code == 0, err
    assert "triangles" in out


def test_corrupt_recipe(tmp_path, capsys):
    bad = tmp_path / "x.tamp.json"
    bad.write_text("{ not json")
    code, _, err = run(capsys, "convert", "--recipe", bad)
    assert code == 1
    assert_one_clear_error(err, "x.tamp.json", "not a readable TAMP-OS recipe")


def test_mesh_of_a_nan_heightmap_is_never_made():
    # The pipeline replaces unknown pixels before meshing; the mesher itself gets finite heights.
    from tamp_os import make_lithograph

    img = np.ones((10, 10), np.float32)
    img[2, 2] = np.nan
    img[5:, 5:] = 3
    litho = make_lithograph(img, resolution_px=10, blur_px=0, relief_style="reference")
    assert np.isfinite(litho.mesh.vertices).all()
    assert litho.heightmap[2, 2] == litho.params.base_mm
