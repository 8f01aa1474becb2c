"""Issue 21: microscope vendors' own formats, checked on the real files in ../shared/fixtures/real
against the facts its README lists, and on small files the tests write (OME-Zarr, pyramids, SIS)."""

import json
import re
import shutil
import struct
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, need_module, run_cli, examples
from tamp_os.errors import InputError, ParameterError
from tamp_os.read.image import read_image

REAL = "real/"


def scale_of(picture):
    from tamp_os.clean.stage import clean_picture

    return clean_picture(picture, pixel_size_m=None, remove_annotations=False).pixel_size


@pytest.fixture
def real(fixture):
    def get(name, module=None):
        if module:
            need_module(module)
        return fixture(REAL + name)

    return get


# --- Zeiss CZI ------------------------------------------------------------------------------------

@pytest.mark.timeout(120)
def test_czi_sem_pixel_size_from_scaling_distance(real):
    picture = read_image(real("zeiss_sem_al2o3_grains.czi", "czifile"))
    assert (picture.file.width, picture.file.height, picture.file.dtype) == (2048, 1536, "uint8")
    size = scale_of(picture)
    assert size.metres == pytest.approx(27.91e-9, rel=1e-4)
    assert "Scaling/Items/Distance" in size.provenance and "czifile" in size.provenance


@pytest.mark.timeout(120)
def test_czi_pixel_items_of_value_1_are_not_a_pixel_size(real, capsys):
    path = real("zeiss_dapi_gfp_2ch.czi", "czifile")
    picture = read_image(path)
    assert picture.file.channel_names == ["DAPI", "GFP"]
    assert scale_of(picture).metres is None
    code, out, _ = run_cli(capsys, "info", path, "--json")
    facts = json.loads(out)
    assert code == 0 and facts["pixel_size_m"] is None and facts["channels"] == 2
    code, out, _ = run_cli(capsys, "info", path)
    assert "pixel size: not known" in out and "2 channels" in out.splitlines()[0]


@pytest.mark.timeout(120)
def test_czi_airyscan_time_channels_and_wavelengths(real):
    path = real("zeiss_airyscan_2ch_t3.czi", "czifile")
    first = read_image(path)
    f = first.file
    assert (f.width, f.height, f.dtype) == (480, 480, "uint16")
    assert f.axes == {"T": 3, "C": 2} and f.channel_count == 2
    assert f.channel_names == ["ChA-T1", "ChA-T2"]
    assert f.wavelengths_nm[0] == pytest.approx(579, abs=1) and f.wavelengths_nm[1] == pytest.approx(523, abs=1)
    assert scale_of(first).metres == pytest.approx(43.93e-9, rel=1e-3)
    assert any("time series of 3" in n for n in f.notes) and any("ChA-T1" in n and "channel 0" in n for n in f.notes)
    later = read_image(path, time=2, channel="ChA-T2")
    assert later.values.shape == (480, 480) and not np.array_equal(later.values, first.values)
    assert np.array_equal(read_image(path, channel="1").values, read_image(path, channel="cha-t2").values)
    with pytest.raises(ParameterError, match="time must be 0–2"):
        read_image(path, time=3)
    with pytest.raises(ParameterError, match="ChA-T1"):
        read_image(path, channel="GFP")


# --- Leica LIF ------------------------------------------------------------------------------------

