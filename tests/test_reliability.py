"""Reliability, second pass (issue 25): memory bounded by the real cost, no super-linear parsing,
no tracebacks for plain situations, every output set whole.

Every test that decodes something large runs in a child process under an address-space limit
(RLIMIT_AS), so a regression fails with MemoryError instead of swapping a shared machine; the
child's real peak (ru_maxrss) is measured too.
"""

import hashlib
import json
import os
import resource
import signal
import struct
import subprocess
import sys
import textwrap
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
import tifffile
from PIL import Image

from conftest import ROOT, run_cli as run

PYTHON = sys.executable
SRC = str(ROOT / "src")


# --- helpers ------------------------------------------------------------------------------------

def run_limited(code: str, *args, limit_gb: float, timeout_s: float = 120) -> tuple[int, str, str, float]:
    """Run `code` in a child Python under RLIMIT_AS = limit_gb: (exit code, stdout, stderr, peak MB).

    The peak is the child's own maximum resident size, read with wait4 so other children of
    the test process do not count.
    """
    limit = int(limit_gb * 2**30)

    def limit_memory():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))

    env = {**os.environ, "PYTHONPATH": SRC, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([PYTHON, "-c", code, *map(str, args)], preexec_fn=limit_memory, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    # communicate() reaped the child; its rusage is in RUSAGE_CHILDREN only as a running maximum,
    # so the child reports its own peak on its last line instead (see PEAK below).
    peak = 0.0
    for line in err.splitlines()[::-1]:
        if line.startswith("PEAK_MB "):
            peak = float(line.split()[1])
            break
    return proc.returncode, out, err, peak


PEAK = "\nimport resource as _r, sys as _s; print('PEAK_MB', _r.getrusage(_r.RUSAGE_SELF).ru_maxrss / 1024, file=_s.stderr)\n"


def cli_code(*argv) -> str:
    """Child code: run the CLI with argv (and sys.argv[1:]), print its peak, exit with its code."""
    return textwrap.dedent(f"""
        import sys
        from tamp_os.cli import main
        code = main({list(map(str, argv))!r} + sys.argv[1:])
        """) + PEAK + "sys.exit(code)\n"


def one_error_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(lines) == 1, err
    assert "Traceback" not in err, err
    return lines[0]


def png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def zero_png(path: Path, width: int, height: int, colour_type: int, palette: bool = False) -> Path:
    """A real, fully decodable PNG of zeros (compressed row by row: tiny on disk, large decoded)."""
    samples = {0: 1, 2: 3, 3: 1, 6: 4}[colour_type]
    comp = zlib.compressobj(9)
    row = b"\0" * (1 + width * samples)
    body = b"".join(comp.compress(row) for _ in range(height)) + comp.flush()
    chunks = [png_chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour_type, 0, 0, 0))]
    if palette:
        chunks.append(png_chunk(b"PLTE", bytes(range(48))))
        chunks.append(png_chunk(b"tRNS", b"\x80"))
    chunks += [png_chunk(b"IDAT", body), png_chunk(b"IEND", b"")]
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + b"".join(chunks))
    return path


def tile_bomb(path: Path, tile_px: int = 65520, compression: str = "zlib") -> Path:
    """A 16×16 TIFF whose header declares one tile_px × tile_px tile (the decoder allocates it)."""
    tifffile.imwrite(path, np.zeros((16, 16), np.uint8), tile=(16, 16), compression=compression)
    with tifffile.TiffFile(path) as tif:
        tags = tif.pages[0].tags
        spots = [(tags[code].valueoffset, int(tags[code].dtype)) for code in (322, 323)]
        order = tif.byteorder
    with open(path, "r+b") as fh:
        for offset, dtype in spots:
            fh.seek(offset)
            fh.write(struct.pack(order + ("H" if dtype == 3 else "I"), tile_px))
    return path


def small_png(path: Path, shape=(60, 80), seed=0) -> Path:
    Image.fromarray((np.random.default_rng(seed).random(shape) * 255).astype(np.uint8)).save(path)
    return path


# --- 1. memory priced before decoding ---------------------------------------------------------------

