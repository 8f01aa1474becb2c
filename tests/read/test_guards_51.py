"""Issue 51, items 1 and 4: small inputs that cost a lot, priced (or bounded) before the work.

Each hostile input is built in milliseconds (tests/bomb_builders.py) and given to the command line
in a child process: one error line naming the file, exit 1, no traceback, nothing written, a
bounded peak RSS (decoding would take GBs) and time; where the napari reader takes the input,
through it too. The neighbours (the same layout at an honest size) still read, and the price the
guard computes is at least the peak the read really takes (measured in a child: VmHWM).
"""

import struct
import textwrap
from pathlib import Path

import numpy as np
import pytest
from bomb_builders import ome_zarr_in_one_chunk, tiff_in_one_tile, velox_in_one_chunk
from cli_support import PEAK, read_peak, run_limited
from conftest import need_module
from test_vendor_bounds import PEAK_RSS_MB, assert_refused

VELOX = "real/velox_talos_haadf_particles.emd"
# Time bounds, generous (docs/testing.md: a loaded machine must not fail them), each far below the
# work the refusal saves (7-60 s of decoding or counting, measured in benchmarks/bench_guards.py):
READERS = "import zarr, h5py, tifffile, rsciio.emd, dask.array"  # imported before the read is measured


def napari_refuses(path: Path, *needles, limit_gb: float = 1.5) -> tuple[str, float, float]:
    """The napari reader takes `path` and refuses it with one InputError line naming it and each
    needle, in a child under an address-space limit (decoding would need GBs): (line, MB, s)."""
    code = textwrap.dedent("""
        import sys, time
        from tamp_os.errors import InputError
        from tamp_os.napari.reader import napari_get_reader
        read = napari_get_reader(sys.argv[1])
        print('TAKEN', read is not None, file=sys.stderr)
        t0 = time.perf_counter()
        try:
            read(sys.argv[1])
            print('READ', file=sys.stderr)
        except InputError as exc:
            print('REFUSED', str(exc), file=sys.stderr)
        print('SECONDS', time.perf_counter() - t0, file=sys.stderr)
        """) + PEAK
    code_, _, err, peak = run_limited(code, path, limit_gb=limit_gb)
    lines = {line.split()[0]: line for line in err.splitlines() if line.split()}
    assert code_ == 0 and "Traceback" not in err, err
    assert lines["TAKEN"] == "TAKEN True", err
    refused = lines.get("REFUSED", "")
    assert refused and "\n" not in refused, err
    for needle in (str(path), *needles):
        assert needle in refused, (needle, refused)
    seconds = float(lines["SECONDS"].split()[1])
    assert peak < PEAK_RSS_MB, (peak, seconds)
    return refused, peak, seconds


# --- item 1: a chunk far larger than its array, and chunks priced with the copies a decoder holds ------

@pytest.mark.timeout(120)
def test_ome_zarr_array_in_one_written_chunk_just_under_the_cap_is_refused(tmp_path):
    """1.56 MB on disk, 1.6 GB decoded (under the 2 GB cap): it took 15 s and 3.2 GB, for a flat plate."""
    path = ome_zarr_in_one_chunk(tmp_path / "upload.zarr", 40000)
    assert sum(f.stat().st_size for f in path.rglob("*")) < 2_000_000
    _, mb, seconds = assert_refused(tmp_path, path, "OME-Zarr", "1×1×64×64 array stored in chunks of 1×1×40000×40000",
                                    "1.6 GB", "never needed", "write it again")
    assert mb < PEAK_RSS_MB, (mb, seconds)


@pytest.mark.timeout(120)
def test_velox_image_in_one_written_chunk_just_under_the_cap_is_refused(tmp_path, fixture):
    """A real Velox file whose 64×64 image is one 30000² uint16 gzip chunk (1.8 GB decoded): it was read, 25 s."""
    path = velox_in_one_chunk(tmp_path / "upload.emd", fixture(VELOX), 30000)
    assert path.stat().st_size < 5_000_000
    _, mb, seconds = assert_refused(tmp_path, path, "EMD", "64×64×1 array stored in chunks of 30000×30000×1", "1.8 GB",
                                    "never needed", "export it again from Velox")
    assert mb < PEAK_RSS_MB, (mb, seconds)