@pytest.mark.timeout(120)
def test_lif_three_images_their_axes_and_steps(real):
    path = real("leica_beads_xz_2ch.lif", "liffile")
    xzt = read_image(path)
    assert xzt.file.axes == {"scenes": 3, "T": 20, "C": 2}
    assert xzt.file.metadata["vendor"]["time_step_s"] == pytest.approx(0.53, abs=0.01)
    assert scale_of(xzt).metres == pytest.approx(0.1403e-6, rel=2e-3)
    assert any("XZ scan" in n and "depth" in n for n in xzt.file.notes)  # Z is not silently the image height
    xzy = read_image(path, scene=1)
    assert xzy.file.axes == {"scenes": 3, "C": 2, "Z": 23}
    assert xzy.file.z_step_m == pytest.approx(0.2291e-6, rel=2e-3)
    xz = read_image(path, scene=2, channel="1")
    assert (xz.file.width, xz.file.height) == (512, 512)
    assert xz.file.metadata["vendor"]["pixel_size_m"] == pytest.approx([0.1027e-6, 0.1027e-6], rel=2e-3)
    names, waves = xz.file.channel_names, xz.file.wavelengths_nm
    assert "HyD 1" in names[0] and "FITC" in names[0] and 493 <= waves[0] <= 541
    assert "HyD 3" in names[1] and "TRITC" in names[1] and 618 <= waves[1] <= 700
    with pytest.raises(ParameterError, match="scene must be 0–2"):
        read_image(path, scene=3)


# --- Nikon ND2 ------------------------------------------------------------------------------------

@pytest.mark.timeout(120)
def test_nd2_channels_and_pixel_size(real):
    picture = read_image(real("nikon_pbmc_4ch.nd2", "nd2"))
    assert picture.file.channel_names == ["Mono", "DAPI", "FITC BP", "TRITC BP"]
    assert picture.file.wavelengths_nm[1:] == [450, 512, 595]
    assert scale_of(picture).metres == pytest.approx(0.32339e-6, rel=1e-4)


@pytest.mark.timeout(120)
def test_nd2_zstack_step_and_slices(real):
    nd2 = need_module("nd2")
    path = real("nikon_widefield_zstack_11z.nd2")
    projection = read_image(path)
    assert projection.file.axes == {"Z": 11} and projection.file.z_step_m == pytest.approx(6.0e-6, rel=1e-6)
    stack = nd2.imread(str(path))
    np.testing.assert_array_equal(projection.values, stack.max(axis=0).astype(np.float32))
    np.testing.assert_array_equal(read_image(path, z_slice=5).values, stack[5].astype(np.float32))


# --- TEM formats through RosettaSciIO --------------------------------------------------------------

@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", ["tia_talos_tem_search.emi", "tia_talos_tem_search_1.ser"])
def test_tia_either_file_of_the_pair(real, name):
    picture = read_image(real(name, "rsciio"))
    assert (picture.file.width, picture.file.height, picture.file.dtype) == (128, 128, "int32")
    assert scale_of(picture).metres == pytest.approx(5.2612e-9, rel=1e-4)
    assert "rosettasciio" in picture.file.reader


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name, size_m, shape", [
    ("velox_talos_haadf_particles.emd", 5.3024e-9, (512, 512)),
    ("stem_haadf_sio2_spheres.hspy", 8.5524e-9, (128, 128)),
    ("jeol_dummy_bf.img", 1.9336e-9, (256, 256)),
])
def test_tem_formats_pixel_size(real, name, size_m, shape):
    need_module("h5py")
    picture = read_image(real(name, "rsciio"))
    assert picture.values.shape == shape
    assert scale_of(picture).metres == pytest.approx(size_m, rel=2e-4)


@pytest.mark.timeout(120)
def test_jeol_step_is_upright(real):
    values = read_image(real("jeol_dummy_bf.img", "rsciio")).values
    assert np.all(values[:191] >= 87) and np.all(values[191:] == 0)  # rows 0–190 grey, the band below black


@pytest.mark.timeout(120)
def test_phenom_blank_image_is_said_and_another_can_be_chosen(real):
    path = real("phenom_elid2v4.elid", "rsciio")
    first = read_image(path)
    assert any("blank" in n and "scene" in n for n in first.file.notes)
    assert scale_of(first).metres == pytest.approx(975.78e-9, rel=1e-4)
    images = first.file.axes["scenes"]
    colour = [read_image(path, scene=s) for s in range(images)]
    rgba = [p for p in colour if p.file.channels == 4]
    assert rgba and rgba[0].values.shape == (24, 32)