@pytest.mark.timeout(120)
def test_rgb_png_bomb_is_refused_in_one_line_within_a_memory_limit(tmp_path):
    bomb = zero_png(tmp_path / "rgb.png", 20000, 20000, 2)
    assert bomb.stat().st_size < 2_000_000
    code, _, err, peak = run_limited(cli_code("convert", bomb, "-o", tmp_path / "out", "--max-megapixels", "1000"),
                                     limit_gb=1.5)
    line = one_error_line(err)
    assert code == 1 and "rgb.png" in line and "max_memory_gb" not in line or "--max-memory-gb" in line, line
    assert "GB of memory" in line and "float32 working arrays" in line, line
    assert peak < 300, f"peak {peak:.0f} MB while refusing"
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.timeout(120)
def test_palette_png_is_priced_with_its_rgba_copies(tmp_path):
    from tamp_os.errors import InputError
    from tamp_os.read import read_image
    from tamp_os.read_cost import WORKING_BYTES_PER_PX

    path = zero_png(tmp_path / "pal.png", 4000, 4000, 3, palette=True)  # 16 Mpx, a few kB on disk
    px = 4000 * 4000
    expected = px * 1 + px * 4 * 2 + px * WORKING_BYTES_PER_PX  # palette indices, RGBA + its NumPy copy, working arrays
    with pytest.raises(InputError, match="converted copies") as caught:
        read_image(path, max_memory_gb=expected / 1e9 * 0.99)
    assert f"{expected / 1e9:.1f} GB" in str(caught.value)
    code, out, err, peak = run_limited(
        "import sys; from tamp_os.read import read_image; p = read_image(sys.argv[1], max_memory_gb=float(sys.argv[2]));"
        "print(p.values.shape)" + PEAK, path, expected / 1e9 * 1.01, limit_gb=2.5)
    assert code == 0, err
    assert "(4000, 4000)" in out
    assert peak * 1e6 < expected, f"measured {peak:.0f} MB, priced {expected / 1e6:.0f} MB"


@pytest.mark.timeout(120)
@pytest.mark.parametrize("compression", ["zlib", "zstd"])
def test_tiff_tile_larger_than_the_image_is_priced_as_declared(tmp_path, compression):
    from conftest import need_module

    if compression == "zstd":
        need_module("imagecodecs")
    bomb = tile_bomb(tmp_path / "tile.tif", compression=compression)
    assert bomb.stat().st_size < 10_000
    code, _, err, peak = run_limited(cli_code("convert", bomb, "-o", tmp_path / "out"), limit_gb=1.5)
    line = one_error_line(err)
    assert code == 1 and "tiles" in line and "4.3 GB" in line and "16×16" in line, line
    assert peak < 300, peak


@pytest.mark.timeout(120)
def test_a_large_sparse_tiff_is_hashed_by_streaming(tmp_path):
    path = tmp_path / "big.tif"
    tifffile.imwrite(path, np.arange(64 * 80, dtype=np.uint16).reshape(64, 80), bigtiff=True)
    size = 1_500_000_000
    os.truncate(path, size)  # sparse: 1.5 GB long, a few kB on disk
    code, out, err, peak = run_limited(
        "import sys; from tamp_os.read import read_image; p = read_image(sys.argv[1]); print(p.file.sha256, p.values.shape)" + PEAK,
        path, limit_gb=1.0)
    assert code == 0, err
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 22), b""):
            digest.update(block)
    assert out.split()[0] == digest.hexdigest()
    assert peak < 250, f"peak {peak:.0f} MB: the file was held in memory"


@pytest.mark.timeout(300)
def test_the_working_estimate_bounds_the_measured_peak_of_a_conversion(tmp_path):
    """WORKING_BYTES_PER_PX is an upper bound of what a conversion really holds per source pixel."""
    from tamp_os.read_cost import WORKING_BYTES_PER_PX

    rng = np.random.default_rng(3)
    side = 3000
    grey = (rng.random((side, side)) * 255).astype(np.uint8)
    path = tmp_path / "rgb.png"
    Image.fromarray(np.stack([grey, grey[::-1], grey[:, ::-1]], -1)).save(path, compress_level=1)
    baseline_code = "import tamp_os.pipeline, tamp_os.outputs, tamp_os.export" + PEAK
    _, _, _, baseline = run_limited(baseline_code, limit_gb=2.0)
    code, _, err, peak = run_limited(cli_code("convert", path, "-o", tmp_path / "out", "--formats", "stl"), limit_gb=3.0,
                                     timeout_s=280)
    assert code == 0, err
    px = side * side
    priced_mb = (px * 3 + px * 3 + px * WORKING_BYTES_PER_PX) / 1e6
    assert peak - baseline < priced_mb, f"measured {peak - baseline:.0f} MB above the baseline, priced {priced_mb:.0f} MB"


