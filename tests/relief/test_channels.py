"""Issue 22: channels and stains as textures, with a braille key; measured on the printed heights."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from conftest import need, examples

from tamp_os.errors import ParameterError
from tamp_os.mesh.validate import check_solid
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.relief.channels import (
    ChannelImage,
    channel_relief,
    parse_assignments,
    stain_channels,
)
from tamp_os.relief.key3d import KEY_GAP_MM, SWATCH_W_MM
from tamp_os.relief.textures3d import (
    DOT_PITCH_MM,
    RIDGE_PITCH_MM,
    RIDGE_WIDTH_MM,
    pattern,
    ridge_angle_unlike,
    spec_for,
)
from tamp_os.standards import BrailleSpec
from tamp_os.tactile.braille import liblouis_available

MM = 0.1  # grid pitch of the texture tests


def _period_and_angle_mm(tex: np.ndarray) -> tuple[float, float]:
    """Strongest spatial period (mm) and its wave direction (degrees, image y down) by FFT."""
    f = np.abs(np.fft.fftshift(np.fft.fft2(tex - tex.mean())))
    r, c = np.unravel_index(np.argmax(f), f.shape)
    fy = (r - f.shape[0] // 2) / (f.shape[0] * MM)
    fx = (c - f.shape[1] // 2) / (f.shape[1] * MM)
    return 1.0 / math.hypot(fx, fy), math.degrees(math.atan2(fy, fx)) % 180


def _widths_mm(profile: np.ndarray) -> list[float]:
    """Lengths (mm) of the runs where a 1-D profile is raised above half height."""
    on = np.concatenate([[0], (profile > 0.5).astype(int), [0]])
    starts, ends = np.flatnonzero(np.diff(on) == 1), np.flatnonzero(np.diff(on) == -1)
    return [(e - s) * MM for s, e in zip(starts, ends)][1:-1]


@pytest.mark.timeout(60)
def test_textures_differ_by_period_direction_and_height():
    shape = (400, 400)
    ridges0 = pattern(spec_for("ridges", 0.0), shape, MM)
    ridges90 = pattern(spec_for("ridges", 90.0), shape, MM)
    dots = pattern(spec_for("dots"), shape, MM)
    hatch = pattern(spec_for("crosshatch", 0.0), shape, MM)
    smooth = pattern(spec_for("smooth"), shape, MM)
    p0, a0 = _period_and_angle_mm(ridges0)
    _, a90 = _period_and_angle_mm(ridges90)
    assert p0 == pytest.approx(RIDGE_PITCH_MM, rel=0.05) and p0 >= 2.5
    assert abs(a0 - a90) == pytest.approx(90, abs=3)  # ridges along x vary along y, and the other way
    # ridges at least 0.8 mm wide where they stand above half their height... measured across them
    widths = _widths_mm(ridges0[:, 200])
    assert widths and min(widths) >= 0.6 and np.median(widths) == pytest.approx(RIDGE_WIDTH_MM / 2 * 1.33, rel=0.25)
    # dots: at least 1.5 mm across at their foot, ≥3 mm apart along a row
    row = dots[0, :]
    foot = np.concatenate([[0], (row > 0).astype(int), [0]])
    feet = (np.flatnonzero(np.diff(foot) == -1) - np.flatnonzero(np.diff(foot) == 1)) * MM
    assert np.median(feet[1:-1]) >= 1.5 - MM
    pd, _ = _period_and_angle_mm(row[None, :].repeat(8, 0))
    assert pd == pytest.approx(DOT_PITCH_MM, rel=0.05) and pd >= 3.0
    # raised share tells them apart: smooth all, hatch more than ridges, dots least
    cover = {k: float((v > 0.5).mean()) for k, v in {"smooth": smooth, "hatch": hatch, "ridges": ridges0, "dots": dots}.items()}
    assert cover["smooth"] == 1.0 and cover["hatch"] > cover["ridges"] * 1.5 and cover["dots"] < cover["ridges"]
    # cross-hatch has energy in both directions
    f = np.abs(np.fft.fft2(hatch - hatch.mean()))
    k = round(400 * MM / 3.0)
    assert f[k, 0] > 0.2 * f.max() and f[0, k] > 0.2 * f.max()


@pytest.mark.timeout(30)
def test_ridge_direction_unlike_the_pictures_lines():
    y = np.mgrid[0:200, 0:200][0]
    horizontal_lines = (np.sin(y / 3.0) > 0).astype(float)  # lines along x
    assert ridge_angle_unlike(horizontal_lines) == 90.0
    assert ridge_angle_unlike(horizontal_lines.T) == 0.0


def _synthetic_channels(rows=300, cols=300):
    """Three channels with known shapes: big round nuclei, long thin filaments, small spots."""
    yy, xx = np.mgrid[0:rows, 0:cols]
    nuclei = np.zeros((rows, cols))
    for cy, cx in [(60, 60), (60, 200), (200, 100), (220, 240)]:
        nuclei[(yy - cy) ** 2 + (xx - cx) ** 2 < 25 ** 2] = 1.0
    fil = np.zeros((rows, cols))
    for k in range(6):
        fil[np.abs(yy - (0.4 * xx + 30 + 45 * k)) < 2.0] = 1.0
    rng = np.random.default_rng(3)
    spots = np.zeros((rows, cols))
    for cy, cx in rng.integers(10, rows - 10, size=(60, 2)):
        spots[(yy - cy) ** 2 + (xx - cx) ** 2 < 2.5 ** 2] = 1.0
    return nuclei, fil, spots


@pytest.mark.timeout(60)
def test_encodings_from_measured_shape_and_heights():
    nuclei, fil, spots = _synthetic_channels()
    mm = 0.3
    chans = [ChannelImage("channel 0", nuclei), ChannelImage("channel 1", fil), ChannelImage("channel 2", spots)]
    res = channel_relief(chans, mm_per_px=mm, base_mm=1.0, relief_mm=3.0)
    enc = {c.name: c.encoding for c in res.choices}
    assert enc == {"channel 0": "domes", "channel 1": "ridges", "channel 2": "dots"}
    h = res.heights_mm - 1.0
    core = nuclei > 0
    assert np.median(h[core]) >= 1.5 and h[core].max() == pytest.approx(3.0, abs=0.05)  # domes stand highest
    assert float((h[(fil > 0) & ~core] >= 0.5).mean()) > 0.5
    assert float((h[(spots > 0) & ~core] >= 0.5).mean()) > 0.5
    from scipy import ndimage as ndi

    background = ~ndi.binary_dilation((nuclei + fil + spots) > 0, iterations=2)  # the masks' edges are blurred by a pixel
    assert float(np.abs(h[background]).max()) < 0.05  # background at the base


@pytest.mark.timeout(30)
def test_names_and_wavelengths_decide_before_shape():
    nuclei, fil, spots = _synthetic_channels()
    chans = [ChannelImage("Hoechst 33342", spots), ChannelImage("Phalloidin-488", nuclei), ChannelImage("x", fil, 405.0, 455.0)]
    res = channel_relief(chans, mm_per_px=0.3, base_mm=1.0, relief_mm=3.0)
    got = {c.name: (c.encoding, c.why) for c in res.choices}
    assert got["Hoechst 33342"] == ("domes", "name")
    assert got["Phalloidin-488"] == ("ridges", "name")
    assert got["x"][1] in ("wavelength", "distinct")


@pytest.mark.timeout(30)
def test_channels_parameter_parsing_and_mistakes():
    assert parse_assignments("DAPI=domes, GFP=ridges") == {"dapi": "domes", "gfp": "ridges"}
    assert parse_assignments("auto") == {}
    with pytest.raises(ParameterError, match="channels.*NAME=ENCODING"):
        parse_assignments("DAPI=bumps")
    nuclei = _synthetic_channels()[0]
    with pytest.raises(ParameterError, match="no channel named gfp"):
        channel_relief([ChannelImage("DAPI", nuclei)], mm_per_px=0.3, base_mm=1, relief_mm=3, assigned={"gfp": "ridges"})


@pytest.mark.timeout(120)
def test_rgb_fluorescence_composite_split_by_colour_with_key():
    need(liblouis_available(), "liblouis (braille key)")
    nuclei, fil, spots = _synthetic_channels()
    rgb = np.stack([fil, spots, nuclei], axis=-1) * 230  # dark background, colour per structure
    litho = make_lithograph(rgb.astype(np.uint8), channels="auto", width_mm=90)
    r = litho.report
    assert r.relief_style == "channels"
    enc = {e.encoding: e.label for e in r.key}
    assert set(enc) == {"domes", "ridges", "dots"}
    assert "blue" in enc["domes"] and "red" in enc["ridges"]
    assert [e["label"] for e in r.as_dict()["key"]] == [e.label for e in r.key]
    check = check_solid(litho.mesh)
    assert check.ok, check.problems
    assert r.relief_mm[1] > 90 + 10  # the plate grew to hold the key
    assert any("grew" in str(w) for w in r.warnings)


@pytest.mark.timeout(60)
def test_no_key_entry_without_channels():
    litho = make_lithograph(np.eye(64), width_mm=40)
    assert "key" not in litho.report.as_dict()


def _key_dots_on_mesh(litho, rows_picture):
    """Heights above the base of the mesh at each key braille dot's expected centre, and the dot's diameter."""
    from tamp_os.relief.key3d import key_strip

    r, spec = litho.report, BrailleSpec()
    mm = r.mm_per_px
    strip = key_strip(r.key, width_mm=r.relief_mm[0], mm_per_px=mm, relief_mm=litho.params.relief_mm,
                      table=litho.params.braille_table)
    ox, oy = r.tactile.relief_origin_mm if r.tactile else (0.0, 0.0)
    depth = r.relief_mm[1]
    v = litho.mesh.vertices
    out = []
    for x, y_dn in strip.dot_centres_mm:
        X, Y = ox + x, oy + depth - ((rows_picture - 1) * mm + y_dn)
        near = v[np.hypot(v[:, 0] - X, v[:, 1] - Y) < spec.dot_diameter_mm]
        base = litho.params.base_mm
        top = near[:, 2].max() - base
        raised = near[near[:, 2] - base > 0.1 * spec.dot_height_mm]
        diam = 2 * np.hypot(raised[:, 0] - X, raised[:, 1] - Y).max() if len(raised) else 0.0
        out.append((top, diam))
    return strip, out


@pytest.mark.timeout(300)
def test_real_czi_dapi_gfp(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    litho = make_lithograph(fixture("real/zeiss_dapi_gfp_2ch.czi"), channels="auto", width_mm=100)
    r = litho.report
    choice = {e.label: e.encoding for e in r.key}
    assert choice["nuclei (DAPI)"] == "domes"
    assert "domes: nuclei (DAPI)" in r.relief_reason
    assert check_solid(litho.mesh).ok
    rows_picture = litho.heightmap.shape[0] - (round((r.relief_mm[1] - 100) / r.mm_per_px))
    strip, dots = _key_dots_on_mesh(litho, rows_picture)
    spec = BrailleSpec()
    assert len(dots) == sum((ord(c) - 0x2800).bit_count() for e in r.key for c in e.braille)
    for top, diam in dots:
        assert top == pytest.approx(spec.dot_height_mm, abs=0.08)
        assert diam == pytest.approx(spec.dot_diameter_mm, abs=2.5 * r.mm_per_px)
    # every dot at least KEY_GAP_MM from the swatches
    for x, _ in strip.dot_centres_mm:
        assert x - spec.dot_diameter_mm / 2 >= KEY_GAP_MM + SWATCH_W_MM + KEY_GAP_MM - 1e-9


@pytest.mark.timeout(300)
def test_real_nd2_four_channels_three_printed(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    litho = make_lithograph(fixture("real/nikon_pbmc_4ch.nd2"), channels="auto", width_mm=80)
    r = litho.report
    assert len(r.key) == 3
    assert any("4 channels" in str(w) and "left out" in str(w) for w in r.warnings)
    assert {e.label: e.encoding for e in r.key}["nuclei (DAPI)"] == "domes"
    assert check_solid(litho.mesh).ok
    one = make_lithograph(fixture("real/nikon_pbmc_4ch.nd2"), channels="DAPI=domes,FITC BP=ridges", width_mm=80)
    assert [(e.label, e.encoding) for e in one.report.key] == [("nuclei (DAPI)", "domes"), ("filaments (FITC BP)", "ridges")]


@pytest.mark.timeout(400)
def test_real_svs_he_epidermis_raised_white_at_base(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    from skimage.transform import resize

    from tamp_os.read.channels import read_channels

    path = fixture("real/aperio_cmu1_he_skin.svs")
    litho = make_lithograph(path, channels="auto", width_mm=100)
    r = litho.report
    assert [e.encoding for e in r.key] == ["domes", "ridges"]  # H&E: no DAB
    assert check_solid(litho.mesh).ok
    # the source's colours on the picture's grid: white space, purple (epidermis) and pink (dermis)
    rgb = np.stack([c.values for c in read_channels(path)], axis=-1) / 255.0
    rows_picture = round(100 * rgb.shape[0] / rgb.shape[1] / r.mm_per_px) + 1
    h = litho.heightmap[:rows_picture] - litho.params.base_mm
    small = resize(rgb, h.shape + (3,), anti_aliasing=True)
    white = small.mean(axis=2) > 0.85
    assert float(white.mean()) == pytest.approx(0.68, abs=0.06)
    hed = stain_channels(small)
    tissue = ~white
    purple = tissue & (hed[0].image > np.percentile(hed[0].image[tissue], 80))
    pink = tissue & (hed[0].image < np.percentile(hed[0].image[tissue], 40))
    assert np.median(h[white]) < 0.1
    assert np.median(h[purple]) >= np.median(h[pink]) + 0.5
    assert float((h[pink] >= 0.5).mean()) > 0.5


@pytest.mark.timeout(60)
@settings(max_examples=examples(60), deadline=None)
@given(st.dictionaries(st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 -", min_size=1, max_size=12).map(str.strip)
                       .filter(bool), st.sampled_from(("domes", "ridges", "dots", "plateau")), min_size=1, max_size=4))
def test_assignments_round_trip(assign):
    text = ",".join(f"{k}={v}" for k, v in assign.items())
    got = parse_assignments(text)
    assert got == {k.lower(): v for k, v in assign.items()} or len({k.lower() for k in assign}) < len(assign)


@pytest.mark.timeout(120)
def test_key_labels_mistake_is_one_clear_message():
    rgb = (np.stack(_synthetic_channels(), axis=-1) * 230).astype(np.uint8)
    with pytest.raises(ParameterError, match="key_labels.*NAME=LABEL"):
        make_lithograph(rgb, channels="auto", key_labels="nuclei", width_mm=90)


# ---- issue 22, second part: the channel path is automatic -------------------------------------

CHANNEL_FIXTURES = {  # the real files that print channel by channel by default, and why
    "real/zeiss_dapi_gfp_2ch.czi": "channels", "real/zeiss_airyscan_2ch_t3.czi": "channels",
    "real/nikon_pbmc_4ch.nd2": "channels", "real/leica_beads_xz_2ch.lif": "channels",
    "real/aperio_cmu1_he_skin.svs": "stain",
    # second batch (fixtures README): two ImageJ multi-channel fluorescence TIFFs; three H&E slides,
    # two of them tiles the tissue fills (≈2 % and ≈8 % glass) and a frozen section with ≈40 % glass
    # (issue 32). The moth SEM and the two atomic-resolution STEM files are grey: luminance.
    "real/fluo_cell_dna_mt_actin_3ch.tif": "channels", "real/fluo_widefield_dapi_tubulin_2ch.tif": "channels",
    "real/histo_he_carcinoma_dense_nuclei.png": "stain", "real/histo_he_stroma_collagen_vessel.png": "stain",
    "real/aperio_tcga_cr7395_j2k_no_mpp.svs": "stain",
}


def _all_fixtures():
    from conftest import ROOT

    top = ROOT.parent / "shared" / "fixtures"
    if not top.is_dir():
        return []
    files = [p for p in sorted(top.iterdir()) + sorted((top / "real").iterdir())
             if p.is_file() and p.suffix not in (".md", ".ser")]  # the .ser is read through its .emi
    return [str(p.relative_to(top)) for p in files]


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", _all_fixtures() or ["real/zeiss_dapi_gfp_2ch.czi"])
def test_automatic_channel_path_on_every_real_fixture(fixture, name):
    """Multi-channel files and the stained slide take the channel path by default; every grey
    picture (SEM, TEM, STEM, grey JPEG stored as RGB, z-stacks, maps) stays on its old path."""
    from tamp_os.params import LithoParams
    from tamp_os.read.image import read_image
    from tamp_os.relief.channel_auto import route

    path = fixture(name)
    params = LithoParams()
    try:
        picture = read_image(path)
    except Exception as exc:  # a file this machine cannot read is not a decision to check
        pytest.fail(f"{name}: {exc}")
    got = route(path, picture, params)
    assert (got.kind if got else None) == CHANNEL_FIXTURES.get(name), (name, got)
    # opting out: one channel, or `channels` off
    assert route(path, picture, params.replace(channels="off")) is None
    assert route(path, picture, params.replace(channel="0")) is None


def _grey_to_lut(grey: np.ndarray, name: str) -> np.ndarray:
    from matplotlib import colormaps

    g = (grey - grey.min()) / (grey.max() - grey.min())
    return (colormaps[name](g)[..., :3] * 255).astype(np.uint8)


@pytest.mark.timeout(60)
def test_colour_decision_grey_lut_diagram_composite_stain():
    import skimage.data
    from PIL import Image, ImageDraw

    from tamp_os.read.image import read_array
    from tamp_os.relief.channel_auto import colour_facts, colour_kind

    def kind(rgb):
        return colour_kind(colour_facts(read_array(rgb).file.colour_sample))

    camera = skimage.data.camera()
    assert kind(np.repeat(camera[..., None], 3, axis=2))[0] == "plain"  # R = G = B
    for lut in ("inferno", "hot", "magma", "viridis", "jet"):  # false-colour SEM: colour follows brightness
        assert kind(_grey_to_lut(camera.astype(float), lut))[0] == "plain", lut
    assert "follows its brightness" in kind(_grey_to_lut(camera.astype(float), "inferno"))[1]
    im = Image.new("RGB", (400, 300), "white")
    draw = ImageDraw.Draw(im)
    draw.rectangle([20, 20, 150, 120], fill=(230, 80, 80), outline="black", width=3)
    draw.ellipse([200, 50, 350, 200], fill=(80, 160, 230), outline="black", width=3)
    draw.line([10, 250, 390, 250], fill=(40, 160, 60), width=5)
    got = kind(np.asarray(im))
    assert got[0] == "plain" and "diagram" in got[1]
    nuclei, fil, spots = _synthetic_channels()
    rng = np.random.default_rng(0)
    composite = np.clip(np.stack([fil, spots, nuclei], axis=-1) * 180 + rng.normal(0, 8, fil.shape + (3,)), 0, 255)
    assert kind(composite.astype(np.uint8))[0] == "fluorescence"
    assert kind((composite * 12).astype(np.uint16))[0] == "fluorescence"  # 12-bit data in 16 bits
    one_colour = np.stack([0 * nuclei, nuclei, 0 * nuclei], axis=-1) * 200
    assert kind(one_colour.astype(np.uint8))[0] == "plain"  # a single channel stored as RGB
    assert kind(skimage.data.immunohistochemistry())[0] == "stain"
    assert kind(skimage.data.astronaut())[0] == "plain"


@pytest.mark.timeout(300)
def test_multichannel_file_prints_channels_by_default_with_honest_notes(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    path = fixture("real/zeiss_dapi_gfp_2ch.czi")
    litho = make_lithograph(path, width_mm=80)
    r = litho.report
    assert r.relief_style == "channels" and r.relief_reason.startswith("auto chose channels (the file has 2 channels)")
    warnings = [str(w) for w in r.warnings]
    assert not any("using channel 0" in w for w in warnings)  # it used both
    assert any("printed channel by channel" in w and "channels off" in w for w in warnings), warnings
    assert [e.encoding for e in r.key] == ["domes", "plateau"]
    off = make_lithograph(path, width_mm=80, channels="off").report
    assert off.relief_style != "channels" and not off.key
    assert any("using channel 0" in str(w) for w in off.warnings)
    one = make_lithograph(path, width_mm=80, channel="1").report
    assert one.relief_style != "channels" and not one.key
    with pytest.raises(ParameterError, match="channel 1 prints one channel and channels DAPI=domes"):
        make_lithograph(path, width_mm=80, channel="1", channels="DAPI=domes")


@pytest.mark.timeout(300)
def test_grey_pictures_unchanged_by_the_automatic_path(fixture):
    """A grey picture gives the same heights with `channels` unset as with `channels` off."""
    for name in ("fept_spheres_sem.png", "real/stem_haadf_sio2_spheres.hspy"):
        auto = make_lithograph(fixture(name), width_mm=60, preset="low")
        off = make_lithograph(fixture(name), width_mm=60, preset="low", channels="off")
        assert auto.report.relief_style != "channels"
        assert np.array_equal(auto.heightmap, off.heightmap), name


@pytest.mark.timeout(60)
def test_tubes_become_lines_not_domes():
    """Branched tubes (mitochondria-like) and round blobs of the same width: lines and domes."""
    from tamp_os.relief.channels import TUBE_ELONGATION, measure_shape, shape_ranking

    rows = cols = 300
    yy, xx = np.mgrid[0:rows, 0:cols]
    tubes = np.zeros((rows, cols))
    for k in range(5):  # wavy tubes 5 px (1.5 mm) wide with a side branch each
        cy = 30 + 55 * k
        tubes[np.abs(yy - (cy + 8 * np.sin(xx / 17.0))) < 2.5] = 1.0
        tubes[(np.abs(xx - (60 + 40 * k)) < 2.5) & (yy > cy) & (yy < cy + 25)] = 1.0
    blobs = np.zeros((rows, cols))
    for cy, cx in [(50, 50), (50, 200), (150, 120), (240, 60), (240, 230)]:
        blobs[(yy - cy) ** 2 + (xx - cx) ** 2 < 15 ** 2] = 1.0
    shape = measure_shape(tubes, 0.3)
    assert shape.tube_elongation >= TUBE_ELONGATION and shape_ranking(shape)[0] == "ridges"
    assert shape_ranking(measure_shape(blobs, 0.3))[0] == "domes"
    res = channel_relief([ChannelImage("a", tubes), ChannelImage("b", blobs)], mm_per_px=0.3, base_mm=1.0, relief_mm=3.0)
    assert {c.name: c.encoding for c in res.choices} == {"a": "ridges", "b": "domes"}
    from scipy import ndimage as ndi

    h = res.heights_mm - 1.0
    line = (h >= 0.5) & (tubes > 0) & (blobs == 0)
    assert float(line.sum()) > 0.3 * float(tubes.sum()) * 1.2 / 1.5  # most of each tube is raised as a line
    from skimage.morphology import skeletonize

    width_mm = 2 * ndi.distance_transform_edt(line)[skeletonize(line)] * 0.3
    assert 0.9 <= np.median(width_mm) <= 1.8  # raised lines about 1.2 mm wide along each tube, not a texture


@pytest.mark.timeout(300)
def test_real_airyscan_mitochondria_as_lines(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    litho = make_lithograph(fixture("real/zeiss_airyscan_2ch_t3.czi"), width_mm=80)
    enc = {e.label: e.encoding for e in litho.report.key}
    # the document name "mCherryEB3_GFPMito" says the roles; GFP-mito: never domes
    assert enc == {"microtubules (ChA-T1)": "plateau", "mitochondria (ChA-T2)": "ridges"}
    assert check_solid(litho.mesh).ok


@pytest.mark.timeout(400)
def test_two_colour_key_braille_and_outlines_on_the_second_part(fixture, tmp_path):
    need(liblouis_available(), "liblouis (braille key)")
    from threemf_support import one_mesh_object as _one_mesh_object, parts_by_material as _parts_by_material, read_3mf as _read_3mf

    from tamp_os.relief.key3d import SWATCH_H_MM

    litho = make_lithograph(fixture("real/zeiss_dapi_gfp_2ch.czi"), width_mm=80, multicolour=True, formats=("3mf",))
    r = litho.report
    assert len(litho.parts) == 2 and "key" in litho.parts[1].label
    litho.save(tmp_path, stem="k")
    wrapper, model = _read_3mf(tmp_path / "k.3mf")
    group = model.GetBaseMaterialGroups()
    assert group.MoveNext()
    names = {i: group.GetCurrentBaseMaterialGroup().GetName(i) for i in group.GetCurrentBaseMaterialGroup().GetAllPropertyIDs()}
    parts = {names[k]: mesh for k, (mesh, _) in _parts_by_material(_one_mesh_object(model)).items()}
    base, raised = parts[litho.parts[0].label], parts[litho.parts[1].label]
    assert base.is_watertight and raised.is_watertight and raised.volume > 0
    rows_picture = litho.heightmap.shape[0] - round((r.relief_mm[1] - 80) / r.mm_per_px)
    spec, b = BrailleSpec(), litho.params.base_mm
    strip, _ = _key_dots_on_mesh(litho, rows_picture)
    ox, oy = r.tactile.relief_origin_mm if r.tactile else (0.0, 0.0)
    xy = np.array([(ox + x, oy + r.relief_mm[1] - ((rows_picture - 1) * r.mm_per_px + y)) for x, y in strip.dot_centres_mm])

    def top_at(mesh, points):
        """Height of the mesh's top surface above the base at each (x, y): the highest triangle over it."""
        tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]  # (n, 3, 3)
        a, e1, e2 = tri[:, 0, :2], tri[:, 1, :2] - tri[:, 0, :2], tri[:, 2, :2] - tri[:, 0, :2]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        ok = np.abs(det) > 1e-12
        tops = []
        for px, py in points:
            dx, dy = px - a[:, 0], py - a[:, 1]
            u = np.where(ok, (dx * e2[:, 1] - dy * e2[:, 0]) / np.where(ok, det, 1), -1)
            v = np.where(ok, (e1[:, 0] * dy - e1[:, 1] * dx) / np.where(ok, det, 1), -1)
            inside = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)
            z = tri[inside, 0, 2] + u[inside] * (tri[inside, 1, 2] - tri[inside, 0, 2]) + v[inside] * (tri[inside, 2, 2] - tri[inside, 0, 2])
            tops.append(z.max() - b if z.size else -1.0)  # no triangle: nothing of this part there
        return np.array(tops)

    on_raised, on_base = top_at(raised, xy), top_at(base, xy)
    assert len(on_raised) == sum((ord(c) - 0x2800).bit_count() for e in r.key for c in e.braille)
    assert min(on_raised) == pytest.approx(spec.dot_height_mm, abs=0.08)  # every key dot is in the second colour
    assert max(on_base) < 0.1  # and none on the base part: the plate is flat there
    # each swatch's outline is in the second colour: raised vertices along the swatch's left edge
    v = np.asarray(raised.vertices)
    ox = r.tactile.relief_origin_mm[0] if r.tactile else 0.0
    from tamp_os.relief.key3d import KEY_GAP_MM, OUTLINE_MM

    left = v[(np.abs(v[:, 0] - (ox + KEY_GAP_MM + OUTLINE_MM / 2)) < OUTLINE_MM) & (v[:, 2] > b + 0.5 * spec.dot_height_mm)]
    assert np.ptp(left[:, 1]) >= SWATCH_H_MM * 0.8


