"""A dense field of small members told from texture (dense.py), and raised so that its members are felt.

Synthetic particle fields (touching domes of one size, each a little brighter or dimmer) and
band-limited Gaussian textures whose speckle has the same size are drawn on a 1000 × 600 source
and prepared as the pipeline prepares them at Medium (250 px across 100 mm, blur 1.2 px).
"""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from tamp_os.relief.dense import blob_scale, neighbourhood_max
from tamp_os.relief.preprocess import prepare
from tamp_os.relief.styles import make_relief
from conftest import examples

BASE, RELIEF = 1.0, 3.0
SRC = (600, 1000)


def _prepared(image, labels=None, cols=250):
    rows = round((SRC[0] - 1) * (cols - 1) / (SRC[1] - 1)) + 1
    out = prepare(image.astype(np.float32), None, rows=rows, cols=cols, target_aspect=(rows - 1) / (cols - 1), fit="stretch",
                  low_pct=2, high_pct=98, sigma_px=1.2, invert=False, flip_x=False).image
    if labels is None:
        return out, None
    zoom = (rows / SRC[0], cols / SRC[1])
    return out, ndimage.zoom(labels, zoom, order=0, grid_mode=True, mode="grid-constant")[:rows, :cols]


def particle_field(seed, radius_px):
    """Touching domes (radius ±10 %, brightness ±8 %) packed at random over a dark ground, with
    noise; (prepared picture, labels of the particles on the same grid)."""
    rng = np.random.default_rng(seed)
    image = np.full(SRC, 0.15, np.float32)
    labels = np.zeros(SRC, np.int32)
    reach = int(radius_px * 1.1) + 1
    yy, xx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    d = np.hypot(yy, xx)
    taken = np.zeros(SRC, bool)
    count = 0
    for _ in range(20000):
        y, x = int(rng.integers(reach, SRC[0] - reach)), int(rng.integers(reach, SRC[1] - reach))
        box = (slice(y - reach, y + reach + 1), slice(x - reach, x + reach + 1))
        r = radius_px * rng.uniform(0.9, 1.1)
        if (taken[box] & (d <= 0.95 * r)).any():
            continue
        count += 1
        dome = 0.15 + 0.75 * rng.normal(1.0, 0.08) * np.sqrt(np.clip(1 - (d / r) ** 2, 0, 1))
        np.maximum(image[box], dome, out=image[box])
        labels[box][(d <= 0.8 * r) & (labels[box] == 0)] = count
        taken[box] |= d <= r
    image += 0.04 * rng.standard_normal(SRC).astype(np.float32)
    return _prepared(image, labels)


def gaussian_texture(seed, speckle_px):
    """White noise smoothed to speckle of `speckle_px` (a Gaussian random field), with fine noise."""
    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.standard_normal(SRC), speckle_px)
    field += 0.1 * field.std() * rng.standard_normal(SRC)
    return _prepared(field)[0]


def felt_share(heights, labels, mm_per_px, ring_mm=1.5):
    """Share of members whose top (95th percentile) stands >= 0.5 mm over the median of a ring
    ring_mm wide around it (ring pixels go to their nearest member), as the benchmark measures."""
    n = int(labels.max())
    mask = labels > 0
    dist, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    owner = np.where(~mask & (dist * mm_per_px <= ring_mm), labels[iy, ix], 0)
    index = np.arange(1, n + 1)
    present = np.bincount(labels.ravel(), minlength=n + 1)[1:] > 0
    top = np.asarray(ndimage.labeled_comprehension(heights, labels, index, lambda v: np.percentile(v, 95), float, np.nan))
    ring = np.asarray(ndimage.median(heights, owner, index), dtype=np.float64)
    ok = present & np.isfinite(top) & np.isfinite(ring)
    return float(np.mean((top - ring)[ok] >= 0.5))


