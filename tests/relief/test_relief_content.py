"""The content relief style (issue 26) on synthetic pictures with exact truth (100 mm wide, 3 mm relief).

Every figure is measured on the heights in mm against the picture's truth, not against what the
style says it found.
"""

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import need_module, examples
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage
from synthetic_content import (
    lumps_as_wide_as_gaps,
    membranes_on_grey,
    dark_line_network,
    dim_and_bright_beads,
    dot_lattice,
    faint_grains,
    line_diagram,
    thin_boundary_grains,
)

from tamp_os.relief.content import ContentHints
from tamp_os.relief.legibility import assess
from tamp_os.relief.preprocess import prepare
from tamp_os.relief.styles import make_relief

BASE, RELIEF = 1.0, 3.0


def prep(image, invert=False):
    rows, cols = image.shape
    return prepare(image, None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
                   low_pct=2.0, high_pct=98.0, sigma_px=1.2, invert=invert, flip_x=False).image


def pitch(image):
    return 100.0 / (image.shape[1] - 1)


def content(image, invert=False, **kw):
    return make_relief(prep(image, invert), style="content", mm_per_px=pitch(image), base_mm=BASE, relief_mm=RELIEF, **kw)


def tops_over_rings(h, labels, mm, ring_mm=1.5):
    """Per true member: highest point minus the median of the 1.5 mm ring around it."""
    mask = labels > 0
    dist, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    owner = np.where(~mask & (dist * mm <= ring_mm), labels[iy, ix], 0)
    n = int(labels.max())
    tops = np.array([h[labels == k].max() for k in range(1, n + 1)])
    rings = np.array([np.median(h[owner == k]) for k in range(1, n + 1)])
    return tops - rings


@pytest.mark.timeout(60)
def test_every_bead_dim_or_bright_is_raised_by_the_same_lift_and_the_glow_is_not():
    truth = dim_and_bright_beads()
    made = content(truth.image)
    mm = pitch(truth.image)
    lifts = tops_over_rings(made.heights_mm, truth.members, mm)
    # Peaks differ 7x in brightness; every bead stands >= 1 mm over its ring, all within 0.3 mm of each other.
    assert lifts.min() >= 1.0 and np.ptp(lifts) <= 0.3, np.round(lifts, 2)
    # The broad glow of shading is no object: the ground 1 mm away from every bead is flat at the base.
    far = ndimage.distance_transform_edt(truth.members == 0) * mm > 1.0
    assert np.percentile(made.heights_mm[far], 99) <= BASE + 0.05
    # The touching pair stays two: a groove between them drops at least 0.5 mm below both tops.
    a, b = truth.members == 5, truth.members == 6
    between = ndimage.binary_dilation(a, iterations=2) & ndimage.binary_dilation(b, iterations=2)
    assert made.heights_mm[between].min() <= min(made.heights_mm[a].max(), made.heights_mm[b].max()) - 0.5
    assert made.object_count == 10
    assert any(check.startswith("Found 10 members, all raised at least") for check in made.checks)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("invert", [False, True])
def test_dark_line_network_becomes_raised_lines_on_a_flat_ground(invert):
    """Dark lines on bright (or, inverted, bright lines on dark): the same raised lines, since
    polarity comes from the content; lines 1.0-1.5 mm wide and 0.8-1.2 mm high."""
    truth = dark_line_network()
    made = content(truth.image, invert=invert)
    mm, h = pitch(truth.image), made.heights_mm
    enclosed = ndimage.distance_transform_edt(~truth.lines) * mm > 1.5
    rise = np.median(h[truth.lines]) - np.median(h[enclosed])
    assert 0.8 <= rise <= 1.2, rise
    assert np.percentile(h[enclosed], 95) <= BASE + 0.05  # flat ground inside the cells
    # Width: raised area (over half the line height) per mm of true line.
    length_mm = _skeleton_length_mm(truth.lines, mm)
    width_mm = ((h - BASE) > 0.5).sum() * mm * mm / length_mm
    assert 1.0 <= width_mm <= 1.6, width_mm
    assert "network of lines" in made.reason and "1.2 mm wide" in made.reason
    assert any("raised 1.0 mm over the areas they enclose" in check for check in made.checks)