@pytest.mark.timeout(300)
def test_paper_graphic_of_a_channel_print_has_textures_and_a_braille_key(fixture, tmp_path):
    """Swell paper: one distinct paper texture per channel (outline, dots, lines), the key with a
    swatch of each and its label in braille, every element at least 3 mm from the others."""
    need(liblouis_available(), "liblouis (braille key)")
    import itertools

    from tamp_os.export.tactile2d import save_graphic
    from tamp_os.lithograph.outputs import tactile_graphic
    from tamp_os.tactile.furniture import CLEARANCE_MM

    litho = make_lithograph(fixture("real/nikon_pbmc_4ch.nd2"), width_mm=80)
    g = tactile_graphic(litho)
    key = litho.report.key
    assert len(g.key) == len(key) == 3
    assert sorted(g.textures.values()) == ["dots", "lines", "outline"]  # three textures, each once
    assert [row.texture for row in g.key] == [g.textures[i + 1] for i in range(3)]
    for row, entry in zip(g.key, key):  # the label's braille, wrapped into lines
        assert "".join(row.label.lines).replace("⠀", "") == entry.braille.replace("⠀", "")
    assert set(np.unique(g.regions)) <= {0, 1, 2, 3} and g.regions.shape[0] == round(80 / g.mm_per_px)
    boxes = g.element_boxes()

    def gap(a, b):
        dx, dy = max(b[0] - a[2], a[0] - b[2], 0), max(b[1] - a[3], a[1] - b[3], 0)
        return math.hypot(dx, dy)

    for (na, a), (nb, b) in itertools.combinations(boxes.items(), 2):
        assert gap(a, b) >= CLEARANCE_MM - 1e-6, (na, nb, gap(a, b))
    for box in boxes.values():  # all on the plate
        assert box[0] >= 0 and box[1] >= 0 and box[2] <= g.plate_mm[0] and box[3] <= g.plate_mm[1]
    path = save_graphic(g, tmp_path / "k.svg")
    svg = path.read_text()
    assert svg.count("<path") >= 1 and path.stat().st_size > 1000


