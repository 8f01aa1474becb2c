"""Issue 40: vendor readers safe as a server. Each hostile file is built here, in a temporary folder,
and refused from its headers: one clear line, exit 1, no traceback, nothing written, bounded
memory and time, and nothing read outside the file (or the OME-Zarr folder) given."""

import bz2
import json
import os
import shutil
import struct
import time

import numpy as np
import pytest
from conftest import FIXTURES, need_module
from cli_support import run_cli_child

PEAK_RSS_MB = 300
OUTSIDE = "refers to data outside this file"


# --- helpers -------------------------------------------------------------------------------------

def assert_refused(tmp_path, path, *needles, extra=()):
    """The CLI refuses `path` in one line naming it and each needle; exit 1, no traceback, nothing written;
    measured in a child process: peak RSS and wall time bounded. Returns (the error line, MB, seconds in main())."""
    out = tmp_path / "out"
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    code, err, mb, in_main, seconds = run_cli_child("convert", path, "-o", out, *extra)
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert code == 1, err
    assert len(errors) == 1 and "Traceback" not in err, err
    for needle in (str(path), *needles):
        assert needle in errors[0], (needle, errors[0])
    assert mb < PEAK_RSS_MB, f"peak RSS {mb:.0f} MB"
    assert not out.exists() or not any(out.iterdir())
    after = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p != out)
    assert after == before  # nothing written anywhere else (no partial file, no cache beside the input)
    print(f"{path.name}: {mb:.0f} MB peak, {in_main:.2f} s in main(), {seconds:.2f} s in all: {errors[0]}")
    return errors[0], mb, in_main


def secret_h5(folder):
    """Another HDF5 file on the 'server': what a hostile upload would like converted."""
    h5py = need_module("h5py")
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "secret.h5"
    with h5py.File(path, "w") as f:
        f["private"] = np.arange(64 * 64, dtype=np.uint16).reshape(64, 64)
    return path


def velox_like(path, fill):
    """An HDF5 file laid out as a Velox EMD (Data/Image/<uuid>/Data); `fill(group)` makes its Data."""
    h5py = need_module("h5py")
    with h5py.File(path, "w") as f:
        f.attrs["version_major"] = 0
        group = f.create_group("Data/Image/6fdbde41eecc4375b45cd86bd2be17c0")
        fill(group)
    return path


def hspy_like(path, fill):
    h5py = need_module("h5py")
    with h5py.File(path, "w") as f:
        f.attrs["file_format"] = "HyperSpy"
        f.attrs["file_format_version"] = "3.1"
        group = f.create_group("Experiments/HAADF")
        fill(group)
    return path


def hdf5_cases(tmp_path):
    h5py = need_module("h5py")
    secret = secret_h5(tmp_path / "elsewhere")

    def external_link(g):
        g["Data"] = h5py.ExternalLink(str(secret), "/private")

    def soft_to_external(g):
        g.file["hidden"] = h5py.ExternalLink(str(secret), "/private")
        g["Data"] = h5py.SoftLink("/hidden")

    def external_storage(g):
        raw = tmp_path / "elsewhere" / "raw.bin"
        raw.write_bytes(np.arange(64 * 64, dtype=np.uint16).tobytes())
        g.create_dataset("Data", shape=(64, 64), dtype=np.uint16, external=[(str(raw), 0, 64 * 64 * 2)])

    def virtual(g):
        layout = h5py.VirtualLayout(shape=(64, 64), dtype=np.uint16)
        layout[...] = h5py.VirtualSource(str(secret), "/private", shape=(64, 64))
        g.create_virtual_dataset("Data", layout)

    return {"external_link": external_link, "soft_link_to_an_external_link": soft_to_external,
            "external_storage": external_storage, "virtual_dataset": virtual}


# --- 1. no read outside the given input: HDF5 -------------------------------------------------------