@pytest.mark.timeout(60)
def test_lines_under_a_strength_floor_are_left_untraced_and_a_network_over_it_is_traced_in_full():
    """find_lines' min_strength: a network stronger than the floor comes out as without it; the
    same picture's lines under a floor above their strength keep their skeleton, strength and
    length but enclose no regions (untraced), so no caller can take them for a network."""
    from tamp_os.relief.lines import find_lines

    truth = dark_line_network()
    dark_lines = 1.0 - truth.image
    full = find_lines(dark_lines, pitch_mm=pitch(truth.image))
    assert full.traced and full.cell_count >= 10 and full.strength > 20
    over = find_lines(dark_lines, pitch_mm=pitch(truth.image), min_strength=full.strength)
    assert over.traced and np.array_equal(over.cells, full.cells) and over.separate_at == full.separate_at
    under = find_lines(dark_lines, pitch_mm=pitch(truth.image), min_strength=full.strength + 1)
    assert not under.traced and under.cell_count == 0 and not under.cells.any() and not under.merged.any()
    assert np.array_equal(under.skeleton, full.skeleton) and under.strength == full.strength
    assert under.length_mm == full.length_mm and under.cover == full.cover


def _skeleton_length_mm(mask, mm):
    from skimage.morphology import skeletonize

    return skeletonize(mask).sum() * mm * 1.12


@pytest.mark.timeout(60)
def test_line_diagram_strokes_are_raised_and_the_text_is_not():
    truth = line_diagram()
    made = content(truth.image)
    mm, h = pitch(truth.image), made.heights_mm
    assert np.median(h[truth.lines]) >= BASE + 0.8
    # White paper is the ground, at the base; the printed words are not raised as lines.
    paper = ndimage.distance_transform_edt(~(truth.lines | truth.text)) * mm > 1.5
    assert np.percentile(h[paper], 99) <= BASE + 0.05
    words = ndimage.binary_dilation(truth.text, iterations=1) & ~ndimage.binary_dilation(truth.lines, iterations=4)
    assert (h[words] - BASE > 0.5).mean() < 0.1


@pytest.mark.timeout(60)
def test_lattice_is_kept_as_domes_and_named_with_its_pitch():
    truth = dot_lattice()  # 10 px = 3.9 mm pitch on a 100 mm print
    made = content(truth.image)
    h = made.heights_mm
    inner = h[13:-13, 13:-13]
    assert np.percentile(inner, 95) - np.percentile(inner, 5) >= 1.0
    pitch_mm = truth.pitch_px * pitch(truth.image)
    import re

    said = re.search(r"a lattice of ([0-9.]+) mm pitch", made.reason)
    assert said and abs(float(said.group(1)) - pitch_mm) <= 0.1 * pitch_mm, made.reason
    report = assess(h, pitch(truth.image), objects=made.objects, style=made.style)
    assert not any("larger detail_mm" in v or "relief_style structure" in v for v in report.verdicts)


@pytest.mark.timeout(60)
def test_grains_three_percent_apart_become_distinct_and_the_mount_stays_at_the_base():
    truth = faint_grains()
    made = content(truth.image)
    h = made.heights_mm
    mount = ndimage.binary_erosion(truth.grains == 0, iterations=3)
    assert np.percentile(h[mount], 99) <= BASE + 0.05
    # Neighbouring grains differ by >= 0.5 mm (median over all neighbouring pairs).
    med = ndimage.median(h, truth.grains, np.arange(truth.grains.max() + 1))
    a, b = truth.grains[:, 3:], truth.grains[:, :-3]
    pairs = {(x, y) for x, y in zip(a[(a != b) & (a > 0) & (b > 0)], b[(a != b) & (a > 0) & (b > 0)])}
    steps = [abs(med[x] - med[y]) for x, y in pairs]
    assert len(steps) >= 10 and np.median(steps) >= 0.5, np.round(steps, 2)


@pytest.mark.timeout(60)
def test_a_bright_patch_of_shading_is_not_an_object():
    rows, cols = 188, 250
    yy, xx = np.mgrid[0:rows, 0:cols]
    glow = 0.2 + 0.5 * np.exp(-((yy - 90) ** 2 + (xx - 120) ** 2) / (2 * 35.0**2))
    image = (glow + 0.01 * np.random.default_rng(0).standard_normal((rows, cols))).astype(np.float32)
    made = content(np.clip(image, 0, 1))
    assert made.object_count == 0 and "members" not in made.reason.split(";")[0]