# ---- key labels that fit: at most two braille lines each, a bounded key depth ----------------

def _read_key_braille_on_mesh(litho, rows_picture, strip):
    """Each key entry's braille read from the mesh: every dot position of every cell in its braille
    box sampled on the mesh (raised: above half the dot height), decoded to Unicode cells, lines
    joined by a blank cell; and the number of lines."""
    from tamp_os.tactile.braille import BLANK, DOT_POSITION

    r, spec = litho.report, BrailleSpec()
    mm = r.mm_per_px
    ox, oy = r.tactile.relief_origin_mm if r.tactile else (0.0, 0.0)
    v = litho.mesh.vertices
    base = litho.params.base_mm
    rad = spec.dot_diameter_mm / 2

    def raised(x, y_dn):
        X, Y = ox + x, oy + r.relief_mm[1] - ((rows_picture - 1) * mm + y_dn)
        near = v[np.hypot(v[:, 0] - X, v[:, 1] - Y) < 0.6]
        return len(near) > 0 and near[:, 2].max() - base > spec.dot_height_mm / 2

    out = []
    for _, (x0, y0, x1, y1) in strip.boxes_mm:
        n_lines = round((y1 - y0 - spec.cell_height_mm) / spec.line_spacing_mm) + 1
        n_cells = round((x1 - x0 - spec.dot_spacing_mm - spec.dot_diameter_mm) / spec.cell_spacing_mm) + 1
        lines = []
        for i in range(n_lines):
            cells = ""
            for j in range(n_cells):
                bits = sum(1 << (d - 1) for d, (col, row) in DOT_POSITION.items() if d <= 6 and raised(
                    x0 + rad + j * spec.cell_spacing_mm + col * spec.dot_spacing_mm,
                    y0 + rad + i * spec.line_spacing_mm + row * spec.dot_spacing_mm))
                cells += chr(0x2800 + bits)
            lines.append(cells.rstrip(BLANK))
        out.append((BLANK.join(lines), n_lines))
    return out