@pytest.mark.timeout(120)
@pytest.mark.parametrize("case", ["external_link", "soft_link_to_an_external_link", "external_storage", "virtual_dataset"])
@pytest.mark.parametrize("layout", ["emd", "hspy"])
def test_hdf5_that_refers_outside_itself_is_refused(tmp_path, case, layout):
    fill = hdf5_cases(tmp_path)[case]
    path = (velox_like if layout == "emd" else hspy_like)(tmp_path / f"upload.{layout}", fill)
    assert_refused(tmp_path, path, OUTSIDE, "Export it as one file", "EMD" if layout == "emd" else "HyperSpy")


@pytest.mark.timeout(120)
def test_an_external_link_is_never_followed(tmp_path):
    """The link points at a FIFO: opening it would block until a writer came, so a reader that
    followed the link would hang here instead of refusing in a second."""
    h5py = need_module("h5py")
    fifo = tmp_path / "elsewhere" / "pipe.h5"
    fifo.parent.mkdir()
    os.mkfifo(fifo)
    path = velox_like(tmp_path / "upload.emd", lambda g: g.__setitem__("Data", h5py.ExternalLink(str(fifo), "/private")))
    assert_refused(tmp_path, path, OUTSIDE, "pipe.h5")


@pytest.mark.timeout(120)
def test_real_velox_file_whose_image_is_an_external_link_is_refused_before_rosettasciio(fixture, tmp_path, monkeypatch):
    """The threat as it was: a real Velox file whose image Data is replaced by an external link converted the
    other file's pixels. Now rosettasciio is never called."""
    h5py = need_module("h5py")
    need_module("rsciio")
    source = fixture("real/velox_talos_haadf_particles.emd")
    secret = secret_h5(tmp_path / "elsewhere")
    path = tmp_path / "upload.emd"
    shutil.copy(source, path)
    with h5py.File(path, "a") as f:
        names = []
        f["Data/Image"].visit(lambda n: names.append(n) if n.endswith("/Data") else None)
        data = f"Data/Image/{names[0]}"
        del f[data]
        f[data] = h5py.ExternalLink(str(secret), "/private")
    from tamp_os.errors import InputError
    from tamp_os.read.image import read_image
    from tamp_os.read.vendor import rsci

    monkeypatch.setattr(rsci, "_reader", lambda kind: pytest.fail("rosettasciio opened the file"))
    with pytest.raises(InputError, match=OUTSIDE) as info:
        read_image(path)
    assert "secret.h5" in str(info.value) and "Velox" in str(info.value)


@pytest.mark.timeout(120)
def test_real_files_with_a_soft_link_inside_still_read_the_same(fixture, tmp_path):
    """Soft links inside the file are allowed (they can lead out only through an external link, refused
    wherever it is): the real Velox and HyperSpy files, with one added, read exactly as before."""
    h5py = need_module("h5py")
    need_module("rsciio")
    from tamp_os.read.image import read_image

    for name in ("velox_talos_haadf_particles.emd", "stem_haadf_sio2_spheres.hspy"):
        source = fixture(f"real/{name}")
        before = read_image(source)
        copy = tmp_path / name
        shutil.copy(source, copy)
        with h5py.File(copy, "a") as f:
            first = next(iter(f.keys()))
            f["alias"] = h5py.SoftLink(f"/{first}")
        after = read_image(copy)
        np.testing.assert_array_equal(after.values, before.values)
        assert after.file.metadata["vendor"]["pixel_size_m"] == before.file.metadata["vendor"]["pixel_size_m"]


# --- 1. no read outside the given input: OME-Zarr ---------------------------------------------------

def small_ome_zarr(path, chunks=(1, 1, 32, 32), shape=(1, 1, 64, 64), zarr_format=2):
    zarr = need_module("zarr")
    group = zarr.open_group(str(path), mode="w", zarr_format=zarr_format)
    array = group.create_array("0", shape=shape, dtype=np.uint8, chunks=chunks, fill_value=0)
    if math_prod(chunks) <= 1 << 20:
        array[...] = (np.arange(math_prod(shape)) % 251).reshape(shape).astype(np.uint8)
    group.attrs["multiscales"] = [{"version": "0.4", "axes": [
        {"name": "c", "type": "channel"}, {"name": "z", "type": "space", "unit": "micrometer"},
        {"name": "y", "type": "space", "unit": "micrometer"}, {"name": "x", "type": "space", "unit": "micrometer"}],
        "datasets": [{"path": "0", "coordinateTransformations": [{"type": "scale", "scale": [1, 1, 0.5, 0.5]}]}]}]
    return path