@pytest.mark.timeout(180)
def test_phenom_blank_image_converts_to_a_flat_plate_with_a_warning(real, tmp_path, capsys):
    code, out, err = run_cli(capsys, "convert", real("phenom_elid2v4.elid", "rsciio"), "-o", tmp_path)
    assert code == 0 and "blank" in (out + err)
    assert "Traceback" not in err
    # the note names the option a user types (it said "choose another with scene")
    blank = [line for line in (out + err).splitlines() if "blank" in line]
    assert blank and all("--scene" in line for line in blank), blank


# --- MRC ------------------------------------------------------------------------------------------

@pytest.mark.timeout(120)
def test_mrc_axis_order_and_voxel_from_sampling(real):
    path = real("mrc_emdb3001_microed.map", "mrcfile")
    picture = read_image(path)
    # mapc, mapr, maps = 3, 1, 2: 73 columns are Z, 43 rows are X, 25 sections are Y
    assert (picture.file.width, picture.file.height) == (43, 25) and picture.file.axes == {"Z": 73}
    vendor = picture.file.metadata["vendor"]
    assert vendor["pixel_size_m"] == pytest.approx([0.448e-10, 0.3925e-10], rel=1e-3)  # cella / m, not cella / n
    assert picture.file.z_step_m == pytest.approx(0.459e-10, rel=1e-3)
    assert vendor["mrc_axis_order"] == [3, 1, 2] and vendor["mrc_space_group"] == 4
    assert any("not square" in n for n in picture.file.notes)


@pytest.mark.timeout(120)
def test_mrc_plane_matches_the_volume_reordered(real):
    mrcfile = need_module("mrcfile")
    path = real("mrc_emdb3197_subtomo.map")
    with mrcfile.open(str(path)) as mrc:  # axis order 1, 2, 3: sections are Z, rows Y (up)
        volume = np.array(mrc.data)
    np.testing.assert_array_equal(read_image(path, z_slice=7).values, volume[7, ::-1, :])
    assert scale_of(read_image(path)).metres == pytest.approx(11.4e-10, rel=1e-4)


# --- TIFF vendor tags and pyramids ----------------------------------------------------------------

@pytest.mark.timeout(60)
def test_tvips_pixel_size_tag(real):
    size = scale_of(read_image(real("tvips_bin4.tif")))
    assert size.metres == pytest.approx(1.4208e-9, rel=1e-4) and "TVIPS" in size.provenance


@pytest.mark.timeout(60)
def test_svs_mpp(real):
    picture = read_image(real("aperio_cmu1_he_skin.svs"))
    assert (picture.file.width, picture.file.height) == (2220, 2967)
    assert scale_of(picture).metres == pytest.approx(0.499e-6, rel=1e-4)