def test_default_limits_agree_with_the_measured_cost():
    from tamp_os.params import LithoParams
    from tamp_os.read_cost import WORKING_BYTES_PER_PX

    p = LithoParams()
    # An 8-bit grey picture at the megapixel limit fits the memory limit (1 decoded + 1 copy + working bytes).
    assert p.max_megapixels * 1e6 * (2 + WORKING_BYTES_PER_PX) <= p.max_memory_gb * 1e9


@pytest.mark.timeout(60)
def test_caption_is_capped_by_length_and_by_the_plate_it_makes(tmp_path, capsys):
    img = small_png(tmp_path / "c.png")
    start = time.perf_counter()
    code, _, err = run(capsys, "convert", img, "-o", tmp_path / "out", "--caption", "a" * 1_000_000)
    assert time.perf_counter() - start < 5
    assert code == 1 and "at most 500" in one_error_line(err)
    code, _, err = run(capsys, "convert", img, "-o", tmp_path / "out", "--caption", "word " * 80)
    line = one_error_line(err)
    assert code == 1 and "deeper than the picture" in line and "--caption" in line, line
    code, out, err = run(capsys, "convert", img, "-o", tmp_path / "out", "--caption", "FePt spheres")
    assert code == 0, err


def test_a_caption_that_fits_keeps_the_plate_at_most_twice_as_deep():
    from tamp_os.tactile.braille import BrailleSpec
    from tamp_os.tactile.furniture import Furniture, plan_furniture

    spec = BrailleSpec()
    for words in range(1, 120):
        furniture = Furniture(spec=spec, caption=" ".join(["⠁⠃⠉"] * words), corner_cut=False)
        try:
            plan = plan_furniture(100.0, 60.0, furniture)
        except Exception as exc:
            assert "deeper than the picture" in str(exc)
            break
        box = plan.placed.caption_box
        assert box[3] - box[1] <= 60.0
    else:
        pytest.fail("a caption of 119 words never hit the cap")


# --- 2. no super-linear parsing: each parser, 1 MB of adversarial text, under 1 s ------------------

MB = 1_000_000


def _timed(fn, *args) -> float:
    start = time.perf_counter()
    fn(*args)
    return time.perf_counter() - start