def math_prod(shape):
    out = 1
    for n in shape:
        out *= n
    return out


@pytest.mark.timeout(120)
@pytest.mark.parametrize("case", ["chunk_file", "array_folder", "array_path"])
def test_ome_zarr_that_leads_out_of_its_folder_is_refused(tmp_path, case):
    path = small_ome_zarr(tmp_path / "in" / "upload.zarr")
    elsewhere = small_ome_zarr(tmp_path / "elsewhere" / "secret.zarr")
    if case == "chunk_file":
        chunk = path / "0" / "0.0.0.0"
        chunk.unlink()
        chunk.symlink_to(elsewhere / "0" / "0.0.0.0")
    elif case == "array_folder":
        shutil.rmtree(path / "0")
        (path / "0").symlink_to(elsewhere / "0", target_is_directory=True)
    else:
        attrs = json.loads((path / ".zattrs").read_text())
        attrs["multiscales"][0]["datasets"][0]["path"] = "../../elsewhere/secret.zarr/0"
        (path / ".zattrs").write_text(json.dumps(attrs))
    assert_refused(tmp_path, path, "refers to data outside this folder", "OME-Zarr")


@pytest.mark.timeout(120)
def test_ome_zarr_symlink_inside_its_folder_still_reads(tmp_path):
    from tamp_os.read.image import read_image

    path = small_ome_zarr(tmp_path / "upload.zarr")
    before = read_image(path).values
    chunk = path / "0" / "0.0.0.1"
    (path / "kept").mkdir()
    chunk.rename(path / "kept" / "0.0.0.1")
    chunk.symlink_to(path / "kept" / "0.0.0.1")
    np.testing.assert_array_equal(read_image(path).values, before)


@pytest.mark.timeout(120)
def test_hdf5_metadata_dataset_declared_huge_and_never_written_is_refused(tmp_path):
    """A 3.6 GB dataset that was never written costs nothing in the file; reading it (rosettasciio reads
    metadata arrays eagerly) allocates and fills all of it."""
    def fill(g):
        g.create_dataset("Data", data=np.zeros((64, 64, 1), np.uint16))
        g.create_dataset("Metadata", shape=(60000, 60000), dtype=np.uint8)

    path = velox_like(tmp_path / "upload.emd", fill)
    assert path.stat().st_size < 100_000
    assert_refused(tmp_path, path, "dataset Data/Image/6fdbde41eecc4375b45cd86bd2be17c0/Metadata of 60000×60000 values",
                   "3.6 GB in all", "limit of 2 GB", "--max-decoded-gb")


# --- 2. decoded cost priced before decoding: chunks ---------------------------------------------------

@pytest.mark.timeout(120)
@pytest.mark.parametrize("layout", ["emd", "hspy"])
def test_hdf5_small_dataset_in_one_huge_chunk_is_refused(tmp_path, layout):
    def fill(g):
        g.create_dataset("Data" if layout == "emd" else "data", shape=(64, 64), maxshape=(None, None), dtype=np.uint8,
                         chunks=(60000, 60000), compression="gzip")

    path = (velox_like if layout == "emd" else hspy_like)(tmp_path / f"upload.{layout}", fill)
    assert_refused(tmp_path, path, "64×64 array stored in chunks of 60000×60000", "3.6 GB", "never needed")