def _write_pyramid(path, width=4096, levels=3, pixel_um=0.5):
    tifffile = need_module("tifffile")
    base = (np.add.outer(np.arange(width * 3 // 4), np.arange(width)) % 251).astype(np.uint8)
    with tifffile.TiffWriter(path, ome=True) as tif:
        tif.write(base, subifds=levels - 1, tile=(256, 256), metadata={"PhysicalSizeX": pixel_um, "PhysicalSizeY": pixel_um})
        for k in range(1, levels):
            tif.write(base[:: 2**k, :: 2**k], subfiletype=1, tile=(256, 256))
    return base


@pytest.mark.timeout(120)
def test_pyramid_reads_the_level_that_fits_and_prices_only_it(tmp_path):
    path = tmp_path / "slide.ome.tif"
    base = _write_pyramid(path)
    picture = read_image(path)  # default: the smallest level at least 2048 px wide
    assert picture.values.shape == (1536, 2048)
    np.testing.assert_array_equal(picture.values, base[::2, ::2].astype(np.float32))
    assert any("level 1" in n for n in picture.file.notes)
    assert scale_of(picture).metres == pytest.approx(1.0e-6, rel=1e-6)  # level 0's 0.5 µm × 2
    level1_gb = 1536 * 2048 / 1e9
    assert read_image(path, max_decoded_gb=level1_gb * 1.01).values.shape == (1536, 2048)
    assert read_image(path, target_px=1000).values.shape == (768, 1024)
    from tamp_os.gui.uploads import decoded_bytes

    assert decoded_bytes(path) == (2048, 1536, 2048 * 1536)  # the web app prices the level that is read


# --- Olympus SIS: the tag on the data page behind the preview -------------------------------------

def _sis_block(pixel_m):
    head = struct.pack("<4s6xhhhhh6x32sH", b"SIS0", 30, 12, 5, 3, 120, b"synthetic".ljust(32, b"\0"), 1)
    record = struct.pack("<10xhdd8xd2x34s32s", -9, pixel_m / 1e-9, pixel_m / 1e-9, 40000.0,
                         b"camera".ljust(34, b"\0"), b"TEM".ljust(32, b"\0"))
    return head + struct.pack("<hhI", 1, 1, 0) + record


@pytest.mark.timeout(60)
def test_sis_tag_on_the_data_page_is_read(tmp_path):
    tifffile = need_module("tifffile")
    need_module("imagecodecs")
    path = tmp_path / "sis.tif"
    data = (np.add.outer(np.arange(256) * 97, np.arange(320) * 13) % 60000).astype(np.uint16)
    block = _sis_block(0.61e-9)
    with tifffile.TiffWriter(path) as writer:  # as real SIS files: page 0 a JPEG preview without the tag
        writer.write(np.zeros((64, 80, 3), np.uint8), photometric="rgb", compression="jpeg", metadata=None)
        writer.write(data, metadata=None, extratags=[(33560, 7, len(block), block, True)])
    raw = bytearray(path.read_bytes())
    at = raw.find(b"SIS0")
    struct.pack_into("<I", raw, at + 64, at + 68)
    path.write_bytes(bytes(raw))
    with tifffile.TiffFile(path) as tif:
        assert not tif.sis_metadata  # tifffile looks at page 0 only
    picture = read_image(path)
    assert picture.values.shape == (256, 320)
    size = scale_of(picture)
    assert size.metres == pytest.approx(0.61e-9, rel=1e-9) and size.provenance == "Olympus SIS pixelsizex"


# --- OME-Zarr (written here: no small public sample is in git) ------------------------------------

def write_ome_zarr(path, data, scale_um=(1.0, 0.5, 0.25, 0.25), labels=("DAPI", "GFP"), levels=1):
    """An NGFF 0.4 OME-Zarr of a (C, Z, Y, X) array, with `levels` halving pyramid levels."""
    zarr = need_module("zarr")
    group = zarr.open_group(str(path), mode="w", zarr_format=2)
    datasets = []
    for k in range(levels):
        level = data[:, :, :: 2**k, :: 2**k]
        group.create_array(str(k), shape=level.shape, dtype=level.dtype, chunks=(1, 1) + level.shape[2:])[...] = level
        s = list(scale_um)
        datasets.append({"path": str(k), "coordinateTransformations": [
            {"type": "scale", "scale": [1.0, s[1], s[2] * 2**k, s[3] * 2**k]}]})
    group.attrs["multiscales"] = [{"version": "0.4", "axes": [
        {"name": "c", "type": "channel"}, {"name": "z", "type": "space", "unit": "micrometer"},
        {"name": "y", "type": "space", "unit": "micrometer"}, {"name": "x", "type": "space", "unit": "micrometer"}],
        "datasets": datasets}]
    group.attrs["omero"] = {"channels": [{"label": name} for name in labels]}
    return path


@pytest.mark.timeout(120)
def test_ome_zarr_folder_axes_scale_and_channels(tmp_path):
    rng = np.random.default_rng(3)
    data = rng.integers(0, 4000, size=(2, 5, 64, 96), dtype=np.uint16)
    path = write_ome_zarr(tmp_path / "cells.zarr", data)
    picture = read_image(path)
    f = picture.file
    assert f.format == "OME-Zarr" and f.axes == {"C": 2, "Z": 5}
    assert f.channel_names == ["DAPI", "GFP"] and f.z_step_m == pytest.approx(0.5e-6)
    assert scale_of(picture).metres == pytest.approx(0.25e-6)
    np.testing.assert_array_equal(picture.values, data[0].max(axis=0).astype(np.float32))
    np.testing.assert_array_equal(read_image(path, channel="GFP", z_slice=3).values, data[1, 3].astype(np.float32))


@pytest.mark.timeout(120)
def test_ome_zarr_pyramid_level_and_its_pixel_size(tmp_path):
    data = np.zeros((1, 1, 512, 768), np.uint8)
    data[0, 0, 100:200, 300:500] = 200
    path = write_ome_zarr(tmp_path / "p.zarr", data, labels=("only",), levels=3)
    picture = read_image(path, target_px=300)  # widths 768, 384, 192: the smallest at least 300 wide is level 1
    assert picture.values.shape == (256, 384)
    assert scale_of(picture).metres == pytest.approx(0.5e-6)
    assert any("level 1" in n for n in picture.file.notes)
    assert read_image(path).values.shape == (512, 768)  # no level is 2048 wide: the largest, level 0


@pytest.mark.timeout(180)
def test_ome_zarr_converts_from_the_command_line(tmp_path, capsys):
    data = np.zeros((1, 3, 96, 128), np.uint16)
    data[0, 1, 20:70, 30:90] = 3000
    path = write_ome_zarr(tmp_path / "in" / "stack.zarr", data, labels=("membrane",))
    code, out, err = run_cli(capsys, "convert", path, "-o", tmp_path / "out")
    assert code == 0, err
    assert (tmp_path / "out" / "stack.stl").is_file()
    recipe = json.loads((tmp_path / "out" / "stack.tamp.json").read_text())
    assert len(recipe["input"]["sha256"]) == 64


# --- read_channels: every channel of the chosen plane ---------------------------------------------

@pytest.mark.timeout(120)
def test_read_channels_of_an_nd2(real):
    nd2 = need_module("nd2")
    from tamp_os.read.channels import read_channels

    path = real("nikon_pbmc_4ch.nd2")
    planes = read_channels(path)
    assert [p.name for p in planes] == ["Mono", "DAPI", "FITC BP", "TRITC BP"]
    assert [p.wavelength_nm for p in planes] == [None, 450, 512, 595]
    stack = nd2.imread(str(path))
    for i, plane in enumerate(planes):
        assert plane.values.dtype == np.float32 and plane.values.ndim == 2
        np.testing.assert_array_equal(plane.values, stack[i].astype(np.float32))


@pytest.mark.timeout(120)
def test_read_channels_of_a_czi_time_point_and_guard(real):
    from tamp_os.read.channels import read_channels

    path = real("zeiss_airyscan_2ch_t3.czi", "czifile")
    planes = read_channels(path, time=1)
    assert [p.name for p in planes] == ["ChA-T1", "ChA-T2"]
    assert planes[0].excitation_nm == 561 and planes[1].excitation_nm == 488
    np.testing.assert_array_equal(planes[1].values, read_image(path, time=1, channel="1").values)
    one_plane_gb = 480 * 480 * 2 / 1e9
    with pytest.raises(InputError, match="max_decoded_gb"):  # both channels are priced together
        read_channels(path, max_decoded_gb=one_plane_gb * 1.5)


@pytest.mark.timeout(60)
def test_read_channels_of_ordinary_images(tmp_path):
    from tamp_os.export.files import write_png
    from tamp_os.read.channels import read_channels

    rgb = np.zeros((8, 10, 3), np.uint8)
    rgb[..., 0], rgb[..., 2] = 200, 50
    write_png(tmp_path / "rgb.png", rgb)
    planes = read_channels(tmp_path / "rgb.png")
    assert [p.name for p in planes] == ["red", "green", "blue"]
    assert planes[0].values.max() == 200 and planes[1].values.max() == 0 and planes[2].values.max() == 50
    tifffile = need_module("tifffile")
    stack = np.stack([np.full((6, 7), 10 * (i + 1), np.uint16) for i in range(3)])
    tifffile.imwrite(tmp_path / "c3.ome.tif", stack, ome=True, photometric="minisblack", metadata={"axes": "CYX", "Channel": {"Name": ["a", "b", "c"]}})
    planes = read_channels(tmp_path / "c3.ome.tif")
    assert [p.name for p in planes] == ["a", "b", "c"] and [p.values.max() for p in planes] == [10, 20, 30]
    tifffile.imwrite(tmp_path / "c3.tif", stack, photometric="minisblack", imagej=True, metadata={"axes": "CYX"})  # ImageJ, unnamed
    assert [(p.name, p.values.max()) for p in read_channels(tmp_path / "c3.tif")] == [("channel 0", 10), ("channel 1", 20), ("channel 2", 30)]
    grey = tmp_path / "grey.png"
    write_png(grey, rgb[..., 0])
    assert [p.name for p in read_channels(grey)] == ["luminance"]


# --- the decoded-size guard holds before any pixel is decoded --------------------------------------

VENDOR_FILES = [
    ("zeiss_sem_al2o3_grains.czi", "czifile"), ("zeiss_airyscan_2ch_t3.czi", "czifile"),
    ("leica_beads_xz_2ch.lif", "liffile"), ("nikon_pbmc_4ch.nd2", "nd2"), ("nikon_widefield_zstack_11z.nd2", "nd2"),
    ("tia_talos_tem_search.emi", "rsciio"), ("tia_talos_tem_search_1.ser", "rsciio"),
    ("velox_talos_haadf_particles.emd", "h5py"), ("mrc_emdb3001_microed.map", "mrcfile"),
    ("mrc_emdb3197_subtomo.map", "mrcfile"), ("jeol_dummy_bf.img", "rsciio"), ("phenom_elid2v4.elid", "rsciio"),
    ("stem_haadf_sio2_spheres.hspy", "h5py"),
]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name, module", VENDOR_FILES)
def test_guard_refuses_before_decoding(real, monkeypatch, name, module):
    import tamp_os.read.vendor.plan as plan

    path = real(name, module)
    need_module("rsciio")

    def no_decoding(*args, **kwargs):
        raise AssertionError("a plane was decoded before the size guard")

    monkeypatch.setattr(plan, "_project", no_decoding)
    with pytest.raises(InputError, match="max_decoded_gb"):
        read_image(path, max_decoded_gb=1e-7)  # 100 bytes: less than any plane


# --- damaged files: named as what they are, one clear error, nothing written ----------------------

TRUNCATED = [(n, m) for n, m in VENDOR_FILES if n != "tia_talos_tem_search.emi"]
WORDS = {".czi": "Zeiss CZI", ".lif": "Leica LIF", ".nd2": "Nikon ND2", ".ser": "TIA", ".emd": "EMD", ".map": "MRC",
         ".img": "JEOL", ".elid": "Phenom", ".hspy": "HyperSpy"}


@pytest.mark.timeout(180)
@pytest.mark.parametrize("name, module", TRUNCATED)
@pytest.mark.parametrize("keep", [0.5, 0.9])
def test_truncated_copy_is_one_clear_error_and_writes_nothing(real, tmp_path, capsys, name, module, keep):
    source = real(name, module)
    need_module("rsciio")
    data = source.read_bytes()
    cut = tmp_path / name
    cut.write_bytes(data[: int(len(data) * keep)])
    out = tmp_path / "out"
    code, stdout, err = run_cli(capsys, "convert", cut, "-o", out)
    assert code != 0
    assert "Traceback" not in err and "BMP" not in err and "damaged HDF5" not in err
    assert WORDS[cut.suffix] in err and ("damaged" in err or "truncated" in err)
    assert "export" in err.lower() or "write it again" in err or "save it again" in err
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.timeout(120)
def test_tia_emi_whose_ser_is_damaged(real, tmp_path, capsys):
    emi, ser = real("tia_talos_tem_search.emi", "rsciio"), real("tia_talos_tem_search_1.ser")
    shutil.copy(emi, tmp_path / emi.name)
    (tmp_path / ser.name).write_bytes(ser.read_bytes()[:4000])
    code, _, err = run_cli(capsys, "convert", tmp_path / emi.name, "-o", tmp_path / "out")
    assert code != 0 and "TIA" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.timeout(60)
def test_tia_emi_without_its_ser_says_to_keep_them_together(real, tmp_path):
    emi = real("tia_talos_tem_search.emi", "rsciio")
    shutil.copy(emi, tmp_path / emi.name)
    with pytest.raises(InputError, match="keep the .emi and its .ser"):
        read_image(tmp_path / emi.name)


@pytest.mark.timeout(60)
def test_damaged_olympus_oib_is_named(tmp_path):
    need_module("oiffile")
    path = tmp_path / "cells.oib"
    path.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(600))
    with pytest.raises(InputError, match="an Olympus OIB/OIF file (whose image data is damaged|of a kind)"):
        read_image(path)


# --- everywhere: batch scans, the web app, parameters, start-up -----------------------------------

@pytest.mark.timeout(60)
def test_batch_scan_finds_vendor_files_once(real, tmp_path):
    from tamp_os.lithograph.batch import collect_inputs

    for name in ("zeiss_dapi_gfp_2ch.czi", "tia_talos_tem_search.emi", "tia_talos_tem_search_1.ser", "mrc_emdb3197_subtomo.map"):
        shutil.copy(real(name), tmp_path / name)
    write_ome_zarr(tmp_path / "stack.zarr", np.zeros((1, 1, 8, 8), np.uint8), labels=("a",))
    found = sorted(rel.as_posix() for _, rel in collect_inputs([tmp_path], recursive=True))
    assert found == ["mrc_emdb3197_subtomo.map", "stack.zarr", "tia_talos_tem_search.emi", "zeiss_dapi_gfp_2ch.czi"]
    assert [rel.as_posix() for _, rel in collect_inputs([tmp_path / "stack.zarr"])] == ["stack.zarr"]  # named: one image


@pytest.mark.timeout(120)
def test_web_upload_of_a_czi_is_priced_and_described(real, tmp_path):
    from tamp_os.gui.uploads import decoded_bytes, inspect_upload

    path = real("zeiss_airyscan_2ch_t3.czi", "czifile")
    assert decoded_bytes(path) is None  # the reader prices its planes itself
    upload = inspect_upload(path, path.name, tmp_path, index=0, max_decoded_mb=150)
    assert (upload.width, upload.height) == (480, 480)
    assert "3 time points" in upload.contents and "ChA-T1" in upload.contents
    with pytest.raises(InputError, match="larger images|limit"):
        inspect_upload(path, path.name, tmp_path, index=1, max_decoded_mb=0.1)


@pytest.mark.timeout(60)
def test_time_and_scene_are_parameters_with_ranges(real, tmp_path, capsys):
    from tamp_os.params import LithoParams

    with pytest.raises(ParameterError, match="scene"):
        LithoParams(scene=-1)
    code, _, err = run_cli(capsys, "convert", real("leica_beads_xz_2ch.lif", "liffile"), "-o", tmp_path, "--scene", "7")
    assert code != 0 and "Traceback" not in err
    assert re.search(r"(--scene|`scene`|scene) must be 0–2", err), err  # named as the front end names it


@pytest.mark.timeout(60)
def test_help_imports_no_vendor_reader():
    code = ("import sys, tamp_os.cli.commands; tamp_os.cli.commands.build_parser().format_help(); "
            "print(sorted(m for m in ('czifile', 'liffile', 'nd2', 'mrcfile', 'zarr', 'rsciio', 'h5py', 'oiffile') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          env={"PYTHONPATH": str(ROOT / "src"), "PATH": "/usr/bin:/bin"}, timeout=60)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


# --- large TIFF stacks are reduced page by page, with the same result ------------------------------

@pytest.mark.timeout(120)
@pytest.mark.parametrize("axes, shape", [("ZYX", (5, 40, 50)), ("TZCYX", (2, 3, 2, 20, 30)), ("CZYX", (3, 4, 16, 18))])
def test_tiff_stack_reduced_page_by_page_equals_the_whole_read(tmp_path, monkeypatch, axes, shape):
    tifffile = need_module("tifffile")
    import tamp_os.read.stacks as read_stacks

    data = np.random.default_rng(len(shape)).integers(0, 60000, size=shape, dtype=np.uint16)
    path = tmp_path / "stack.ome.tif"
    tifffile.imwrite(path, data, ome=True, metadata={"axes": axes})
    choices = [{}, {"z_slice": 1}] + ([{"channel": "1"}] if "C" in axes else []) + ([{"page": 1}] if "T" in axes else [])
    for kw in choices:
        monkeypatch.setattr(read_stacks, "STREAM_BYTES", 1e12)
        whole = read_image(path, **kw)
        monkeypatch.setattr(read_stacks, "STREAM_BYTES", 0)
        monkeypatch.setattr(tifffile.TiffPageSeries, "asarray", lambda *a, **k: pytest.fail("the whole series was decoded"))
        paged = read_image(path, **kw)
        monkeypatch.undo()
        np.testing.assert_array_equal(paged.values, whole.values)
        assert paged.file.notes == whole.file.notes and paged.file.pages == whole.file.pages


# --- any bytes behind a vendor signature: one clear error, never a crash ---------------------------

SIGNATURES = {
    "x.czi": b"ZISRAWFILE" + bytes(22), "x.lif": b"\x70\x00\x00\x00\x00\x00\x00\x00\x2a", "x.nd2": b"\xda\xce\xbe\x0a",
    "x.emd": b"\x89HDF\r\n\x1a\n", "x.ser": b"II\x97\x01", "x.img": b"\x34\x00\x00\x00JED-2200:Lib",
    "x.elid": b"BZh91AY&SY", "x.map": None,
}


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", sorted(SIGNATURES))
def test_random_bytes_behind_a_signature_give_one_clear_error(tmp_path, name):
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    from tamp_os.errors import TampError

    need_module("rsciio")

    @settings(max_examples=examples(15), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(tail=st.binary(min_size=0, max_size=3000))
    def check(tail):
        head = SIGNATURES[name]
        if head is None:  # MRC: the "MAP " stamp at byte 208
            data = bytearray(tail.ljust(1100, b"\0"))
            data[208:212] = b"MAP "
            data = bytes(data)
        else:
            data = head + tail
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(TampError) as caught:
            read_image(path)
        assert str(path) in str(caught.value)

    check()


@pytest.mark.timeout(180)
@pytest.mark.parametrize("name, module", VENDOR_FILES)
def test_info_text_and_json_agree(real, capsys, name, module):
    path = real(name, module)
    need_module("rsciio")
    code, out, _ = run_cli(capsys, "info", path, "--json")
    facts = json.loads(out)
    code_text, text, _ = run_cli(capsys, "info", path)
    assert code == code_text == 0
    n = facts["channels"]
    first = text.splitlines()[0]
    assert first.endswith(f"{n} channel{'s' if n != 1 else ''}") and "page" not in first, first  # scenes are said on the axes line
    if facts["channel_names"]:
        assert len(facts["channel_names"]) == n
    if n > 1:  # the reader's note names the same count, or info says which channels convert prints (issue 33.1)
        printed = facts.get("convert_channels")
        assert any(note.startswith(f"{n} channels") for note in facts["notes"]) or (
            printed and 2 <= len(printed["key"]) <= n and printed["why"] == f"the file has {n} channels"), facts
    assert facts["reader"] and facts["vendor"]["reader"] == facts["reader"]
    if facts["pixel_size_m"]:
        assert facts["vendor"]["reader"] in facts["pixel_size_source"]
