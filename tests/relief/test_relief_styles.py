"""Relief styles on synthetic pictures with known ground truth (3 mm relief, 100 mm wide)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage
from skimage import measure

from synthetic import particles_on_texture, sem_spheres, tem_texture
from tamp_os.errors import ParameterError
from tamp_os.relief.legibility import assess
from tamp_os.relief.preprocess import prepare
from tamp_os.relief.styles import STYLES, StyleOptions, make_relief
from conftest import examples

RELIEF, BASE = 3.0, 1.0


def prep(image, invert=False, sigma_px=1.2):
    """The pipeline's preparation, with the picture already at grid size."""
    rows, cols = image.shape
    return prepare(
        image, None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
        low_pct=2.0, high_pct=98.0, sigma_px=sigma_px, invert=invert, flip_x=False,
    ).image


def pitch(image, width_mm=100.0):
    return width_mm / (image.shape[1] - 1)


def relief(image, style, **kw):
    return make_relief(prep(image), style=style, mm_per_px=pitch(image), base_mm=BASE, relief_mm=RELIEF, **kw)


def lift(heights, mask, mm_per_px):
    return assess(heights, mm_per_px, objects=mask).lowest_lift_mm


@pytest.mark.timeout(60)
def test_reference_reproduces_the_pipeline_bit_for_bit(gradient_image):
    from tamp_os.lithograph.pipeline import make_lithograph

    for quantize in (False, True):
        litho = make_lithograph(gradient_image, width_mm=60, quantize=quantize, mesher="grid", relief_style="reference")
        lay = litho.layout
        image = prepare(
            gradient_image.astype(np.float32), None, rows=lay.rows, cols=lay.cols, target_aspect=lay.target_aspect,
            fit=lay.fit, low_pct=2.0, high_pct=98.0, sigma_px=lay.blur_px, invert=False, flip_x=False,
        ).image
        made = make_relief(
            image, style="reference", mm_per_px=lay.mm_per_px, base_mm=litho.params.base_mm,
            relief_mm=litho.params.relief_mm, layer_mm=litho.report.layer_mm if quantize else None,
        )
        assert made.heights_mm.dtype == litho.heightmap.dtype
        assert np.array_equal(made.heights_mm, litho.heightmap)


@pytest.mark.timeout(60)
def test_sem_spheres_rise_in_structure_and_objects_but_not_in_reference():
    syn = sem_spheres()
    mm = pitch(syn.image)
    assert lift(relief(syn.image, "reference").heights_mm, syn.objects, mm) < 1.0
    for style in ("structure", "objects"):
        made = relief(syn.image, style)
        assert lift(made.heights_mm, syn.objects, mm) >= 1.0, style


@pytest.mark.timeout(60)
def test_objects_fills_rims_and_keeps_shadows_out_of_the_ground():
    syn = sem_spheres()
    made = relief(syn.image, "objects")
    truth, _ = ndimage.label(syn.objects)
    assert made.object_count == truth.max() == 4
    for k in range(1, 5):  # each sphere is filled, not a ring (a rim band would cover < 40 %)
        sphere = truth == k
        assert (made.objects[sphere] > 0).mean() > 0.8
    assert ((made.objects > 0) & ~syn.objects).sum() < 0.15 * syn.objects.sum()
    ground = ~ndimage.binary_dilation(syn.objects, iterations=4)
    g = made.heights_mm[ground]
    # A flat, lightly textured ground: shadows are not trenches.
    assert np.percentile(g, 99) - np.percentile(g, 1) <= StyleOptions().texture_mm + 1e-9
    assert made.heights_mm[syn.objects].max() > BASE + 0.9 * RELIEF


@pytest.mark.timeout(60)
def test_structure_leaves_little_fine_texture_and_keeps_the_shape():
    """Noisy texture: <= 10 % of the variance finer than sigma = 1 mm. 'Not flattened' means the
    heights still span >= 60 % of the relief (1st-99th percentile) and follow the clean grains
    under the noise (correlation >= 0.7) better than the reference does."""
    syn = tem_texture()
    mm = pitch(syn.image)
    ref = relief(syn.image, "reference").heights_mm
    made = relief(syn.image, "structure").heights_mm
    report = assess(made, mm)
    assert report.fine_share <= 0.10 < assess(ref, mm).fine_share
    assert report.relief_span_mm >= 0.6 * RELIEF
    clean = syn.clean.ravel()
    r_made = np.corrcoef(made.ravel(), clean)[0, 1]
    assert r_made >= 0.7 and r_made > np.corrcoef(ref.ravel(), clean)[0, 1]


def _regions(heights):
    return measure.label(np.round(heights, 6) * 1e6, background=-1, connectivity=1)


