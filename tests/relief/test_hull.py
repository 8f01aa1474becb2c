"""Object hulls (relief/hull.py) against scikit-image's convex_hull_image, pixel for pixel."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage
from skimage.morphology import convex_hull_image

from tamp_os.relief.hull import convex_hull_mask, hull_pixels, labelled_hulls, solid_enough
from conftest import examples


@pytest.mark.timeout(120)
@settings(max_examples=examples(400), deadline=None)
@given(mask=arrays(bool, st.tuples(st.integers(1, 40), st.integers(1, 40))), opened=st.booleans())
def test_same_pixels_as_scikit_image(mask, opened):
    if opened:
        mask = ndimage.binary_opening(mask)
    if not mask.any():
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scikit-image warns for degenerate hulls it then still draws
        expected = convex_hull_image(mask)
    got = convex_hull_mask(mask)
    assert got.shape == mask.shape and np.array_equal(got, expected)
    assert not (mask & ~got).any()  # the hull holds the object


@pytest.mark.timeout(60)
def test_solidity_of_known_shapes():
    labels = np.zeros((40, 60), np.int32)
    labels[5:15, 5:25] = 1  # a rectangle: solidity 1
    labels[20:35, 30:45] = 2
    labels[20:32, 33:42] = 0  # an upside-down U: 15x15 box less a 12x9 notch open at the top
    labels[30:33, 10:13] = 3  # not asked for
    which = np.array([False, True, True, False])
    got = {k: (box, hull, solidity) for k, box, hull, solidity in labelled_hulls(labels, which)}
    assert set(got) == {1, 2}
    assert got[1][2] == 1.0 and got[1][1].all() and got[1][0] == (slice(5, 15), slice(5, 25))
    assert got[2][2] == pytest.approx((15 * 15 - 12 * 9) / 225)


@pytest.mark.timeout(60)
def test_solid_enough_drops_only_concave_candidates():
    labels = np.zeros((40, 60), np.int32)
    labels[5:15, 5:25] = 1  # rectangle, solidity 1
    labels[20:35, 30:45] = 2
    labels[20:32, 33:42] = 0  # upside-down U, solidity 117 / 225 = 0.52
    labels[30:33, 10:13] = 3  # a square that is not a candidate
    candidates = np.array([False, True, True, False])
    assert solid_enough(labels, candidates, 0.7).tolist() == [False, True, False, False]
    assert solid_enough(labels, candidates, 0.5).tolist() == [False, True, True, False]


@pytest.mark.timeout(120)
@settings(max_examples=examples(200), deadline=None)
@given(mask=arrays(bool, st.tuples(st.integers(1, 50), st.integers(1, 50))), opened=st.booleans(), fold=st.integers(0, 3),
       seed=st.integers(0, 2**16))
def test_hull_pixels_of_all_labels_at_once_are_each_hulls(mask, opened, fold, seed):
    # Labels of any shape, some in several pieces (fold), some not asked for.
    if opened:
        mask = ndimage.binary_opening(mask)
    labels, n = ndimage.label(mask)
    if fold:
        labels = np.where(labels > 0, labels % (fold + 1) + 1, 0)
        n = int(labels.max())
    which = np.zeros(n + 2, bool)  # one label more than present: it has no pixels
    which[1:] = np.random.default_rng(seed).random(n + 1) < 0.8
    got = hull_pixels(labels, which)
    boxes = ndimage.find_objects(labels, max_label=n + 1)
    for k in range(n + 2):
        asked = k > 0 and which[k] and boxes[k - 1] is not None
        assert got[k] == (convex_hull_mask(labels[boxes[k - 1]] == k).sum() if asked else 0)


@pytest.mark.timeout(60)
def test_a_candidate_without_pixels_stays_a_candidate():
    labels = np.zeros((10, 10), np.int32)
    labels[2:5, 2:5] = 1
    assert solid_enough(labels, np.array([False, True, True]), 0.7).tolist() == [False, True, True]