@pytest.mark.timeout(60)
def test_the_reason_names_the_files_detector_and_the_electron_signal_sets_the_ground():
    truth = dim_and_bright_beads()
    made = content(truth.image, hints=ContentHints(detector="HAADF", signal="STEM"))
    assert "file metadata: detector HAADF, STEM signal" in made.reason
    assert "STEM signal: electron images have a dark ground" in made.reason


@pytest.mark.timeout(120)
def test_content_through_the_pipeline_is_a_closed_print_of_the_requested_size(tmp_path):
    import trimesh

    from tamp_os.lithograph.pipeline import make_lithograph

    image = (dark_line_network().image * 255).astype(np.uint8)
    litho = make_lithograph(image, relief_style="content", width_mm=80, scale_bar="off")
    assert litho.report.relief_style == "content" and "network of lines" in litho.report.relief_reason
    path = tmp_path / "lines.stl"
    litho.save(path)
    mesh = trimesh.load(path, force="mesh")
    mesh.merge_vertices()
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert mesh.bounds[1][0] - mesh.bounds[0][0] == pytest.approx(80, abs=1e-6)
    # The check compares with the picture, first among the legibility sentences.
    assert litho.report.legibility["verdicts"][0].startswith("A network of lines, raised 1.0 mm")
    # Lines stand 1 mm over the base, whatever the relief: a tactile line's height.
    assert litho.heightmap.max() == pytest.approx(litho.params.base_mm + 1.0, abs=0.05)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("pitch_px, feelable", [(10.0, True), (4.0, False)])
def test_the_check_counts_a_feelable_lattice_as_pattern_and_a_fine_one_as_roughness(pitch_px, feelable):
    """Brightness = height of a dot lattice: at 3.9 mm pitch the check says it is a lattice a finger
    feels and gives no advice to smooth it away; at 1.6 mm it is roughness."""
    truth = dot_lattice(pitch_px=pitch_px)
    mm = pitch(truth.image)
    h = make_relief(prep(truth.image), style="reference", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF).heights_mm
    report = assess(h, mm, style="reference")
    assert report.fine_share > 0.2
    said = " ".join(report.verdicts)
    if feelable:
        assert report.period_mm == pytest.approx(pitch_px * mm, rel=0.1)
        assert "lattice of" in said and "roughness" in said and "try" not in said.split("lattice of")[0][-60:]
        assert not any("larger detail_mm" in v for v in report.verdicts)
    else:
        assert report.period_mm is None and "felt as roughness" in said


@pytest.mark.timeout(60)
def test_auto_takes_the_faint_grains_as_plateaus_above_the_mount_and_says_how_many_levels():
    truth = faint_grains()
    made = make_relief(prep(truth.image), style="auto", mm_per_px=pitch(truth.image), base_mm=BASE, relief_mm=RELIEF, layer_mm=0.12)
    assert made.style == "content" and "grains" in made.reason, made.reason
    h = made.heights_mm
    mount = ndimage.binary_erosion(truth.grains == 0, iterations=3)
    assert np.percentile(h[mount], 99) <= BASE + 0.05
    # Every grain stands on a plateau at least one 0.5 mm step above the mount; at least two levels in use.
    inner = ndimage.binary_erosion(truth.grains > 0, iterations=3)
    assert np.percentile(h[inner], 5) >= BASE + 0.5
    levels = np.unique(np.round(h[inner], 1))
    assert sum((np.round(h[inner], 1) == v).mean() > 0.05 for v in levels) >= 2
    assert any(c.startswith("Grains: ") and "levels" in c for c in made.checks), made.checks


@pytest.mark.timeout(60)
def test_both_polarities_ridges_from_one_hessian_match_the_inverted_picture():
    from tamp_os.relief.lines import hessian_ridges, ridge_response

    truth = dark_line_network()
    image, mm = prep(truth.image), pitch(truth.image)
    bright, dark = hessian_ridges(image, mm)
    np.testing.assert_allclose(bright, ridge_response(image, mm), atol=1e-6)
    # Up to the truncated kernel's answer on a constant (scipy's second-derivative kernels sum to
    # about 2e-4, not 0): negligible beside the lines' response (its 99th percentile is ~0.2).
    np.testing.assert_allclose(dark, ridge_response(1.0 - image, mm), atol=1e-3)
    assert np.percentile(dark, 99) > 0.1
    assert dark[truth.lines].mean() > 5 * bright[truth.lines].mean()  # the network's lines are dark