ADVERSARIAL_XML = {
    "unclosed_channel": "<OME>" + "<Channel" + " a" * (MB // 2),
    "long_comment": "<OME><!--" + " Channel Name" * (MB // 13) + "--><Channel Name=\"DAPI\"/></OME>",
    "many_attributes": "<OME><Channel " + " ".join(f"a{i}=\"x\"" for i in range(MB // 10)) + " Name=\"GFP\"/></OME>",
    "entity_bomb": "<?xml version=\"1.0\"?><!DOCTYPE l [<!ENTITY a \"" + "a" * 1000 + "\">" + "".join(
        f"<!ENTITY a{i} \"&a{i - 1 if i else ''};&a{i - 1 if i else ''};\">" for i in range(1, 30)) + "]><OME>&a29;</OME>",
}


@pytest.mark.timeout(60)
@pytest.mark.parametrize("case", sorted(ADVERSARIAL_XML))
def test_ome_xml_parsing_is_linear(case):
    from tamp_os.clean.scale import read_pixel_size
    from tamp_os.read import _channel_names

    text = ADVERSARIAL_XML[case]
    assert len(text) >= MB * 0.9 or case == "entity_bomb"
    assert _timed(_channel_names, {"ome_metadata": text}) < 1.0
    assert _timed(read_pixel_size, {"ome_metadata": text}, {}, None, 100) < 1.0
    names = _channel_names({"ome_metadata": text})
    assert names == {"long_comment": ["DAPI"], "many_attributes": ["GFP"]}.get(case, [])


@pytest.mark.timeout(60)
def test_channel_names_of_real_ome_xml_by_the_parser():
    from tamp_os.xmltext import ome_channel_names

    xml = ('<?xml version="1.0"?><OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06"><Image><Pixels>'
           '<Channel ID="C0" Name="DAPI"/><Channel ID="C1"/><Channel ID="C2" Name="Alexa &amp; 488"/></Pixels></Image></OME>')
    assert ome_channel_names(xml) == ["DAPI", "Alexa & 488"]


@pytest.mark.timeout(120)
def test_an_ome_tiff_with_a_long_comment_reads_quickly(tmp_path):
    from tamp_os.read import read_image

    path = tmp_path / "long.ome.tif"
    data = np.random.default_rng(0).integers(0, 60000, (2, 32, 40), dtype=np.uint16)
    tifffile.imwrite(path, data, ome=True, metadata={"axes": "CYX", "Channel": {"Name": ["DAPI", "GFP"]}})
    with tifffile.TiffFile(path) as tif:
        xml = tif.ome_metadata
    padded = xml.replace("<Image ", "<!--" + " <Channel" * 60_000 + " --><Image ", 1)
    tifffile.tiffcomment(path, padded.encode())
    start = time.perf_counter()
    picture = read_image(path, channel="GFP")
    assert time.perf_counter() - start < 3.0
    assert np.array_equal(picture.values, data[1].astype(np.float32))


SIDECAR_CASES = {
    "blank_lines": "\n" * MB,
    "spaces_one_line": " " * MB,
    "dollars": "$" * MB,
    "key_prefix_repeated": "PixelSize" * (MB // 9),
    "jeol_marker_spaces": "$$SM_MICRON_MARKER" + " " * MB + "x",
    "many_keys": "$$SM_MICRON_BAR \n" * (MB // 17),
}


@pytest.mark.timeout(60)
@pytest.mark.parametrize("case", sorted(SIDECAR_CASES))
def test_line_sidecars_are_read_in_linear_time(tmp_path, case):
    from tamp_os.clean.scale import read_pixel_size

    image = tmp_path / "sem.tif"
    image.write_bytes(b"")
    (tmp_path / "sem.txt").write_text(SIDECAR_CASES[case][:MB])
    (tmp_path / "sem.hdr").write_text("[MAIN]\n" + SIDECAR_CASES[case][:MB - 7])
    start = time.perf_counter()
    found = read_pixel_size({}, {}, str(image), 100)
    assert time.perf_counter() - start < 1.0
    assert found.metres is None


@pytest.mark.timeout(60)
def test_a_sidecar_larger_than_a_sidecar_can_be_is_ignored_with_a_warning(tmp_path):
    from tamp_os.clean.scale import read_pixel_size

    image = tmp_path / "h.tif"
    image.write_bytes(b"")
    (tmp_path / "h.txt").write_text("PixelSize=2.5\n" + "x" * 2 * MB)
    found = read_pixel_size({}, {}, str(image), 100)
    assert found.metres is None and any("too large for a microscope sidecar" in w for w in found.warnings)


@pytest.mark.timeout(60)
def test_length_text_from_a_file_is_refused_before_its_pattern_runs():
    from tamp_os.errors import ParameterError
    from tamp_os.units import parse_length_m

    for text in ("1" * MB, "1." + "1" * MB, " " * MB + "nm"):
        start = time.perf_counter()
        with pytest.raises(ParameterError, match="cannot read"):
            parse_length_m(text)
        assert time.perf_counter() - start < 1.0


@pytest.mark.timeout(60)
def test_ini_sidecar_parsing_is_linear():
    from tamp_os.clean.vendor import ini_sections

    for text in ("[MAIN]\n" + "a=b\n" * (MB // 4), "[" * MB, "[MAIN]\n" + "=" * MB, "[MAIN]\nPixelSizeX=" + "1" * MB):
        assert _timed(ini_sections, text) < 1.0