@pytest.mark.timeout(120)
def test_tiff_in_one_written_tile_just_under_the_cap_is_refused(tmp_path):
    """The same bomb as a TIFF: 16×16 pixels in one written 40000² zlib tile (it took 1.7 GB)."""
    path = tiff_in_one_tile(tmp_path / "upload.tif", 40000)
    _, mb, seconds = assert_refused(tmp_path, path, "16×16 pixels", "1.6 GB", "never needed")
    assert mb < PEAK_RSS_MB, (mb, seconds)


@pytest.mark.timeout(120)
def test_napari_reader_refuses_the_chunk_bombs(tmp_path, fixture):
    need_module("zarr")
    zarr_line, _, _ = napari_refuses(ome_zarr_in_one_chunk(tmp_path / "upload.zarr", 40000), "40000×40000", "never needed")
    emd_line, _, _ = napari_refuses(velox_in_one_chunk(tmp_path / "upload.emd", fixture(VELOX), 30000), "30000×30000",
                                    "never needed")
    assert "OME-Zarr" in zarr_line and "EMD" in emd_line


@pytest.mark.timeout(120)
@pytest.mark.parametrize("zarr_format", [2, 3])
def test_ome_zarr_chunks_are_priced_with_three_copies(tmp_path, zarr_format):
    """A 2000×2000 array in 2000² chunks (4 MB each) reads under the cap; priced at three copies
    (12 MB) it is refused under a 0.01 GB cap that the chunk alone (4 MB) would pass."""
    from test_vendor_bounds import small_ome_zarr

    path = small_ome_zarr(tmp_path / "upload.zarr", chunks=(1, 1, 2000, 2000), shape=(1, 1, 2000, 2000), zarr_format=zarr_format)
    line, _, _ = assert_refused(tmp_path, path, "chunks of 1×1×2000×2000 values, 4 MB each", "holds 12 MB", "limit of 0.01 GB",
                                extra=("--max-decoded-gb", "0.01"))
    assert "never needed" not in line


@pytest.mark.timeout(300)
@pytest.mark.parametrize("case", ["zarr", "emd", "tiff"])
def test_a_chunk_a_little_larger_than_its_array_still_reads_and_its_price_covers_the_peak(tmp_path, fixture, case):
    """Neighbours: a pyramid's small level keeps the writer's chunk size, so a chunk larger than its
    array is allowed up to CHUNK_PAST_DATA_FREE_BYTES. Read in a child, the read's peak (above the
    process before it) is at most the guard's price, and at least half the chunk (it is decoded)."""
    from tamp_os.read.cost import (CHUNK_PAST_DATA_FREE_BYTES, HDF5_CHUNK_COPIES, ZARR_CHUNK_COPIES, chunk_bytes,
                                   tiff_chunk_bytes)

    if case == "zarr":
        need_module("zarr")
        side = 6000  # 36 MB
        path, chunk = ome_zarr_in_one_chunk(tmp_path / "level.zarr", side), side * side
        price = chunk_bytes((1, 1, 64, 64), (1, 1, side, side), 1, copies=ZARR_CHUNK_COPIES)
    elif case == "emd":
        side = 5000  # 50 MB of uint16
        path, chunk = velox_in_one_chunk(tmp_path / "level.emd", fixture(VELOX), side), side * side * 2
        price = chunk_bytes((64, 64, 1), (side, side, 1), 2, copies=HDF5_CHUNK_COPIES)
    else:
        import tifffile

        side = 6000
        path, chunk = tiff_in_one_tile(tmp_path / "level.tif", side), side * side
        with tifffile.TiffFile(path) as tif:
            price = tiff_chunk_bytes(tif.pages[0]) + 4e6  # the tile, its compressed bytes, the reader's objects (READER_BYTES)
    assert chunk < CHUNK_PAST_DATA_FREE_BYTES
    outcome, _, peak_mb = read_peak(path, imports=READERS)
    assert outcome == "OK", outcome
    print(f"{case}: chunk {chunk / 1e6:.0f} MB, price {price / 1e6:.0f} MB, peak {peak_mb * 2**20 / 1e6:.0f} MB")
    assert chunk / 2 < peak_mb * 2**20 <= price