@pytest.mark.timeout(120)
@pytest.mark.parametrize("zarr_format", [2, 3])
def test_ome_zarr_small_array_in_one_huge_chunk_is_refused(tmp_path, zarr_format):
    path = small_ome_zarr(tmp_path / "upload.zarr", chunks=(1, 1, 60000, 60000), zarr_format=zarr_format)
    assert_refused(tmp_path, path, "1×1×64×64 array stored in chunks of 1×1×60000×60000", "3.6 GB", "never needed")


# --- 2. MRC: extended header and voxels against the file size ------------------------------------------

def mrc_bytes(nx=8, ny=8, nz=1, mode=2, nsymbt=0, data=None, order="<", stamp=b"\x44\x44"):
    header = bytearray(1024)
    struct.pack_into(order + "4i", header, 0, nx, ny, nz, mode)
    struct.pack_into(order + "3i", header, 28, 8, 8, 1)  # mx, my, mz
    struct.pack_into(order + "3f", header, 40, 8.0, 8.0, 1.0)  # cella
    struct.pack_into(order + "3f", header, 52, 90.0, 90.0, 90.0)
    struct.pack_into(order + "3i", header, 64, 1, 2, 3)  # mapc, mapr, maps
    struct.pack_into(order + "i", header, 92, nsymbt)
    header[208:212] = b"MAP "
    header[212:214] = stamp
    body = data if data is not None else np.arange(64, dtype=np.float32).tobytes()
    return bytes(header) + body


@pytest.mark.timeout(120)
@pytest.mark.parametrize("case, needles", [
    ("extended_header", ("extended header of 2,000,000,000 bytes", "2 GB")),
    ("voxels", ("60000×60000×100 voxels of 4 bytes (mode 2)", "1,440.0 GB", "2 GB")),
    ("voxels_big_endian", ("60000×60000×100 voxels of 4 bytes (mode 2)", "2 GB")),
    ("voxels_big_endian_with_a_wrong_stamp", ("60000×60000×100 voxels of 4 bytes (mode 2)", "2 GB")),
])
def test_mrc_header_declaring_more_than_the_file_is_refused(tmp_path, case, needles):
    path = tmp_path / "upload.mrc"
    if case == "extended_header":
        path.write_bytes(mrc_bytes(nsymbt=2_000_000_000))
    elif case == "voxels":
        path.write_bytes(mrc_bytes(60000, 60000, 100))
    else:
        stamp = b"\x11\x11" if case == "voxels_big_endian" else b"\x44\x44"
        path.write_bytes(mrc_bytes(60000, 60000, 100, order=">", stamp=stamp, data=np.zeros(64, ">f4").tobytes()))
    assert_refused(tmp_path, path, "MRC", *needles, "more than the ")


@pytest.mark.timeout(60)
def test_a_small_honest_mrc_still_reads(tmp_path):
    need_module("mrcfile")
    from tamp_os.read.image import read_image

    path = tmp_path / "ok.mrc"
    path.write_bytes(mrc_bytes())
    assert read_image(path).values.shape == (8, 8)


# --- 2. Phenom ELID: only what the layout declares is decompressed, in bounded pieces ------------------

@pytest.fixture(scope="module")
def elid_bomb():
    """A valid bzip2 stream of 1.4 kB that decompresses to 2 GB (the 'EID2' magic, then zeros: no image declared)."""
    from bomb_builders import elid_zero_bomb

    return elid_zero_bomb(2 * 10**9)


@pytest.mark.timeout(120)
def test_elid_bzip2_bomb_is_refused_from_its_declared_layout(tmp_path, elid_bomb):
    """The bomb's header declares no image: its 2 GB of zeros are never decompressed (counting them took 27 s)."""
    assert len(elid_bomb) < 5000
    path = tmp_path / "upload.elid"
    path.write_bytes(elid_bomb)
    assert_refused(tmp_path, path, "Phenom ELID", "no image in it")  # (counting took 15-60 s)