@pytest.mark.slow
@pytest.mark.timeout(120)
@settings(max_examples=examples(8), deadline=None)
@given(count=st.integers(2, 5), seed=st.integers(0, 50), which=st.sampled_from(["tem", "particles"]))
def test_levels_gives_exact_plateaus_big_enough_to_feel(count, seed, which):
    maker = tem_texture if which == "tem" else particles_on_texture
    syn = maker(96, 128, seed=seed)
    mm = pitch(syn.image, 60.0)
    opts = StyleOptions(level_count=count)
    made = make_relief(prep(syn.image), style="levels", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF, options=opts)
    heights = np.unique(made.heights_mm)
    assert len(heights) == len(made.levels_mm) >= 2
    # A level whose regions are all under a fingertip is merged away, and the notes say so (with the
    # objects found in the picture's own terms, 2 of 51 particle pictures at 60 mm lose one level).
    assert len(heights) == count or f"only {len(heights)} of {count} levels" in " ".join(made.notes)
    assert np.diff(heights).min() >= 0.5
    regions = _regions(made.heights_mm)
    assert np.bincount(regions.ravel())[1:].min() * mm**2 >= opts.min_area_mm2
    # Outlines smooth at nozzle scale: hardly anything narrower than two nozzle widths.
    assert assess(made.heights_mm, mm).narrow_share < 0.05


@pytest.mark.timeout(60)
def test_levels_with_a_low_relief_uses_fewer_levels_and_says_so():
    syn = tem_texture(96, 128)
    made = make_relief(prep(syn.image), style="levels", mm_per_px=0.5, base_mm=1, relief_mm=1.0, options=StyleOptions(level_count=5))
    assert len(np.unique(made.heights_mm)) == 3 and any("level_count" in n for n in made.notes)


@pytest.mark.timeout(60)
def test_auto_picks_and_says_why():
    # SEM spheres: a population, so auto picks the content translation (issue 26), which
    # raises the four spheres the edge finder outlines.
    sem = relief(sem_spheres().image, "auto")
    assert sem.style == "content" and sem.reason.startswith("auto chose content (a population")
    assert "4 objects outlined by edges" in sem.reason and sem.object_count == 4
    tem = relief(tem_texture().image, "auto")
    assert tem.style == "structure" and tem.reason.startswith("auto chose structure")


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name, chosen", [("camera", "levels"), ("cell", "structure"), ("immunohistochemistry", "structure"), ("retina", "structure"), ("coins", "content")])
def test_auto_on_pictures_says_the_facts_it_chose_by(name, chosen):
    """A portrait is not a population of particles; stained tissue, a fundus and a cell are
    continuous tones; the coins are a population (each raised by the same lift). The reason
    names measured figures."""
    import skimage.data

    image, mm, uniform = prepared(np.asarray(getattr(skimage.data, name)()))
    made = make_relief(image, style="auto", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF, uniform=uniform)
    assert made.style == chosen and made.reason.startswith(f"auto chose {chosen}")
    assert ("%" in made.reason or chosen == "content") and any(ch.isdigit() for ch in made.reason)


@pytest.mark.timeout(60)
def test_auto_picks_levels_for_a_terrace():
    """Three flat, noisy terraces of distinct brightness: the levels hold the picture."""
    rng = np.random.default_rng(3)
    image = np.full((188, 250), 0.2, np.float32)
    image[:, 90:170] = 0.5
    image[40:150, 170:] = 0.85
    image += 0.03 * rng.standard_normal(image.shape).astype(np.float32)
    made = relief(np.clip(image, 0, 1), "auto")
    assert made.style == "levels" and "3 distinct brightness levels" in made.reason


@pytest.mark.timeout(60)
@pytest.mark.parametrize("style", STYLES)
def test_every_style_follows_invert_and_stays_in_bounds(style):
    syn = particles_on_texture(96, 128)
    mm = pitch(syn.image, 60.0)
    made = {inv: make_relief(prep(syn.image, invert=inv), style=style, mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF).heights_mm for inv in (False, True)}
    for h in made.values():
        assert h.min() >= BASE - 1e-9 and h.max() <= BASE + RELIEF + 1e-9 and np.isfinite(h).all()
    assert not np.array_equal(made[False], made[True])
    if style in ("reference", "structure"):  # brightness-led styles turn over with invert
        assert np.corrcoef(made[False].ravel(), made[True].ravel())[0, 1] < 0


@pytest.mark.timeout(60)
@pytest.mark.parametrize("style", STYLES)
def test_uniform_picture_is_a_flat_plate_in_every_style(style):
    image = np.zeros((40, 50), np.float32)
    made = make_relief(image, style=style, mm_per_px=1.0, base_mm=BASE, relief_mm=RELIEF, uniform=True)
    assert np.all(made.heights_mm == BASE)


@pytest.mark.timeout(60)
def test_fine_grids_are_worked_at_nozzle_scale_and_come_back_full_size():
    syn = sem_spheres(384, 512)
    mm = pitch(syn.image, 30.0)  # 0.06 mm pitch: the working grid is coarser
    made = make_relief(prep(syn.image, sigma_px=0), style="objects", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF)
    assert made.heights_mm.shape == syn.image.shape and made.objects.shape == syn.image.shape
    assert lift(made.heights_mm, syn.objects, mm) >= 1.0