@pytest.mark.timeout(300)
def test_each_refusal_takes_milliseconds_once_the_readers_are_imported(tmp_path, fixture):
    """The refusals above, timed alone in a child: from the headers, before a chunk is decoded."""
    need_module("zarr")
    for path in (ome_zarr_in_one_chunk(tmp_path / "upload.zarr", 40000), tiff_in_one_tile(tmp_path / "upload.tif", 40000),
                 velox_in_one_chunk(tmp_path / "upload.emd", fixture(VELOX), 30000)):
        outcome, seconds, peak_mb = read_peak(path, call="read_image(sys.argv[1])", imports=READERS, limit_gb=1.5)
        print(f"{path.name}: {seconds * 1000:.0f} ms, {peak_mb:.1f} MB: {outcome[:120]}")
        assert outcome.startswith("ERROR InputError") and "never needed" in outcome, outcome
        assert peak_mb < 20, (path.name, seconds, peak_mb)


def test_the_chunk_rule_spares_pyramid_levels_and_refuses_bombs():
    from tamp_os.read.cost import chunk_past_data

    assert not chunk_past_data((1, 1, 100, 100), (1, 1, 1024, 1024), 2)  # a small level in the writer's chunk: 2 MB
    assert not chunk_past_data((4000, 4000), (4096, 4096), 4)  # rounded up: 67 MB, 1.05 times the data
    assert chunk_past_data((64, 64), (40000, 40000), 1)
    assert chunk_past_data((64, 64, 1), (30000, 30000, 1), 2)
    assert not chunk_past_data((64, 64), (64, 64, 1), 1)  # a malformed rank: left to the reader


# --- item 4: small inputs that cost a lot elsewhere --------------------------------------------------

def run_convert(tmp_path, path, *argv, timeout_s: float = 240) -> tuple[int, str, float, float, Path]:
    """The CLI's convert in a child: (exit code, stderr, peak MB, seconds in main(), the output folder)."""
    from cli_support import run_cli_child

    out = tmp_path / "out"
    code, err, mb, seconds, _ = run_cli_child("convert", path, "-o", out, *argv, timeout_s=timeout_s)
    assert "Traceback" not in err, err
    print(f"{path.name} {' '.join(argv)}: exit {code}, {mb:.0f} MB peak, {seconds:.1f} s in main()")
    return code, err, mb, seconds, out


@pytest.mark.timeout(300)
def test_a_checkerboard_tour_prices_its_regions_before_outlining_them(tmp_path):
    """A 1000² checkerboard PNG of a few hundred bytes raises 1,250 squares: each made a whole-picture
    mask before the tour kept 40 (1.4 GB at 1000 grid points; the issue's 87 s and 1.5 GB)."""
    from bomb_builders import checkerboard_png

    png = checkerboard_png(tmp_path / "board.png", 1000, 20)
    assert png.stat().st_size < 30_000
    code, err, mb, _, out = run_convert(tmp_path, png, "--formats", "ebraille,tour", "--resolution-px", "1000")
    assert code == 0, err
    tour = (out / "board.tour.html").read_text()
    assert "40 regions on the picture (the largest; 1208 smaller ones are left out of the tour)" in tour
    assert (out / "board.ebrl").stat().st_size > 0
    assert mb < 700, f"peak {mb:.0f} MB"


@pytest.mark.timeout(300)
def test_a_checkerboard_pin_refusal_comes_without_a_pass_over_the_picture_per_square(tmp_path):
    """The pin pages placed each square with two passes over the whole picture, page after page
    (46 s before the refusal); now its areas and centres are counted once per page."""
    from bomb_builders import checkerboard_png

    png = checkerboard_png(tmp_path / "board.png", 1000, 20)
    code, err, _, _, out = run_convert(tmp_path, png, "--formats", "dotpad,graphiti,monarch", "--resolution-px", "1000")
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert code == 1 and len(errors) == 1 and "finer than a pin on every page" in errors[0], err
    assert not out.exists() or not any(out.iterdir())


class CountedLabels(np.ndarray):
    """A label picture that counts the whole-picture comparisons made with it (labels == v)."""

    compared = 0
    whole: tuple = ()

    def __eq__(self, other):
        if np.ndim(other) == 0 and self.shape == CountedLabels.whole:
            CountedLabels.compared += 1
        return super().__eq__(other)

    __hash__ = None