def test_elid_reading_keeps_pieces_small(tmp_path):
    """A TIFF record of 50 MB (a TIFF header, then zeros): decompressed in pieces of at most PIECE_BYTES."""
    import rsciio.phenom._api as api
    from bomb_builders import bzip2_zeros
    from tamp_os.read.model import Limits
    from tamp_os.read.vendor import rsci

    stream, size = bzip2_zeros(b"EID2" + struct.pack("<iII", 4, 1, 50_000_000) + b"II*\x00", 100_000_000)
    path = tmp_path / "record.elid"
    path.write_bytes(stream)
    seen = []
    real = api.bz2.BZ2Decompressor

    class Spy:
        def __init__(self):
            self.inner = real()

        def decompress(self, data, max_length=-1):
            out = self.inner.decompress(data, max_length)
            seen.append(len(out))
            return out

        def __getattr__(self, name):
            return getattr(self.inner, name)

    api.bz2.BZ2Decompressor = Spy
    try:
        with pytest.raises(Exception):  # zeros after the header: tifffile finds no image
            rsci.read_elid(path, Limits(400.0, 2.0))
    finally:
        api.bz2.BZ2Decompressor = real
    assert 50e6 <= sum(seen) <= 50e6 + 20 and max(seen) <= rsci.PIECE_BYTES and size > 90e6  # the 40 MB after it: never


@pytest.mark.timeout(60)
def test_real_elid_reads_the_same_with_a_bomb_appended(fixture, tmp_path, elid_bomb):
    """The reader decompresses exactly the project's first bzip2 stream, the one rosettasciio reads: a
    bomb appended as a second stream is read by neither."""
    from rsciio.phenom import file_reader
    from tamp_os.read.image import read_image
    from tamp_os.read.vendor.rsci import bounded_reader_class

    path = fixture("real/phenom_elid2v4.elid")
    size = len(bz2.decompress(path.read_bytes()))
    appended = tmp_path / "appended.elid"
    appended.write_bytes(path.read_bytes() + elid_bomb)
    reader = bounded_reader_class()(str(appended), 2e9)
    assert reader._at == size
    for ours, theirs in zip(reader.dictionaries, file_reader(str(path)), strict=True):
        np.testing.assert_array_equal(ours["data"], theirs["data"])
    np.testing.assert_array_equal(read_image(appended).values, read_image(path).values)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("declared, needles", [
    (0xFFFFFFFF, ("record of 4,294,967,295 bytes at byte 16", "8.6 GB", "limit of 2 GB", "--max-decoded-gb")),
    (900_000_000, ("damaged or truncated", "embedded image at byte 16 of the project is no TIFF")),
])
def test_elid_record_declared_huge_is_refused_before_it_is_decompressed(tmp_path, declared, needles):
    """A TIFF record whose length is above the cap is refused before a byte of it is decompressed; one
    under the cap whose bytes start as no TIFF is refused at its first piece (not after 900 MB)."""
    from bomb_builders import elid_declaring_a_tiff

    path = tmp_path / "upload.elid"
    path.write_bytes(elid_declaring_a_tiff(declared, 10**9))
    assert_refused(tmp_path, path, "Phenom ELID", *needles)  # peak and time bounded (decompressing: 1.9 GB, 15 s)


# --- 2. JEOL .img: the declared size against the stored bits and the cap --------------------------------

def jeol_img(width, height, bits: bytes, size_type: int = 3) -> bytes:
    """A JEOL Analysis Station .img: magic 52, its format name, offsets, then the tagged tree with Image/Size and Bits."""
    def field(key: str, val_type: int, value: bytes) -> bytes:
        name = key.encode() + b"\0"
        return b"\x01" + struct.pack("<i", len(name)) + name + struct.pack("<2i", val_type, len(value)) + value + b"\xff"

    def group(key: str, body: bytes) -> bytes:
        name = key.encode() + b"\0"
        return b"\x01" + struct.pack("<i", len(name)) + name + struct.pack("<2i", 0, 0) + body + b"\xff"

    size = struct.pack({3: "<2i", 2: "<2H", 5: "<2d"}[size_type], width, height)
    tree = group("Image", field("Size", size_type, size) + field("Bits", 1, bits)) + b"\xff"
    data_pos = 48
    head = struct.pack("<I", 52) + b"JED-2200:LibJxImageForm".ljust(32, b"\0") + struct.pack("<3I", 0, 0, data_pos)
    return head + bytes(12) + tree


