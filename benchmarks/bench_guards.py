"""Bounded work on hostile input, timed: each parser on 1 MB of adversarial text, a 1,000,000
character caption, a 450 KB OME comment, and a single picture offered to the web app's panel
chooser. The tests (tests/test_reliability.py, test_gui_panels.py) check what each returns and
catch a hang with their timeout; the times, and the bound each should stay under on a quiet
2-core machine, are here: the first call's CPU time in this process.

Then the small inputs that cost a lot (issue 51, tests/read/test_guards_51.py): each built in
milliseconds (tests/bomb_builders.py) and given to the command line in a child process, with its
time in main() and peak RSS, the guard's price beside the true peak (the read measured alone, in a
child, with the guard lifted: VmHWM above the process before it; the price must be at least it),
and with --before REV the same command run on that revision's source (git archive).

    PYTHONPATH=src .venv/bin/python benchmarks/bench_guards.py [--before REV] [--only WORD]
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from cli_support import ADVERSARIAL_XML, MB, SIDECAR_CASES  # noqa: E402


def first_cpu_s(fn) -> float:
    """The first call's CPU time: the parsers cache by text, so a repeat would time the cache."""
    start = time.process_time()
    fn()
    return time.process_time() - start


def cases(tmp: Path):
    from tamp_os.clean.scale import read_pixel_size
    from tamp_os.clean.vendor import ini_sections
    from tamp_os.errors import ParameterError
    from tamp_os.read.model import file_channel_names
    from tamp_os.units import parse_length_m

    for name, text in sorted(ADVERSARIAL_XML.items()):
        yield f"OME-XML {name}: channel names", 1.0, lambda text=text: file_channel_names({"ome_metadata": text})
        yield f"OME-XML {name}: pixel size", 1.0, lambda text=text: read_pixel_size({"ome_metadata": text}, {}, None, width_px=100)
    image = tmp / "sem.tif"
    image.write_bytes(b"")
    for name, text in sorted(SIDECAR_CASES.items()):
        def sidecar(text=text):
            (tmp / "sem.txt").write_text(text[:MB])
            (tmp / "sem.hdr").write_text("[MAIN]\n" + text[:MB - 7])
            read_pixel_size({}, {}, str(image), width_px=100)
        yield f"sidecar {name}", 1.0, sidecar

    def lengths():
        for text in ("1" * MB, "1." + "1" * MB, " " * MB + "nm"):
            try:
                parse_length_m(text)
            except ParameterError:
                pass
    yield "length text of 1 MB (3 cases)", 1.0, lengths

    def ini():
        for text in ("[MAIN]\n" + "a=b\n" * (MB // 4), "[" * MB, "[MAIN]\n" + "=" * MB, "[MAIN]\nPixelSizeX=" + "1" * MB):
            ini_sections(text)
    yield "INI sidecar of 1 MB (4 cases)", 1.0, ini

    from figures import synthetic_texture
    from tamp_os.gui.panel_choice import find_panels

    single = synthetic_texture(300, 400, 7).astype(np.float32) / 255
    yield "web app: a single 400x300 picture offered for panels", 0.5, lambda: find_panels(single, tmp / "none", 4)


# --- issue 51: small inputs that cost a lot -----------------------------------------------------------

VELOX = ROOT.parent / "shared" / "fixtures" / "real" / "velox_talos_haadf_particles.emd"
READERS = "import zarr, h5py, tifffile, rsciio.emd, rsciio.phenom, dask.array"
LIFTED = ("import tamp_os.read.cost as c, tamp_os.read.model as m; "
          "c.CHUNK_PAST_DATA_FREE_BYTES = m.CHUNK_PAST_DATA_FREE_BYTES = float('inf'); "
          "read_image(sys.argv[1], max_decoded_gb=1000, max_memory_gb=1000)")
ELID_LIFTED = "read_image(sys.argv[1], max_decoded_gb=1000, max_memory_gb=1000)"  # the bounded reader, its cap lifted


def zarr_price(path: Path, out: Path) -> tuple[float, str]:
    import zarr

    from tamp_os.read.cost import ZARR_CHUNK_COPIES, chunk_bytes

    array = zarr.open_group(str(path), mode="r")["0"]
    n = chunk_bytes(array.shape, array.chunks, array.dtype.itemsize, copies=ZARR_CHUNK_COPIES)
    return n, f"chunk × {ZARR_CHUNK_COPIES} copies"


def velox_price(path: Path, out: Path) -> tuple[float, str]:
    import h5py

    from tamp_os.read.cost import HDF5_CHUNK_COPIES, chunk_bytes

    with h5py.File(path, "r") as f:
        names: list = []
        f.visit(names.append)
        data = f[next(n for n in names if n.startswith("Data/Image/") and n.endswith("/Data"))]
        n = chunk_bytes(data.shape, data.chunks, data.dtype.itemsize, copies=HDF5_CHUNK_COPIES)
    return n, f"chunk × {HDF5_CHUNK_COPIES} copies"


def tiff_price(path: Path, out: Path) -> tuple[float, str]:
    import math

    import tifffile

    from tamp_os.read.cost import READER_BYTES, tiff_chunk_bytes, working_bytes

    with tifffile.TiffFile(path) as tif:
        page = tif.pages[0]
        n = tiff_chunk_bytes(page) + math.prod(page.shape) * page.dtype.itemsize + working_bytes(*page.shape[:2]) + READER_BYTES
    return n, "tile + compressed tile + pixels + working + reader"


def elid_price(path: Path, out: Path) -> tuple[float, str]:
    """What the bounded reader charges under the default limits by the time it ends, stops or refuses."""
    from tamp_os.read.vendor.rsci import ElidRefused, bounded_reader_class

    cls = bounded_reader_class()
    reader = cls.__new__(cls)  # kept by name: its __init__ reads the project, and may raise
    try:
        reader.__init__(str(path), 2e9, 4e9)  # the default limits: max_decoded_gb 2, max_memory_gb 4
        return reader.held_bytes, "decompressor + values × 40 B"
    except ElidRefused as refused:
        kind, _, facts = refused.args
        return (reader.held_bytes, "decompressor + record × 2: refused") if kind == "record" else (reader.held_bytes, kind)
    except Exception:  # the read stopped where the record showed it is no TIFF
        return reader.held_bytes, "decompressor + record × 2: stopped"


def regions_counted(path: Path, out: Path) -> tuple[float | None, str]:
    """What the tour's region guard decided: the pieces counted from their labels, and those outlined."""
    import re

    tour = next(out.glob("*.tour.html"), None)
    found = re.search(r"(\d+) regions? on the picture(?: \(the largest; (\d+) smaller)?", tour.read_text()) if tour else None
    if not found:
        return None, "(no tour written)"
    from tamp_os.export.regions import MIN_REGION_MM2

    kept, left = int(found.group(1)), int(found.group(2) or 0)
    return None, f"{kept + left:,} pieces of ≥ {MIN_REGION_MM2:g} mm² priced from labels, {kept} outlined"


def channels_read(path: Path, out: Path) -> tuple[float | None, str]:
    import re

    text = next(out.glob("*.description.txt")).read_text()
    found = re.search(r"has (\d+) channels; (\d+) were read and measured", text)
    return None, f"{found.group(2)} of {found.group(1)} channels read and measured" if found else "(every channel read)"


def adversarial(tmp: Path):
    """(name, input words, path, CLI arguments, price function (path, output folder) -> (bytes or None,
    words) or None, the call whose true peak the price is held against, or None)."""
    import bomb_builders as b

    def words(path: Path) -> str:
        size = sum(f.stat().st_size for f in path.rglob("*")) if path.is_dir() else path.stat().st_size
        return f"{size / 1e6:.2f} MB" if size >= 1e5 else f"{size:,} B"

    z = b.ome_zarr_in_one_chunk(tmp / "chunk.zarr", 40000)
    yield "OME-Zarr 64×64 in one 40000² zlib chunk (1.6 GB)", words(z), z, (), zarr_price, LIFTED
    if VELOX.is_file():
        e = b.velox_in_one_chunk(tmp / "chunk.emd", VELOX, 30000)
        yield "Velox EMD 64×64 in one 30000² uint16 gzip chunk (1.8 GB)", words(e), e, (), velox_price, LIFTED
    t = b.tiff_in_one_tile(tmp / "tile.tif", 40000)
    yield "TIFF 16×16 in one written 40000² zlib tile (1.6 GB)", words(t), t, (), tiff_price, LIFTED
    bomb = tmp / "bomb.elid"
    bomb.write_bytes(b.elid_zero_bomb(2 * 10**9))
    yield "ELID bzip2 bomb: 2 GB of zeros, no image declared", words(bomb), bomb, (), elid_price, ELID_LIFTED
    record = tmp / "record.elid"
    record.write_bytes(b.elid_declaring_a_tiff(0xFFFFFFFF, 10**9))
    yield "ELID declaring a 4.3 GB TIFF record, then 1 GB of zeros", words(record), record, (), elid_price, ELID_LIFTED
    no_tiff = tmp / "no_tiff.elid"
    no_tiff.write_bytes(b.elid_declaring_a_tiff(900_000_000, 10**9))
    yield "ELID declaring a 0.9 GB TIFF record of zeros (under the cap)", words(no_tiff), no_tiff, (), elid_price, ELID_LIFTED
    real = VELOX.parent / "phenom_elid2v4.elid"
    if real.is_file():
        yield "neighbour: the real Phenom ELID project (1.7 million values)", words(real), real, (), elid_price, ELID_LIFTED
    board = b.checkerboard_png(tmp / "board.png", 1000, 20)
    for argv in (("--formats", "ebraille,tour", "--resolution-px", "1000"), ("--formats", "dotpad,graphiti,monarch", "--resolution-px", "1000")):
        yield (f"checkerboard 1000² of 20 px squares, {argv[1]}", words(board), board, argv,
               regions_counted if "tour" in argv[1] else None, None)
    fine = b.checkerboard_png(tmp / "fine.png", 1000, 8)
    yield "checkerboard 1000² of 8 px squares, ebraille,tour --preset high", words(fine), fine, ("--formats", "ebraille,tour", "--preset", "high"), regions_counted, None
    czi = b.czi_many_channels(tmp / "many.czi", 100, 512)
    yield "CZI of 100 channels, 512² each", words(czi), czi, (), channels_read, None


def outcome_of(code: int, err: str) -> str:
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    if "Traceback" in err:
        return "TRACEBACK"
    return "refused" if code == 1 and len(errors) == 1 else "printed" if code == 0 else f"exit {code}"


def adversarial_table(before: str | None, only: str | None) -> None:
    from cli_support import read_peak, run_cli_child

    print()
    print("| case | input | before: s in main, MB peak | after: s in main, MB peak | refusal alone | price | true peak | price ≥ peak |")
    print("|---|---:|---|---|---:|---:|---:|:---:|")
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        old_src = checkout(before, tmp / "before") if before else None
        for name, size, path, argv, price_fn, true_call in adversarial(tmp):
            if only and only.lower() not in name.lower():
                continue
            out = tmp / "out"

            def cli(src):
                import shutil

                shutil.rmtree(out, ignore_errors=True)
                code, err, mb, seconds, _ = run_cli_child("convert", path, "-o", out, *argv, timeout_s=900, src=src)
                return f"{outcome_of(code, err)}, {seconds:.1f} s, {mb:,.0f} MB"

            was = cli(old_src) if old_src else "—"
            now = cli(str(ROOT / "src"))  # last: its output folder is what the counted prices read
            alone = "—"
            if "refused" in now and true_call is not None:  # a read's guard: its refusal timed alone, readers imported
                said, s_alone, _ = read_peak(path, call="read_image(sys.argv[1])", imports=READERS, limit_gb=2.0)
                alone = f"{s_alone * 1000:.0f} ms" if said.startswith("ERROR InputError") else f"not refused alone: {said[:30]}"
            price, how, peak, ok = "—", "", "—", ""
            if price_fn is not None:
                n, how = price_fn(path, out)
                price = how if n is None else f"{n / 1e9:.3g} GB ({how})" if n >= 1e6 else f"{n:,.0f} B ({how})"
                if true_call:
                    outcome, s_true, mb = read_peak(path, call=true_call, imports=READERS, limit_gb=12.0, timeout_s=900)
                    peak_bytes = mb * 2**20
                    peak = f"{peak_bytes / 1e9:.3g} GB in {s_true:.1f} s" if peak_bytes >= 1e6 else f"{peak_bytes / 1e6:.2f} MB in {s_true:.2f} s"
                    ok = "yes" if n >= peak_bytes else "NO"
            print(f"| {name} | {size} | {was} | {now} | {alone} | {price} | {peak} | {ok} |", flush=True)


def checkout(rev: str, folder: Path) -> str:
    """The package source of `rev`, unpacked from git (the worktree is left alone)."""
    import io
    import subprocess
    import tarfile

    data = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src"], capture_output=True, check=True).stdout
    tarfile.open(fileobj=io.BytesIO(data)).extractall(folder, filter="data")
    return str(folder / "src")


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="a revision to run the adversarial cases on too (e.g. main)")
    parser.add_argument("--only", help="only the adversarial cases whose name has this word")
    parser.add_argument("--no-parsers", action="store_true", help="skip the parsers' CPU table")
    args = parser.parse_args()
    if not args.no_parsers:
        print("| case | CPU s | bound s |")
        print("|---|---:|---:|")
        with tempfile.TemporaryDirectory() as folder:
            for name, bound, fn in cases(Path(folder)):
                print(f"| {name} | {first_cpu_s(fn):.3f} | {bound:g} |")
    adversarial_table(args.before, args.only)


if __name__ == "__main__":
    main()