def test_pin_pages_place_labels_without_a_whole_picture_pass_per_label():
    from skimage.measure import label as cc_label
    from tamp_os.export.pins import DEVICES, Layer, PinSource, pin_pages
    from tamp_os.params import LithoParams

    squares = (np.indices((400, 400)) // 8).sum(axis=0) % 2 == 1
    labels = cc_label(squares, connectivity=1).view(CountedLabels)  # 1,250 members
    CountedLabels.whole = labels.shape
    source = PinSource(labels.shape, [Layer("members", "raised parts", labels)], 0.5, "board", "board", LithoParams().braille_table)
    CountedLabels.compared = 0
    try:
        pin_pages(source, DEVICES["dotpad"])
    except Exception:  # too fine for the pins: refused, as the CLI does; the pages were made first
        pass
    assert CountedLabels.compared == 0  # was one per label on every page (14,000 at 1000² px: 17 s)


def test_pieces_are_counted_from_labels_and_only_the_kept_get_a_mask_of_their_own_box():
    from tamp_os.export.pins import Layer
    from tamp_os.export.regions import MAX_PICTURE_REGIONS, _kept_pieces

    from skimage.measure import label as cc_label

    squares = (np.indices((1000, 1000)) // 10).sum(axis=0) % 2 == 1
    labels = cc_label(squares, connectivity=1)  # 5,000 squares of 100 px (1 mm² at 0.1 mm a pixel)
    labels[:40, :40] = 0
    labels[5:35, 5:35] = labels.max() + 1  # one larger piece: kept first
    count = len(np.unique(labels)) - 1
    pieces, left_out = _kept_pieces([Layer("members", "raised parts", labels)], labels.shape, (0.1, 0.1))
    assert len(pieces) == MAX_PICTURE_REGIONS and left_out == count - MAX_PICTURE_REGIONS == 4953
    assert pieces[0].area_px == 900 and pieces[0].mask.shape == (30, 30) and pieces[0].mask.all()
    assert all(p.mask.shape == (10, 10) for p in pieces[1:])  # its own box, not the picture


def test_outlines_keep_a_bounded_number_of_parts_the_largest_first():
    from tamp_os.export.regions import MAX_OUTLINE_PARTS, _outline_budget

    assert _outline_budget([3, 5]) == 5  # under the budget: everything
    keep = _outline_budget([5000, 10, 10])
    assert sum(min(n, keep) for n in (5000, 10, 10)) <= MAX_OUTLINE_PARTS < sum(min(n, keep + 1) for n in (5000, 10, 10))
    assert keep == MAX_OUTLINE_PARTS - 20


def test_label_stats_are_the_per_label_areas_and_centres():
    from tamp_os.export.pins import _label_stats

    labels = np.random.default_rng(1).integers(0, 30, (57, 83))
    areas, centres = _label_stats(labels)
    for v in (1, 7, 29):
        ys, xs = np.nonzero(labels == v)
        assert areas[v] == ys.size and centres[v][0] == ys.mean() and centres[v][1] == xs.mean()


@pytest.mark.timeout(300)
def test_a_czi_of_100_channels_reads_and_measures_at_most_eight(tmp_path, monkeypatch):
    """Each channel was read, put on the grid and measured to choose 3: 100 of them took 45 s."""
    from bomb_builders import czi_many_channels
    from tamp_os.relief import channels as relief_channels
    from tamp_os.relief.channel_stage import MAX_CHANNELS_MEASURED

    path = czi_many_channels(tmp_path / "many.czi", 100, 128)
    code, err, _, _, out = run_convert(tmp_path, path)
    assert code == 0, err
    text = (out / "many.description.txt").read_text()
    assert f"The picture has 100 channels; {MAX_CHANNELS_MEASURED} were read and measured" in text
    assert f"the other {100 - MAX_CHANNELS_MEASURED} not" in text and "Of the 8 channels measured, the 3" in text
    measured = []
    real = relief_channels.measure_shape
    monkeypatch.setattr(relief_channels, "measure_shape", lambda img, *a, **k: measured.append(1) or real(img, *a, **k))
    from tamp_os.read.vendor import plan

    planes = []
    project = plan._project
    monkeypatch.setattr(plan, "_project", lambda stack, t, c, zs: planes.append(c) or project(stack, t, c, zs))
    from tamp_os.lithograph.convert import convert

    convert(path, None, tmp_path / "again")
    assert len(measured) == MAX_CHANNELS_MEASURED and len(set(planes) - {0}) <= MAX_CHANNELS_MEASURED, (measured, planes)


def test_the_channels_picked_are_named_ones_first_then_in_order():
    from tamp_os.errors import ParameterError
    from tamp_os.read.vendor.model import Channel
    from tamp_os.relief.channel_stage import MAX_CHANNELS_MEASURED, ChannelPick

    few = [Channel(f"c{i}") for i in range(MAX_CHANNELS_MEASURED)]
    assert ChannelPick({})(few) == list(range(MAX_CHANNELS_MEASURED))
    many = [Channel(f"c{i}") for i in range(40)] + [Channel("DAPI"), Channel("x", emission_nm=520.0)]
    pick = ChannelPick({})
    chosen = pick(many)
    assert pick.total == 42 and len(chosen) == MAX_CHANNELS_MEASURED and {40, 41} <= set(chosen) and chosen[:2] == [0, 1]
    assert ChannelPick({"c33": "domes", "dapi": "dots"})(many) == [33, 40]
    with pytest.raises(ParameterError, match="no channel named nope"):
        ChannelPick({"nope": "domes"})(many)


@pytest.mark.timeout(300)
def test_napari_reads_a_czi_of_100_channels_as_its_layers_in_bounded_time(tmp_path):
    from bomb_builders import czi_many_channels

    path = czi_many_channels(tmp_path / "many.czi", 100, 64)
    code = textwrap.dedent("""
        import sys, time
        from tamp_os.napari.reader import napari_get_reader
        t0 = time.perf_counter()
        layers = napari_get_reader(sys.argv[1])(sys.argv[1])
        print('LAYERS', len(layers), len({k['name'] for _, k, _ in layers}), file=sys.stderr)
        print('SECONDS', time.perf_counter() - t0, file=sys.stderr)
        """) + PEAK
    status, _, err, peak = run_limited(code, path, limit_gb=2.0)
    found = {line.split()[0]: line.split()[1:] for line in err.splitlines() if line.split()}
    assert status == 0 and "Traceback" not in err, err
    assert found["LAYERS"] == ["100", "100"] and peak < 500, (found, peak)


@pytest.mark.timeout(120)
def test_napari_reader_refuses_the_elid_bombs_from_their_layout(tmp_path):
    from bomb_builders import elid_declaring_a_tiff, elid_zero_bomb

    bomb, record = tmp_path / "bomb.elid", tmp_path / "record.elid"
    bomb.write_bytes(elid_zero_bomb(2 * 10**9))
    record.write_bytes(elid_declaring_a_tiff(0xFFFFFFFF, 10**9))
    napari_refuses(bomb, "Phenom ELID", "no image in it")
    napari_refuses(record, "record of 4,294,967,295 bytes", "8.6 GB")


@pytest.mark.timeout(120)
def test_the_elid_refusals_take_milliseconds_once_rosettasciio_is_imported(tmp_path):
    from bomb_builders import elid_declaring_a_tiff, elid_zero_bomb

    for name, data in (("bomb.elid", elid_zero_bomb(2 * 10**9)), ("record.elid", elid_declaring_a_tiff(0xFFFFFFFF, 10**9)),
                       ("no_tiff.elid", elid_declaring_a_tiff(900_000_000, 10**9))):
        path = tmp_path / name
        path.write_bytes(data)
        outcome, seconds, peak_mb = read_peak(path, call="read_image(sys.argv[1])", imports="import rsciio.phenom", limit_gb=1.5)
        print(f"{name}: {seconds * 1000:.0f} ms, {peak_mb:.1f} MB: {outcome[:140]}")
        assert outcome.startswith("ERROR InputError"), outcome
        assert peak_mb < 20, (name, seconds, peak_mb)


@pytest.mark.timeout(120)
def test_the_values_an_elid_read_holds_are_priced_against_the_memory_limit(tmp_path, fixture):
    """The real project's 1.7 million values are priced at 40 B each (77 MB with the decompressor):
    under a 0.05 GB memory limit it is refused while reading, in one line naming that limit."""
    path = fixture("real/phenom_elid2v4.elid")
    line, _, _ = assert_refused(tmp_path, path, "values read by byte", "limit of 0.05 GB on the memory", "--max-memory-gb",
                                extra=("--max-memory-gb", "0.05"))
    assert "max-decoded-gb" not in line


def test_an_elid_with_more_values_than_max_reads_is_refused_while_reading(fixture, monkeypatch):
    from tamp_os.errors import InputError
    from tamp_os.read.model import Limits
    from tamp_os.read.vendor import rsci

    monkeypatch.setattr(rsci, "MAX_READS", 100_000)
    with pytest.raises(InputError, match="holds more than 100,000 values"):
        rsci.read_elid(fixture("real/phenom_elid2v4.elid"), Limits(400.0, 2.0))