@pytest.mark.timeout(60)
def test_jeol_walk_matches_rosettasciio_on_the_real_file(fixture):
    from tamp_os.read.vendor.rsci import jeol_image_fields

    assert jeol_image_fields(fixture("real/jeol_dummy_bf.img")) == {"Size": (256, 256), "Bits": (1, 65536)}
    assert jeol_image_fields_of(jeol_img(60000, 60000, bytes(256))) == {"Size": (60000, 60000), "Bits": (1, 256)}


def jeol_image_fields_of(data, tmp=None):
    import tempfile

    from tamp_os.read.vendor.rsci import jeol_image_fields

    with tempfile.NamedTemporaryFile(suffix=".img") as fh:
        fh.write(data)
        fh.flush()
        return jeol_image_fields(fh.name)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("size_type", [3, 2, 5])  # int32 (as JEOL writes it), uint16, float64: rsciio resizes to any
def test_jeol_image_larger_than_its_bits_is_refused(tmp_path, size_type):
    path = tmp_path / "upload.img"
    path.write_bytes(jeol_img(60000, 60000, bytes(256), size_type))
    assert_refused(tmp_path, path, "JEOL", "60000×60000 pixels", "3.6 GB", "more than the 256 bytes of pixels", "2 GB")


@pytest.mark.timeout(120)
def test_jeol_image_above_the_cap_is_refused(fixture, tmp_path):
    """The real file, honest, but above a cap of 10 kB: refused from the header with the cap named."""
    source = fixture("real/jeol_dummy_bf.img")
    path = tmp_path / "upload.img"
    shutil.copy(source, path)
    assert_refused(tmp_path, path, "JEOL", "256×256 pixels", "limit of 1e-05 GB", "--max-decoded-gb",
                   extra=("--max-decoded-gb", "0.00001"))


# --- the web app: the same refusals through an upload ----------------------------------------------------

@pytest.fixture(scope="module")
def server(tmp_path_factory):
    from gui_support import start_server, stop_server

    root = tmp_path_factory.mktemp("gui-bounds")
    proc, url = start_server(root, slow_s=0.0)
    yield url, root
    stop_server(proc)


def web_cases(tmp_path, elid_bomb):
    h5py = need_module("h5py")
    secret = secret_h5(tmp_path / "elsewhere")
    cases = {
        "link.emd": (velox_like(tmp_path / "link.emd", lambda g: g.__setitem__("Data", h5py.ExternalLink(str(secret), "/private"))),
                     OUTSIDE),
        "chunk.hspy": (hspy_like(tmp_path / "chunk.hspy", lambda g: g.create_dataset(
            "data", shape=(64, 64), maxshape=(None, None), dtype=np.uint8, chunks=(60000, 60000))), "60000×60000"),
        "voxels.mrc": (tmp_path / "voxels.mrc", "60000×60000×100 voxels"),
        "bits.img": (tmp_path / "bits.img", "60000×60000 pixels"),
        "bomb.elid": (tmp_path / "bomb.elid", "Phenom ELID"),
        "tiles.elid": (tmp_path / "tiles.elid", "embedded image at byte 16"),
    }
    raw = bz2.decompress((FIXTURES / "real" / "phenom_elid2v4.elid").read_bytes())
    n, bomb = int.from_bytes(raw[12:16], "little"), tile_bomb_tiff()
    cases["tiles.elid"][0].write_bytes(bz2.compress(raw[:12] + struct.pack("<I", len(bomb)) + bomb + raw[16 + n:]))
    cases["voxels.mrc"][0].write_bytes(mrc_bytes(60000, 60000, 100))
    cases["bits.img"][0].write_bytes(jeol_img(60000, 60000, bytes(256)))
    cases["bomb.elid"][0].write_bytes(elid_bomb)
    # The CZI subblocks' prices (tests/test_vendor_safe.py builds each hostile CZI)
    from test_vendor_safe import HOSTILE as CZI_CASES

    for case, needle in (("jpeg_sof_30000", "frame header says 30000×30000"), ("lzw_declared_40000", "40000×40000 LZW stream"),
                         ("data_size_2_to_40", "damaged or truncated")):
        cases[f"{case}.czi"] = (CZI_CASES[case][0](tmp_path / f"{case}.czi"), needle)
    return cases