def _gap_mm(a, b):
    dx = max(b[0] - a[2], a[0] - b[2], 0.0)
    dy = max(b[1] - a[3], a[1] - b[3], 0.0)
    return math.hypot(dx, dy)


@pytest.mark.timeout(300)
def test_real_nd2_key_labels_fit_two_lines_read_back_from_the_mesh(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    from tamp_os.relief.key3d import MAX_LABEL_LINES, key_depth_bound_mm, key_strip
    from tamp_os.tactile.braille import to_braille

    litho = make_lithograph(fixture("real/nikon_pbmc_4ch.nd2"), width_mm=80)
    r = litho.report
    grew = float(next(str(w) for w in r.warnings if "grew by" in str(w)).split("grew by ")[1].split(" mm")[0])
    assert grew <= key_depth_bound_mm(len(r.key)) + r.mm_per_px
    rows_picture = litho.heightmap.shape[0] - round(grew / r.mm_per_px)
    strip = key_strip(r.key, width_mm=r.relief_mm[0], mm_per_px=r.mm_per_px, relief_mm=litho.params.relief_mm,
                      table=litho.params.braille_table)
    assert strip.depth_mm == pytest.approx(grew, abs=r.mm_per_px)
    read = _read_key_braille_on_mesh(litho, rows_picture, strip)
    for e, (cells, n_lines) in zip(r.key, read):
        assert n_lines <= MAX_LABEL_LINES
        assert cells == e.braille == to_braille(e.braille_label, litho.params.braille_table)
        assert "BP" not in e.braille_label  # the filter is not written in braille...
    labels = {e.label for e in r.key}
    assert {"spots (FITC BP)", "diffuse (TRITC BP)"} <= labels  # ...the full name stays in the report
    assert "spots (FITC BP)" in r.relief_reason and any("shorter labels" in str(w) for w in r.warnings)
    boxes = [b for pair in strip.boxes_mm for b in pair]
    assert min(_gap_mm(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:]) >= KEY_GAP_MM - 1e-9


@pytest.mark.timeout(120)
def test_synthetic_long_names_shortened_or_cut_to_two_lines_and_two_columns_on_a_wide_plate():
    need(liblouis_available(), "liblouis (braille key)")
    from tamp_os.relief.channels import KeyEntry
    from tamp_os.relief.key3d import SWATCH_H_MM as SWATCH_H_MM_
    from tamp_os.relief.key3d import key_depth_bound_mm, key_strip
    from tamp_os.relief.key_labels import label_forms
    from tamp_os.tactile.braille import to_braille

    spec = BrailleSpec()
    two_lines_mm = spec.line_spacing_mm + spec.cell_height_mm
    long_name = "Hoechst 33342 HyD 2 Leica/BP 460/50"
    entries = (
        KeyEntry(f"nuclei ({long_name})", "domes", key_forms=label_forms("nuclei", long_name)),
        KeyEntry("mitochondria stained with a tetramethylrhodamine ester dye, imaged live", "ridges"),  # the user's words
        KeyEntry("spots (Alexa Fluor 647 BP 690/50)", "dots", key_forms=label_forms("spots", "Alexa Fluor 647 BP 690/50")),
    )
    for width in (70.0, 100.0, 250.0):
        strip = key_strip(entries, width_mm=width, mm_per_px=0.4, relief_mm=3.0, table="en-ueb-g2.ctb")
        assert strip.depth_mm <= key_depth_bound_mm(len(entries)) + 0.4
        for e, (swatch, text) in zip(strip.entries, strip.boxes_mm):
            assert text[3] - text[1] <= two_lines_mm + 1e-9  # at most two braille lines
            assert text[2] <= width - KEY_GAP_MM + 1e-9 and swatch[0] >= KEY_GAP_MM - 1e-9
            assert "HyD" not in e.braille_label and "460" not in e.braille_label and "690" not in e.braille_label
            full = to_braille(e.braille_label, "en-ueb-g2.ctb")
            if e.key_forms:  # a form of the channel's name, written whole
                assert e.braille == full
            else:  # the user's own words: whole, or their first two lines
                assert e.braille == full or full.replace("\u2800", "").startswith(e.braille.replace("\u2800", ""))
        assert "Hoechst" in strip.entries[0].braille_label
        if width == 70.0:  # the user's long words do not fit two lines there: cut, not a third line
            assert strip.entries[1].braille != to_braille(strip.entries[1].label, "en-ueb-g2.ctb")
        boxes = [b for pair in strip.boxes_mm for b in pair]
        assert min(_gap_mm(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:]) >= KEY_GAP_MM - 1e-9
    # four short labels on a wide plate: two columns, read row by row, half as deep as one column
    four = tuple(KeyEntry(f"{role} ({dye})", enc, key_forms=label_forms(role, dye)) for role, dye, enc in
                 (("nuclei", "DAPI", "domes"), ("lines", "GFP", "ridges"), ("spots", "Cy5", "dots"), ("diffuse", "RFP", "plateau")))
    wide = key_strip(four, width_mm=250.0, mm_per_px=0.4, relief_mm=3.0, table="en-ueb-g2.ctb")
    lefts = [sw[0] for sw, _ in wide.boxes_mm]
    assert lefts[0] == lefts[2] < 250.0 / 2 < lefts[1] == lefts[3]
    one_line_row = max(SWATCH_H_MM_, spec.cell_height_mm) + KEY_GAP_MM
    assert wide.depth_mm == pytest.approx(KEY_GAP_MM + 2 * one_line_row, abs=0.4)  # to the grid step
    assert [e.braille_label for e in wide.entries] == [e.label for e in four]  # nothing shortened: room enough
    boxes = [b for pair in wide.boxes_mm for b in pair]
    assert min(_gap_mm(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:]) >= KEY_GAP_MM - 1e-9


# ---- axial sections: points the PSF drew long along Z are still round objects -----------------

def _xz_beads_and_a_layer(rows=240, cols=240, stretch=3.0):
    """An XZ section: beads 4 px across, drawn `stretch` times longer along Z (rows), and a
    second channel with two thin layers along X (a coverslip and a membrane, seen side-on)."""
    yy, xx = np.mgrid[0:rows, 0:cols]
    beads = np.zeros((rows, cols))
    rng = np.random.default_rng(5)
    for cy, cx in rng.integers(30, rows - 30, size=(25, 2)):
        beads = np.maximum(beads, np.exp(-((xx - cx) ** 2 / (2 * 2.5 ** 2) + (yy - cy) ** 2 / (2 * (2.5 * stretch) ** 2))))
    layer = np.zeros((rows, cols))
    for y0 in (60, 170):
        layer[np.abs(yy - y0) < 2] = 1.0
    return beads, layer


@pytest.mark.timeout(60)
def test_axial_section_beads_are_not_lines_and_layers_stay_lines():
    from tamp_os.relief.channels import axial_stretch, foreground

    beads, layer = _xz_beads_and_a_layer()
    chans = [ChannelImage("channel 0", beads), ChannelImage("channel 1", layer)]
    as_top_view = channel_relief(chans, mm_per_px=0.4, base_mm=1.0, relief_mm=3.0)
    side = channel_relief(chans, mm_per_px=0.4, base_mm=1.0, relief_mm=3.0, section="XZ")
    assert {c.name: c.encoding for c in as_top_view.choices}["channel 0"] == "ridges"  # what went wrong before
    got = {c.name: c.encoding for c in side.choices}
    assert got["channel 0"] in ("domes", "dots") and got["channel 1"] == "ridges"
    stretch = axial_stretch([foreground(beads), foreground(layer)])
    assert 2.0 <= stretch <= 4.0  # drawn 3x longer; the Otsu outline of a Gaussian is a little rounder
    assert any("XZ section" in str(n) and "longer along Z" in str(n) for n in side.notes)
    # a section whose structures are not stretched is measured as it is, and says so
    plain = channel_relief([ChannelImage("a", _synthetic_channels()[0]), ChannelImage("b", _synthetic_channels()[2])],
                           mm_per_px=0.3, base_mm=1.0, relief_mm=3.0, section="XZ")
    assert any("not stretched" in str(n) for n in plain.notes)


@pytest.mark.timeout(300)
def test_real_leica_xz_beads_print_as_domes_or_dots_and_the_report_says_xz(fixture):
    need(liblouis_available(), "liblouis (braille key)")
    path = fixture("real/leica_beads_xz_2ch.lif")
    for scene in (None, 2):  # `xzt` (the default) and `xz`, the 512x512 section
        litho = make_lithograph(path, width_mm=100, scene=scene)
        r = litho.report
        assert sorted(e.encoding for e in r.key) == ["domes", "dots"], [(e.label, e.encoding) for e in r.key]
        assert any("XZ section" in str(w) for w in r.warnings)
        h = litho.heightmap - litho.params.base_mm
        # the beads stand: every channel's structures raised at least 0.5 mm (as the benchmark measures)
        from skimage import filters
        from skimage.transform import resize

        from tamp_os.relief import channel_stage

        grew = float(next(str(w) for w in r.warnings if "grew by" in str(w)).split("grew by ")[1].split(" mm")[0])
        pic = h[: h.shape[0] - round(grew / r.mm_per_px)]
        for _, values, _, _ in channel_stage.raw_channels(path, litho.params):
            v = resize(values.astype(np.float64), pic.shape, anti_aliasing=True)
            s = v > filters.threshold_otsu(v)
            assert float((pic[s] >= 0.5).mean()) > 0.8


# ---- annotations burnt into one channel ---------------------------------------------------------

@pytest.mark.timeout(300)
def test_label_burnt_into_channel_1_only_is_removed_from_it_and_channel_0_keeps_its_nucleus(tmp_path):
    need(liblouis_available(), "liblouis (braille key)")
    import tifffile
    from PIL import Image, ImageDraw

    n, f, s = _synthetic_channels(300, 300)
    yy, xx = np.mgrid[0:300, 0:300]
    under = (yy - 276) ** 2 + (xx - 240) ** 2 < 11 ** 2  # a nucleus of channel 0 under channel 1's label
    ch0 = ((np.maximum(n, under) * 200) + 10).astype(np.uint16)
    ch1 = (s * 180 + f * 120 + 10).astype(np.uint16)
    box = Image.fromarray(np.zeros((300, 300), np.uint8))
    draw = ImageDraw.Draw(box)
    draw.rectangle([190, 262, 290, 290], fill=255)  # a white label box with dark text, as a viewer burns it in
    draw.text((196, 268), "GFP 10 um", fill=0)
    label = np.asarray(box) > 128
    ch1 = np.where(label, 4095, ch1).astype(np.uint16)  # the camera's white, only in channel 1
    path = tmp_path / "two_channels.tif"
    tifffile.imwrite(path, np.stack([ch0, ch1]), imagej=True, metadata={"axes": "CYX"})

    litho = make_lithograph(path, width_mm=90)
    r = litho.report
    assert r.relief_style == "channels" and len(r.key) == 2
    assert any("'channel 1' alone" in str(w) and "box" in str(w) for w in r.warnings)
    pic = litho.heightmap[: round(90 / r.mm_per_px) + 1] - litho.params.base_mm
    k = pic.shape[0] / 300

    def grid(mask):
        from skimage.transform import resize

        return resize(mask.astype(float), pic.shape, order=0) > 0.5

    box_on_grid = grid(label) & ~grid(ndi_dilate(under, 8))  # the label's box, away from the nucleus under it
    assert float((pic[box_on_grid] >= 0.5).mean()) < 0.02  # no raised block where the label was
    assert pic[round(276 * k), round(240 * k)] >= 1.0  # channel 0's nucleus under it still stands
    # elsewhere the print is the one the same picture makes without the label
    clean = tmp_path / "two_channels_no_label.tif"
    tifffile.imwrite(clean, np.stack([ch0, np.where(label, (s * 180 + f * 120 + 10), ch1).astype(np.uint16)]),
                     imagej=True, metadata={"axes": "CYX"})
    plain = make_lithograph(clean, width_mm=90)
    assert not any("alone" in str(w) for w in plain.report.warnings)
    other = plain.heightmap[: pic.shape[0]] - litho.params.base_mm
    away = ~grid(ndi_dilate(label, 6))
    assert float((np.abs(pic - other)[away] > 0.05).mean()) < 0.01
    assert float((pic[away & grid((s + f) > 0)] >= 0.5).mean()) > 0.5  # and channel 1's structures stand there


def ndi_dilate(mask, px):
    from scipy import ndimage as ndi

    return ndi.binary_dilation(mask, iterations=px)


@pytest.mark.timeout(300)
def test_the_description_gives_the_pictures_own_size_beside_the_key():
    """Issue 33 (6): a square three-channel picture on a plate grown for its braille key is
    described as a square picture; the key's depth is the plate's, not the picture's."""
    need(liblouis_available(), "liblouis (braille key)")
    from tamp_os.lithograph.report import describe

    nuclei, fil, spots = _synthetic_channels()
    rgb = (np.stack([fil, spots, nuclei], axis=-1) * 230).astype(np.uint8)
    litho = make_lithograph(rgb, width_mm=80)
    r = litho.report
    assert r.key and r.key_depth_mm > 5, r.key_depth_mm
    assert r.relief_mm[1] == pytest.approx(80 + r.key_depth_mm, abs=0.5)
    said = describe(r, litho.params, "cells.png")
    assert "the picture on it is 80 by 80 mm" in said, said
    assert r.as_dict()["key_depth_mm"] == r.key_depth_mm
    plain = make_lithograph(nuclei, width_mm=80).report
    assert "key_depth_mm" not in plain.as_dict() and "the picture on it is 80 by 80 mm" in describe(plain, litho.params, "n.png")