@pytest.mark.timeout(120)
@settings(max_examples=examples(60), deadline=None)
@given(seed=st.integers(0, 2**31 - 1), sigma=st.floats(0.5, 3.0), level=st.floats(0.45, 0.62))
def test_the_bounding_octagon_holds_every_pixel_of_the_hull(seed, sigma, level):
    from tamp_os.relief.hull import convex_hull_mask, octagon_px

    rng = np.random.default_rng(seed)
    labels, n = ndimage.label(ndimage.gaussian_filter(rng.random((24, 24)), sigma) > level)
    if n == 0:
        return
    boxes = ndimage.find_objects(labels)
    which = np.ones(n + 1, bool)
    which[0] = False
    bound = octagon_px(labels, which, boxes)
    for k in range(1, n + 1):
        box = boxes[k - 1]
        hull = int(convex_hull_mask(labels[box] == k).sum())
        assert int((labels == k).sum()) <= hull <= bound[k] <= (box[0].stop - box[0].start) * (box[1].stop - box[1].start)


@pytest.mark.timeout(120)
def test_a_dense_sem_particle_field_has_nine_in_ten_particles_felt(fixture):
    """SiO2 35kx (README: rounded particles 0.3-0.6 um, many touching): particles by Otsu after a
    2 px Gaussian, split by a distance watershed (benchmarks/content_truth.py), rows above the
    databar box; at least 90 % stand 0.5 mm over a 1.5 mm ring on the auto relief."""
    tifffile = need_module("tifffile")
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from content_metrics import members_felt
    from content_truth import _case, _members_by_threshold

    values = tifffile.imread(fixture("real/sem_fei_sio2_particles_35kx.tif")).astype(np.float32)
    values = (values[..., 0] if values.ndim == 3 else values)[:418]
    case = _case("35kx", values, members=_members_by_threshold(values, 2.0, 9, 120))
    made = make_relief(case.image01, style="auto", mm_per_px=case.mm_per_px, base_mm=BASE, relief_mm=RELIEF, layer_mm=0.12)
    assert made.style == "content"
    assert members_felt(made.heights_mm, case.truth.members, case.mm_per_px) >= 0.9


@pytest.mark.timeout(120)
def test_line_diagram_through_the_whole_pipeline_raises_its_strokes():
    """A drawing whose strokes enclose only two regions (no network: the diagram with its circle
    opened at the top) is still line art on empty paper: through make_lithograph (stretch, blur,
    Medium grid) its strokes stand up as lines and the paper lies at the base (before, the paper
    was raised and the strokes were grooves)."""
    from skimage.transform import resize

    from tamp_os import make_lithograph

    truth = line_diagram()
    gap = truth.lines & (np.arange(truth.image.shape[1]) >= 140)[None, :] & (np.arange(truth.image.shape[0]) < 50)[:, None]
    lines = truth.lines & ~gap
    image = np.where(gap, np.median(truth.image), truth.image).astype(np.float32)
    litho = make_lithograph(image, scale_bar="off")
    h = litho.heightmap - litho.params.base_mm
    strokes = resize(lines.astype(float), h.shape, order=0) > 0.5
    paper = resize((ndimage.distance_transform_edt(~(truth.lines | truth.text)) > 4).astype(float), h.shape, order=0) > 0.5
    assert litho.report.relief_style == "content" and "line art" in litho.report.relief_reason
    assert np.median(h[strokes]) >= 0.8 and np.percentile(h[paper], 99) <= 0.05