@pytest.mark.timeout(240)
def test_web_upload_of_each_hostile_vendor_file_is_refused(server, tmp_path, elid_bomb, fixture):
    fixture("real/phenom_elid2v4.elid")
    import httpx
    from gui_support import form_token

    url, root = server
    cases = web_cases(tmp_path, elid_bomb)
    with httpx.Client(base_url=url, timeout=60) as client:
        token = form_token(client)
        for name, (path, needle) in cases.items():
            jobs_before = {p.name for p in root.iterdir()}
            start = time.monotonic()
            r = client.post("/jobs", data={"token": token}, files={"images": (name, path.read_bytes(), "application/octet-stream")})
            seconds = time.monotonic() - start
            assert r.status_code == 400, (name, r.status_code)
            message = r.text.split('id="images-error"')[1].split("</p>")[0]
            assert name in message and needle in message, (name, message)
            assert "Traceback" not in r.text and str(path) not in r.text and "secret" not in message.replace("secret.h5", "")
            print(f"web {name}: {seconds:.2f} s: {message.strip()[:300]}")
            assert {p.name for p in root.iterdir()} == jobs_before  # the refused upload's job is gone, files and all
        assert httpx.get(url + "/", timeout=5).status_code == 200  # still answering


def tile_bomb_tiff() -> bytes:
    """A 16×16 deflate-tiled TIFF whose tile tags then claim 65520×65520 (4.3 GB decoded per tile)."""
    import io

    import tifffile

    buf = io.BytesIO()
    tifffile.imwrite(buf, np.zeros((16, 16), np.uint8), tile=(16, 16), compression="zlib")
    data = bytearray(buf.getvalue())
    with tifffile.TiffFile(io.BytesIO(bytes(data))) as tif:
        for name in ("TileWidth", "TileLength"):
            tag = tif.pages[0].tags[name]
            fmt = {3: "<H", 4: "<I"}[int(tag.dtype)]
            struct.pack_into(fmt, data, tag.valueoffset, 65520)
    return bytes(data)


@pytest.mark.timeout(120)
def test_elid_whose_embedded_tiff_is_a_tile_bomb_is_refused(fixture, tmp_path):
    """The real ELID with its first image replaced by a 16×16 TIFF whose tiles claim 65520×65520:
    rosettasciio would hand it to tifffile, which allocates whole tiles."""
    source = fixture("real/phenom_elid2v4.elid")
    raw = bz2.decompress(source.read_bytes())
    n = int.from_bytes(raw[12:16], "little")
    assert raw[16:20] == b"II*\x00"
    bomb = tile_bomb_tiff()
    path = tmp_path / "upload.elid"
    path.write_bytes(bz2.compress(raw[:12] + struct.pack("<I", len(bomb)) + bomb + raw[16 + n:]))
    assert_refused(tmp_path, path, "Phenom ELID", "embedded image at byte 16", "16×16 TIFF", "tiles being decoded",
                   "limit of 2 GB", "--max-decoded-gb")


@pytest.mark.timeout(120)
def test_real_elid_embedded_images_are_priced_small(fixture):
    from tamp_os.read.vendor.rsci import bounded_reader_class

    costs = bounded_reader_class()(str(fixture("real/phenom_elid2v4.elid")), 2e9).tiff_costs
    sizes = {size for _, _, size in costs}
    assert {(20, 16), (32, 24), (40, 35)} <= sizes and max(c.total for _, c, _ in costs) < 1e5