@pytest.mark.timeout(300)
@settings(max_examples=examples(4), deadline=None)
@given(seed=st.integers(0, 2**16), radius_px=st.floats(10.5, 13.0))
@example(seed=432, radius_px=12.5)  # the population path parts half of them; its reason names the other side's dense field
def test_a_dense_particle_field_is_found_and_nine_in_ten_members_are_felt(seed, radius_px):
    """Particles 2.1-2.6 mm across on the print, hundreds of them touching: the blobs are a dense
    field, auto takes the content style, and >= 90 % of them stand 0.5 mm over the ring around them.
    (Finer fields fade towards a symmetric texture on the Medium grid: at 1.8 mm the asymmetry is
    1.14-1.15, at the threshold.)"""
    image, labels = particle_field(seed, radius_px)
    mm = 100.0 / (image.shape[1] - 1)
    blobs = blob_scale(image, mm)
    assert blobs is not None and blobs.dense, blobs
    made = make_relief(image, style="auto", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF, layer_mm=0.12)
    # (Where the local-contrast segmentation parts enough of them, the population path takes it first.)
    assert made.style == "content" and made.object_count > 0
    assert felt_share(made.heights_mm, labels, mm) >= 0.9
    # Drawn as a dense field, the check counts the domes a finger finds: of the order of the particles
    # drawn. (Not when the population path parted them: its reason may say "dense field" of the other
    # side's blobs only to explain the polarity, as hypothesis found for seed 432.)
    if "content: a dense field of small members" in made.reason:
        assert 0.5 * labels.max() <= made.object_count <= 1.5 * labels.max()


@pytest.mark.timeout(300)
@settings(max_examples=examples(6), deadline=None)
@given(seed=st.integers(0, 2**16), speckle_px=st.floats(4.0, 9.0))
def test_a_gaussian_texture_of_one_speckle_size_is_not_a_dense_field(seed, speckle_px):
    """A random texture whose speckle has one size (as noisy TEM) gathers its blobs at one scale
    too, but its troughs are as deep as its peaks are high: not a dense field, and auto does not
    raise it as one."""
    image = gaussian_texture(seed, speckle_px)
    mm = 100.0 / (image.shape[1] - 1)
    blobs = blob_scale(image, mm)
    assert blobs is not None and not blobs.dense and blobs.asymmetry < 1.1, blobs.words()
    made = make_relief(image, style="auto", mm_per_px=mm, base_mm=BASE, relief_mm=RELIEF)
    assert "dense field" not in made.reason


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ["test_STEM_image.dm3", "test_loading_image_saved_with_imageJ.tif"])
def test_texture_fixtures_are_no_dense_field_at_any_width(fixture, name):
    """The noisy STEM texture and the ImageJ picture, printed 60-150 mm wide."""
    from tamp_os.lithograph.pipeline import make_lithograph

    for width_mm in (60, 80, 100, 120, 150):
        litho = make_lithograph(fixture(name), width_mm=width_mm, mesher="grid", scale_bar="off", channels="off", relief_style="reference")
        image = ((litho.heightmap - litho.params.base_mm) / litho.params.relief_mm).astype(np.float32)
        made = make_relief(image, style="auto", mm_per_px=litho.layout.mm_per_px, base_mm=BASE, relief_mm=RELIEF,
                           uniform=litho.report.uniform)
        assert "dense field" not in made.reason, (width_mm, made.reason)


@pytest.mark.timeout(60)
@settings(max_examples=examples(40), deadline=None)
@given(shape=st.tuples(st.integers(1, 4), st.integers(1, 9), st.integers(1, 9)), levels=st.integers(1, 5), seed=st.integers(0, 2**16))
def test_neighbourhood_max_is_scipys_3x3x3_maximum_with_nothing_beyond_the_edges(shape, levels, seed):
    """The same numbers as ndimage.maximum_filter (size 3, -inf outside) in 3-D and, in 2-D, as its
    default 'reflect' mode and as minus the minimum filter of minus the picture; few levels make ties."""
    values = np.random.default_rng(seed).integers(-levels, levels + 1, size=shape).astype(np.float32) / 3
    assert np.array_equal(neighbourhood_max(values), ndimage.maximum_filter(values, size=3, mode="constant", cval=-np.inf))
    plane = values[0]
    assert np.array_equal(neighbourhood_max(plane), ndimage.maximum_filter(plane, 3))
    assert np.array_equal(-neighbourhood_max(-plane), ndimage.minimum_filter(plane, 3))