def _fine_case(truth, cols=250):
    """The picture prepared on the Medium grid (cols across 100 mm), its Prepared, and the truth
    lines on that grid."""
    rows = round((truth.image.shape[0] - 1) * (cols - 1) / (truth.image.shape[1] - 1)) + 1
    prepared = prepare(truth.image, None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
                       low_pct=2.0, high_pct=98.0, sigma_px=1.2, invert=False, flip_x=False)
    zoom = (rows / truth.image.shape[0], cols / truth.image.shape[1])
    lines = ndimage.zoom(truth.lines.astype(np.uint8), zoom, order=0, grid_mode=True, mode="grid-constant") > 0
    grains = ndimage.zoom(truth.grains, zoom, order=0, grid_mode=True, mode="grid-constant")
    return prepared, lines, grains, 100.0 / (cols - 1)


@pytest.mark.timeout(120)
def test_boundaries_under_a_print_pixel_wide_are_found_before_the_blur_and_raised_as_closed_lines():
    """Grain boundaries whose dark core and bright rims cancel on the Medium grid (as the Al2O3
    SEM picture's): lost there, found on the fine grid, drawn as tactile lines that keep the
    grains apart."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from content_metrics import lines_over_enclosed

    truth = thin_boundary_grains()
    prepared, lines, grains, mm = _fine_case(truth)
    kw = {"style": "auto", "mm_per_px": mm, "base_mm": BASE, "relief_mm": RELIEF, "layer_mm": 0.12}
    blind = make_relief(prepared.image, **kw)
    assert lines_over_enclosed(blind.heights_mm, lines, mm) < 0.5  # the print grid alone loses them
    made = make_relief(prepared.image, fine=prepared.finer, **kw)
    assert made.style == "content" and "thinner than the print grid" in made.reason, made.reason
    h = made.heights_mm
    assert lines_over_enclosed(h, lines, mm) >= 0.5
    top = float(np.median(h[lines]) - BASE)
    assert 0.8 <= top <= 1.2  # a tactile line's height
    # Closed regions stay closed: most grains' interiors lie in a low region of their own.
    low, _ = ndimage.label(h < BASE + 0.5)
    own = 0
    ids = [g for g in np.unique(grains) if g > 0 and (ndimage.binary_erosion(grains == g, iterations=4)).sum() > 40]
    where = {}
    for g in ids:
        inner = ndimage.binary_erosion(grains == g, iterations=4)
        region = np.bincount(low[inner]).argmax()
        where.setdefault(region, []).append(g)
    own = sum(len(v) for k, v in where.items() if k > 0 and len(v) == 1)
    assert own >= 0.7 * len(ids), (own, len(ids))


@pytest.mark.timeout(60)
def test_fine_lines_finds_the_same_network_whether_its_pieces_are_gathered_box_by_box_or_in_one_pass(monkeypatch):
    """The kept pieces' pixels are gathered from their boxes when they are few (MANY_PIECES) and in
    one pass over the fine grid otherwise: both give the same skeleton, regions and strength; a
    floor on the strength leaves out only the polarities under it."""
    from tamp_os.relief import lines as lines_module

    truth = thin_boundary_grains()
    prepared, _, _, mm = _fine_case(truth)
    picture = prepared.finer(2 * prepared.image.shape[1])
    fine_pitch_mm = 100.0 / (picture.shape[1] - 1)
    kw = {"fine_pitch_mm": fine_pitch_mm, "work_shape": prepared.image.shape, "pitch_mm": mm, "min_area_mm2": 6.0}
    by_box = lines_module.fine_lines(picture, **kw)
    monkeypatch.setattr(lines_module, "MANY_PIECES", -1)
    one_pass = lines_module.fine_lines(picture, **kw)
    assert by_box[False].skeleton.sum() > 100  # the grains' dark boundaries are found
    for bright in (True, False):
        a, b = by_box[bright], one_pass[bright]
        assert np.array_equal(a.skeleton, b.skeleton) and np.array_equal(a.cells, b.cells)
        assert a.strength == b.strength and a.cell_count == b.cell_count
    # A floor on the strength leaves out a weaker polarity and nothing else.
    floor = by_box[False].strength
    kept = lines_module.fine_lines(picture, **kw, min_strength=floor)
    assert np.array_equal(kept[False].skeleton, by_box[False].skeleton)
    assert set(kept) == {False} | ({True} if by_box[True].strength >= floor else set())
    assert lines_module.fine_lines(picture, **kw, min_strength=floor + 1e-6).keys() <= {True}


@pytest.mark.timeout(180)
def test_the_al2o3_grain_boundaries_become_a_raised_network_and_the_report_says_where_they_separate(fixture):
    """The Al2O3 SE picture (README: ~100 grains outlined by thin boundaries): auto takes the
    network found before the blur; lines stand at least 0.5 mm over what they enclose (truth:
    white top-hat, benchmarks/content_truth.py); lines too close to feel apart are merged and
    the note names a print width wider than this one."""
    czifile = need_module("czifile")
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import re

    from content_metrics import lines_over_enclosed
    from content_truth import _case, _no_short
    from skimage import filters, morphology

    values = np.squeeze(czifile.imread(fixture("real/zeiss_sem_al2o3_grains.czi"))).astype(np.float32)
    hat = morphology.white_tophat(filters.gaussian(values, 2, preserve_range=True), morphology.disk(8))
    truth_lines = ndimage.binary_dilation(_no_short(morphology.skeletonize(hat > filters.threshold_otsu(hat)), 40), iterations=2)
    case = _case("al2o3", values, lines=truth_lines)
    made = make_relief(case.image01, style="auto", mm_per_px=case.mm_per_px, base_mm=BASE, relief_mm=RELIEF, layer_mm=0.12,
                       fine=case.fine)
    assert made.style == "content" and "thinner than the print grid" in made.reason, made.reason
    assert lines_over_enclosed(made.heights_mm, case.truth.lines, case.mm_per_px) >= 0.5
    regions = int(re.search(r"enclosing (\d+) regions", made.reason).group(1))
    assert regions >= 50  # README: about 100 grains larger than 400 px²
    note = next(n for n in made.notes if "cannot separate" in n)
    assert int(re.search(r"print width of about (\d+) mm", note).group(1)) > 100


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", ["camera", "retina"])
def test_a_portrait_or_a_fundus_keeps_its_choice_though_the_fine_grid_finds_outlines(name):
    """Outlines the fine grid finds in a portrait or a fundus do not tile the picture (its sky or
    background is one region): auto chooses as without the fine grid."""
    import skimage.data
    from skimage.color import rgb2gray

    picture = np.asarray(getattr(skimage.data, name)(), np.float32)
    picture = rgb2gray(picture / 255.0) if picture.ndim == 3 else picture / 255.0
    truth = type("T", (), {"image": picture.astype(np.float32), "lines": np.zeros(picture.shape, bool),
                           "grains": np.zeros(picture.shape, np.int32)})()
    prepared, _, _, mm = _fine_case(truth)
    kw = {"style": "auto", "mm_per_px": mm, "base_mm": BASE, "relief_mm": RELIEF, "layer_mm": 0.12}
    assert prepared.finer(1001).shape[1] >= 2 * prepared.image.shape[1]  # the fine grid is looked at
    with_fine = make_relief(prepared.image, fine=prepared.finer, **kw)
    without = make_relief(prepared.image, **kw)
    assert (with_fine.style, with_fine.reason) == (without.style, without.reason)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("spacing_px", [6, 9, 12])
def test_the_print_width_at_which_merged_lines_separate_opens_their_gap_to_a_fingers_width(spacing_px):
    """A grid of lines spacing_px apart: scaled by separate_at, the gap between drawn lines
    (centre distance minus the drawn width) reaches MIN_GAP_MM, to within a grid pixel."""
    from tamp_os.relief.lines import LINE_WIDTH_MM, MIN_GAP_MM, network_of

    mm = 0.4
    skeleton = np.zeros((10 * spacing_px + 1, 13 * spacing_px + 1), bool)  # whole cells, closed at the border
    skeleton[::spacing_px] = True
    skeleton[:, ::spacing_px] = True
    lines = network_of(skeleton, pitch_mm=mm, min_area_mm2=6.0, strength=50.0)
    centre_mm = spacing_px * mm
    if centre_mm - LINE_WIDTH_MM >= MIN_GAP_MM:
        assert lines.separate_at == 1.0 and not lines.merged.any()
    else:
        assert lines.merged.any()
        assert abs(lines.separate_at * centre_mm - LINE_WIDTH_MM - MIN_GAP_MM) <= 2 * mm


@pytest.mark.timeout(180)
@pytest.mark.parametrize("width_mm", [60, 100, 150])
def test_needle_on_a_noisy_ground_is_one_plateau_not_grains(fixture, width_mm):
    """The TIA needle (fixtures README: one object, a single raised or sunk region): the shot noise
    of its empty ground is no grain structure, so the ground stays flat and the needle is one
    plateau (it was three plateaus of equalised noise, with the needle at the base)."""
    need_module("rsciio")
    from tamp_os.lithograph.pipeline import make_lithograph

    litho = make_lithograph(fixture("real/tia_talos_tem_search.emi"), width_mm=width_mm)
    assert litho.report.content_kind == "plateau"
    h = litho.heightmap
    raised = h > h.min() + 1.0
    labels, n = ndimage.label(raised)
    assert n == 1
    pitch = litho.report.mm_per_px
    far = ~ndimage.binary_dilation(raised, iterations=int(np.ceil(2.0 / pitch)))
    assert np.ptp(h[far]) <= 0.3  # the ground 2 mm away from the needle is one height
    assert raised[:, 0].any() and not raised[:, -1].any()  # it enters from the left, its tip short of the right edge


@pytest.mark.timeout(120)
def test_one_grey_step_is_one_plateau_and_one_flat_band(fixture):
    """The JEOL dummy (fixtures README): rows 0-190 one grey, rows 191-255 black: one plateau and
    one flat band, not 'grains in 3 levels'."""
    need_module("rsciio")
    from tamp_os.lithograph.pipeline import make_lithograph

    litho = make_lithograph(fixture("real/jeol_dummy_bf.img"), width_mm=100)
    h = litho.heightmap
    assert litho.report.content_kind == "plateau"
    rows = h.shape[0]
    top, bottom = h[: int(0.70 * rows)], h[int(0.78 * rows):]  # away from the step at row 191 of 256
    assert np.ptp(top) <= 0.05 and np.ptp(bottom) <= 0.05 and abs(float(top.mean() - bottom.mean())) >= 2.0


@pytest.mark.timeout(120)
def test_faint_grains_are_still_grains_at_several_widths():
    from tamp_os.lithograph.pipeline import make_lithograph

    for width_mm in (60, 150):
        litho = make_lithograph(faint_grains().image, width_mm=width_mm)
        assert litho.report.content_kind == "grains", width_mm


def test_members_are_domes_not_pins():
    """A member a grid point or two wide is not raised the full relief (a 0.4 mm wide, 3 mm tall
    pin prints badly and pricks): its dome stands at most twice its inscribed radius; a wide
    member keeps the full lift."""
    from tamp_os.relief.content import PIN_ASPECT
    from tamp_os.relief.objects import dome_profile

    pitch, relief = 0.4, 3.0
    labels = np.zeros((60, 60), np.int32)
    labels[10:13, 10:14] = 1  # 3 x 4 points (1.2 x 1.6 mm): a sliver with one interior row
    yy, xx = np.mgrid[:60, :60]
    labels[(yy - 35) ** 2 + (xx - 35) ** 2 <= 12 ** 2] = 2  # 9.6 mm across
    domes = dome_profile(labels, pitch_mm=pitch, round_mm=10.0, pin_aspect=PIN_ASPECT, relief_mm=relief)  # as the content style asks
    sliver_mm = float(domes[labels == 1].max()) * relief
    # its half-width, 1.5 points, and half a point for the outline the distance counts: 0.8 mm
    assert 0 < sliver_mm <= PIN_ASPECT * (1.5 + 0.5) * pitch + 1e-6 and sliver_mm < relief / 1.5
    assert float(domes[labels == 2].max()) == pytest.approx(1.0)


@pytest.mark.timeout(120)
def test_a_polished_alloy_prints_its_grains_on_a_specimen_plateau_despite_its_inclusions():
    """Issue 32, class 3: weak channelling contrast (20 grey levels) inside a specimen on a dark
    mount, with carbides and twin lines spanning the range: not one blank raised square, but the
    specimen above the mount with its grains at distinct heights, each grain mostly one height."""
    from synthetic_content import polished_alloy
    from tamp_os.lithograph.pipeline import make_lithograph

    t = polished_alloy()
    litho = make_lithograph(t.image, width_mm=100, scale_bar="off")
    h = litho.heightmap
    rows, cols = h.shape
    grains = t.grains[np.linspace(0, t.grains.shape[0] - 1, rows).round().astype(int)][:, np.linspace(0, t.grains.shape[1] - 1, cols).round().astype(int)]
    specimen = grains > 0
    assert litho.report.content_kind == "grains", litho.report.relief_reason
    assert np.median(h[~specimen]) <= litho.params.base_mm + 0.05  # the mount at the base
    heights, counts = np.unique(np.round(h[ndimage.binary_erosion(specimen, iterations=3)], 1), return_counts=True)
    distinct = heights[counts > 0.1 * counts.sum()]
    assert len(distinct) >= 2 and np.ptp(distinct) >= 0.9, (heights, counts)  # grains a step apart, not one plateau
    shares = []
    for k in range(1, int(grains.max()) + 1):
        v = np.round(h[grains == k], 1)
        if v.size >= 30:
            shares.append(np.unique(v, return_counts=True)[1].max() / v.size)
    assert np.mean(shares) >= 0.7, np.mean(shares)  # a grain is mostly one height: noise does not crack it


@pytest.mark.timeout(120)
def test_a_band_of_close_lines_is_said_only_when_it_fills_a_share_worth_acting_on(monkeypatch):
    """Issue 33.9: "the space between them (0% of the picture) was filled" is no warning; a fill of a
    clear share still is, with the width that would part the lines."""
    from types import SimpleNamespace

    import tamp_os.relief.content as content

    lines = np.zeros((100, 100), bool)
    lines[50, :] = True
    monkeypatch.setattr(content, "draw_lines", lambda found, pitch: lines.astype(np.float32))

    def notes(merged_share):
        merged = np.zeros((100, 100), bool)
        merged.flat[: int(merged_share * merged.size)] = True
        found = SimpleNamespace(merged=merged, separate_at=1.8, cell_count=2, length_mm=40.0, strength=9.0, skeleton=lines)
        return content._as_lines(found, 0.4, 3.0, 100.0, content.Polarity(True, 0.1, "dark ground"), "", "lines").notes

    assert notes(0.004) == ()
    said = notes(0.06)
    assert len(said) == 1 and "(6% of the picture) was filled" in said[0] and "about 180 mm" in said[0]


@pytest.mark.timeout(60)
def test_dark_membranes_on_a_grey_textured_ground_are_raised_lines_not_grooves():
    """Issue 53 class 2: a Voronoi cell network of dark 0.5 mm lines on a mid-grey, grainy ground
    (no empty paper, so neither the strength nor the line-art rule fires): the lines stand at
    least 0.5 mm over the cell interiors, which stay at the base."""
    truth = membranes_on_grey()
    made = content(truth.image)
    mm, h = pitch(truth.image), made.heights_mm
    interiors = ndimage.distance_transform_edt(~truth.lines) * mm > 1.0
    assert made.content_kind == "lines", made.reason
    assert np.median(h[truth.lines]) - np.median(h[interiors]) >= 0.5
    assert np.median(h[interiors]) <= BASE + 0.05
    assert "dark lines" in made.reason and "textured ground" in made.reason


@pytest.mark.timeout(60)
def test_bright_lumps_as_wide_as_the_gaps_between_them_are_lumps_not_a_network():
    """The converse: bright lumps 2.7 mm across, gaps as wide, on a mid-grey ground are members
    (domes), not a network of twigs; neither side's lines pass as a textured network."""
    from tamp_os.relief.content import _Finder, _is_textured_network
    from tamp_os.relief.lines import textured_lines
    from tamp_os.relief.styles import WORK_MAX_POINTS, WorkGrid

    truth = lumps_as_wide_as_gaps()
    made = content(truth.image)
    assert made.content_kind == "members", made.reason
    felt = tops_over_rings(made.heights_mm, truth.members, pitch(truth.image)) >= 0.5
    assert felt.mean() >= 0.9
    image = prep(truth.image)
    grid = WorkGrid.plan(image.shape, pitch(truth.image), 0.4, max_points=WORK_MAX_POINTS)
    finder = _Finder(grid.down(image), grid.pitch_mm, 6.0)
    for response in finder.ridges():
        lines, widths = textured_lines(response, pitch_mm=grid.pitch_mm, min_area_mm2=6.0)
        assert not _is_textured_network(lines, widths), widths
