"""relief/population.py's shortcuts give what the plain way gives, pixel for pixel."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from tamp_os.relief import population

pytestmark = pytest.mark.timeout(120)


def _members_with_holes(rows, cols, n, seed):
    """Touching square-ish members with holes of every size, some holes on a border between two."""
    rng = np.random.default_rng(seed)
    labels = np.zeros((rows, cols), np.int32)
    for k in range(1, n + 1):
        r, c = rng.integers(0, rows), rng.integers(0, cols)
        h, w = rng.integers(3, 15, 2)
        labels[r:r + h, c:c + w] = k
    labels[rng.random((rows, cols)) < rng.choice([0.02, 0.1, 0.3])] = 0  # holes of one pixel and more
    return labels


def _plain_filled(labels):
    # What _filled did before: holes by a fill of the mask, each hole's nearest members in its box.
    holes, n = ndimage.label(ndimage.binary_fill_holes(labels > 0) & (labels == 0))
    out = labels.copy()
    area = np.bincount(labels.ravel(), minlength=int(labels.max()) + 1)
    for k, box in enumerate(ndimage.find_objects(holes), 1):
        box = tuple(slice(max(0, b.start - 1), b.stop + 1) for b in box)
        window = labels[box]
        _, (iy, ix) = ndimage.distance_transform_edt(window == 0, return_indices=True)
        hole = holes[box] == k
        nearest = window[iy[hole], ix[hole]]
        if hole.sum() <= area[nearest[-1]]:
            out[box][hole] = nearest
    return out


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(3, 60), cols=st.integers(3, 60), n=st.integers(0, 25), seed=st.integers(0, 2**16))
def test_holes_are_filled_as_the_plain_way_fills_them(rows, cols, n, seed):
    labels = _members_with_holes(rows, cols, n, seed)
    np.testing.assert_array_equal(population._filled(labels), _plain_filled(labels))


def test_a_ring_around_a_wide_hole_keeps_its_hole_and_a_pinhole_is_filled():
    labels = np.zeros((40, 40), np.int32)
    labels[5:35, 5:35] = 1
    labels[7:33, 7:33] = 0  # a thin ring: its hole is larger than the ring
    labels[36:39, 36:39] = 2
    labels[37, 37] = 0  # a pinhole in a small member
    out = population._filled(labels)
    assert (out[7:33, 7:33] == 0).all() and out[37, 37] == 2


def _plain_object_width_mm(image, labels, pitch_mm):
    # What object_width_mm did before: the distance transform of the whole picture.
    from skimage import filters

    from tamp_os.relief.hull import solid_enough
    from tamp_os.relief.objects import label_max

    if labels.max() == 0 or float(np.ptp(image)) <= 0:
        return 0.0
    objects, n = ndimage.label(image > filters.threshold_otsu(image))
    held = np.zeros(n + 1, bool)
    held[objects[labels > 0]] = True
    held[0] = False
    held &= np.bincount(objects.ravel(), minlength=n + 1) <= population.MAX_MEMBER_SHARE * objects.size
    held = solid_enough(objects, held, population.MIN_SOLIDITY)
    if not held.any():
        return 0.0
    radius = label_max(ndimage.distance_transform_edt(objects > 0), objects, n)
    return float(np.median(2.0 * radius[np.flatnonzero(held)] * pitch_mm))


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(8, 70), cols=st.integers(8, 70), n=st.integers(1, 12), seed=st.integers(0, 2**16))
def test_object_width_is_the_whole_pictures_distance_transform(rows, cols, n, seed):
    # Discs of many sizes, some cut by the picture's border, members in some of them.
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:rows, :cols]
    image = rng.random((rows, cols)) * 0.2
    for _ in range(n):
        cy, cx, r = rng.integers(-5, rows + 5), rng.integers(-5, cols + 5), rng.integers(2, 20)
        image[(yy - cy) ** 2 + (xx - cx) ** 2 < r * r] += 0.8
    labels = np.where(rng.random((rows, cols)) < 0.05, rng.integers(1, 4, (rows, cols)), 0)
    assert population.object_width_mm(image, labels, 0.4) == _plain_object_width_mm(image, labels, 0.4)


@settings(max_examples=100, deadline=None)
@given(n=st.integers(0, 60), pairs=st.integers(0, 80), seed=st.integers(0, 2**16))
def test_joined_roots_are_each_groups_smallest_label(n, pairs, seed):
    rng = np.random.default_rng(seed)
    xs, ys = rng.integers(0, n + 1, pairs), rng.integers(0, n + 1, pairs)
    got = population.joined_roots(n, xs.tolist(), ys.tolist())
    # The groups: connected components of the pairs' graph, found by flooding.
    expected = np.arange(n + 1)
    changed = True
    while changed:
        changed = False
        for x, y in zip(xs, ys):
            low = min(expected[x], expected[y])
            if expected[x] != low or expected[y] != low:
                expected[x] = expected[y] = low
                changed = True
    np.testing.assert_array_equal(got, expected)


def _plain_largest_parts(labels):
    # What _largest_parts did before: a loop over the parts from the largest.
    parts, n = ndimage.label(labels > 0, structure=np.ones((3, 3)))
    if n == 0:
        return labels
    owner = np.zeros(n + 1, np.int64)
    owner[parts.ravel()] = labels.ravel()
    size = np.bincount(parts.ravel(), minlength=n + 1)
    size[0] = 0
    best = np.zeros(int(labels.max()) + 1, np.int64)
    for part in np.argsort(size)[::-1]:
        if part != 0 and size[part] != 0 and best[owner[part]] == 0:
            best[owner[part]] = part
    keep = np.zeros(n + 1, bool)
    keep[best[best > 0]] = True
    return np.where(keep[parts], labels, 0)


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(1, 40), cols=st.integers(1, 40), n=st.integers(1, 8), share=st.floats(0.05, 0.9),
       seed=st.integers(0, 2**16))
def test_largest_parts_keep_what_the_loop_kept(rows, cols, n, share, seed):
    # Crumbs of equal sizes (ties), labels split into several parts, parts holding two labels.
    rng = np.random.default_rng(seed)
    labels = np.where(rng.random((rows, cols)) < share, rng.integers(1, n + 1, (rows, cols)), 0).astype(np.int32)
    np.testing.assert_array_equal(population._largest_parts(labels), _plain_largest_parts(labels))