@pytest.mark.timeout(30)
@pytest.mark.parametrize(
    "kwargs, name, shown",
    [
        (dict(style="bas-relief"), "relief_style", "'bas-relief'"),
        (dict(options=StyleOptions(detail_mm=0.2)), "detail_mm", "0.2"),
        (dict(options=StyleOptions(level_count=1)), "level_count", "1"),
        (dict(options=StyleOptions(level_count=6)), "level_count", "6"),
        (dict(options=StyleOptions(texture_mm=-1)), "texture_mm", "-1"),
    ],
)
def test_bad_values_name_parameter_range_and_value(kwargs, name, shown):
    args = dict(style="structure", mm_per_px=0.4, base_mm=1.0, relief_mm=3.0) | kwargs
    with pytest.raises(ParameterError) as err:
        make_relief(np.zeros((20, 20), np.float32), **args)
    text = str(err.value)
    assert text.startswith(f"{name}:") and shown in text and ("between" in text or "from" in text or "one of" in text)


def prepared(path):
    """The pipeline's prepared picture of a file at Medium (100 mm wide): the reference heights
    are base + relief × image01, so image01 comes back from them."""
    import dataclasses

    from tamp_os.params import LithoParams
    from tamp_os.lithograph.pipeline import make_lithograph

    fields = {f.name for f in dataclasses.fields(LithoParams)}
    style = {"relief_style": "reference"} if "relief_style" in fields else {}
    litho = make_lithograph(path, mesher="grid", scale_bar="off", channels="off", **style)  # the brightness picture
    image01 = (litho.heightmap - litho.params.base_mm) / litho.params.relief_mm
    return image01.astype(np.float32), litho.layout.mm_per_px, litho.report.uniform


# The four FePt spheres, measured by eye on the picture: centre (x, y) and radius as
# fractions of the picture's width.
FEPT_SPHERES = [(0.20, 0.38, 0.187), (0.567, 0.24, 0.173), (0.46, 0.63, 0.171), (0.807, 0.56, 0.187)]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("style", ["objects", "structure", "auto"])
def test_all_four_fept_spheres_rise(fixture, style):
    """Every sphere's inner half is one object of its own and stands >= 1 mm above the ground
    (the picture away from all four spheres), the top-middle one too."""
    image, mm, uniform = prepared(fixture("fept_spheres_sem.png"))
    made = make_relief(image, style=style, mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF, uniform=uniform)
    rows, cols = image.shape
    yy, xx = np.mgrid[0:rows, 0:cols] / (cols - 1)
    disks = [(xx - x) ** 2 + (yy - y * (rows - 1) / (cols - 1)) ** 2 for x, y, _ in FEPT_SPHERES]
    ground = np.all([d > (1.2 * r) ** 2 for d, (_, _, r) in zip(disks, FEPT_SPHERES)], axis=0)
    ground_mm = float(np.median(made.heights_mm[ground]))
    seen = set()
    for d, (_, _, r) in zip(disks, FEPT_SPHERES):
        inner = d <= (0.5 * r) ** 2
        assert np.median(made.heights_mm[inner]) - ground_mm >= 1.0
        labels = made.objects[inner]
        main = int(np.bincount(labels).argmax())
        assert main > 0 and (labels == main).mean() > 0.9 and main not in seen
        seen.add(main)
    assert made.object_count == 4


@pytest.mark.timeout(120)
@pytest.mark.parametrize("name", ["test_STEM_image.dm3", "test_loading_image_saved_with_imageJ.tif", "FEI-Helios-Ebeam-8bits.tif"])
def test_no_objects_in_fixtures_without_any(fixture, name):
    """Noisy STEM texture, a tiny ImageJ picture and a blank SEM frame hold no objects."""
    image, mm, uniform = prepared(fixture(name))
    assert make_relief(image, style="objects", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF, uniform=uniform).object_count == 0


@pytest.mark.timeout(60)
def test_no_objects_in_noisy_texture():
    assert relief(tem_texture().image, "objects").object_count == 0


def boundary_steps(heights, objects, mm_per_px, reach_mm=0.5):
    """Per known object: median height in the band up to reach_mm inside its outline minus the
    median in the band up to reach_mm outside it (so measured across at most ~1 mm)."""
    labels, count = ndimage.label(objects)
    inside = ndimage.distance_transform_edt(objects) * mm_per_px
    outside, (iy, ix) = ndimage.distance_transform_edt(~objects, return_indices=True)
    owner = labels[iy, ix]  # the object each ground pixel is nearest to
    steps = []
    for k in range(1, count + 1):
        inner = (labels == k) & (inside <= reach_mm + 0.5 * mm_per_px)
        outer = (labels == 0) & (owner == k) & (outside * mm_per_px <= reach_mm + 0.5 * mm_per_px)
        steps.append(float(np.median(heights[inner]) - np.median(heights[outer])))
    return np.array(steps)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("seed", [1])
def test_structure_keeps_particle_boundaries_as_steps(seed):
    """Across every particle's outline, within ~1 mm, the structure relief steps up >= 0.5 mm
    (a ramp spread over the fingertip scale would not), with a 3 mm relief."""
    syn = particles_on_texture(seed=seed)
    mm = pitch(syn.image)
    steps = boundary_steps(relief(syn.image, "structure").heights_mm, syn.objects, mm)
    assert len(steps) >= 10 and steps.min() >= 0.5, np.round(steps, 2)
