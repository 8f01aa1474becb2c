"""relief/objects.py's label helpers: the lookup-table renumbering and ranks are scikit-image's and NumPy's."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage
from skimage import segmentation

from tamp_os.relief.objects import dense_ranks, scipy_label_median, sequential_labels, sorted_by_label

pytestmark = pytest.mark.timeout(120)


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(1, 40), cols=st.integers(1, 40), top=st.integers(0, 5000), seed=st.integers(0, 2**16),
       dtype=st.sampled_from([np.int32, np.int64, np.uint16]))
def test_sequential_labels_are_relabel_sequentials(rows, cols, top, seed, dtype):
    rng = np.random.default_rng(seed)
    labels = np.where(rng.random((rows, cols)) < 0.4, 0, rng.integers(0, top + 1, (rows, cols))).astype(dtype)
    got = sequential_labels(labels)
    assert got.dtype == labels.dtype
    np.testing.assert_array_equal(got, segmentation.relabel_sequential(labels)[0])
    assert set(np.unique(got)) - {0} == set(range(1, len(set(np.unique(labels)) - {0}) + 1))


@settings(max_examples=60, deadline=None)
@given(size=st.integers(1, 3000), top=st.one_of(st.integers(0, 100), st.integers(10**6, 10**12)), seed=st.integers(0, 2**16))
def test_dense_ranks_are_uniques_inverse(size, top, seed):
    # Small keys take the lookup table, keys far larger than their count take np.unique.
    keys = np.random.default_rng(seed).integers(0, top + 1, (size // 30 + 1, 30)).astype(np.int64)
    expected = np.unique(keys, return_inverse=True)[1].reshape(keys.shape)
    np.testing.assert_array_equal(dense_ranks(keys), expected)


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(1, 30), cols=st.integers(1, 30), n=st.integers(1, 12), ground=st.floats(0.0, 1.0),
       seed=st.integers(0, 2**16), dtype=st.sampled_from([np.float32, np.float64, np.int32, np.uint8]))
def test_scipy_label_median_is_ndimage_median(rows, cols, n, ground, seed, dtype):
    # Labels 1..n with some empty, with or without ground pixels; ties among values.
    rng = np.random.default_rng(seed)
    labels = np.where(rng.random((rows, cols)) < ground, 0, rng.integers(1, n + 1, (rows, cols)))
    values = (rng.integers(0, 20, (rows, cols)) * (0.37 if np.issubdtype(dtype, np.floating) else 1)).astype(dtype)
    expected = np.asarray(ndimage.median(values, labels, np.arange(1, n + 1)))
    got = scipy_label_median(values, labels, n)
    assert got.dtype == expected.dtype
    np.testing.assert_array_equal(got, expected)


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(1, 30), cols=st.integers(1, 30), n=st.integers(1, 12), seed=st.integers(0, 2**16),
       dtype=st.sampled_from([np.float32, np.float64]), special=st.sampled_from(["none", "signed zeros", "nan", "inf"]))
def test_values_sorted_by_label_are_each_labels_sorted_values(rows, cols, n, seed, dtype, special):
    # float32 values take one sort of packed keys: negatives, infinities, ties, -0.0 and NaN included.
    rng = np.random.default_rng(seed)
    labels = np.where(rng.random((rows, cols)) < 0.3, 0, rng.integers(1, n + 1, (rows, cols)))
    values = (rng.integers(-20, 20, (rows, cols)) * 0.37).astype(dtype)
    extra = {"none": values, "signed zeros": -0.0, "nan": np.nan, "inf": -np.inf}[special]
    values = np.where(rng.random((rows, cols)) < 0.2, extra, values).astype(dtype)
    val, starts, counts = sorted_by_label(values, labels, n)
    assert val.dtype == values.dtype
    for k in range(1, n + 1):
        np.testing.assert_array_equal(val[starts[k - 1]:starts[k - 1] + counts[k - 1]], np.sort(values[labels == k]))


def test_inside_distance_is_remembered_for_the_same_labels_only():
    from tamp_os.relief.objects import InsideDistance, inner_outline

    labels = np.zeros((20, 30), np.int32)
    labels[2:12, 3:15], labels[5:18, 15:28] = 1, 2  # two touching members
    memo = InsideDistance()
    inside, dist = memo(labels)
    expected_inside = (labels > 0) & ~inner_outline(labels)
    np.testing.assert_array_equal(inside, expected_inside)
    np.testing.assert_array_equal(dist, ndimage.distance_transform_edt(expected_inside))
    assert memo(labels)[1] is dist  # the same labels: not computed again
    with pytest.raises(ValueError):
        dist[0, 0] = 1.0  # shared: read-only
    other = labels.copy()
    other[labels == 2] = 0  # another array (same values until changed): its own distances
    assert memo(other)[1] is not dist and memo(other)[0].sum() < inside.sum()


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(4, 50), cols=st.integers(4, 50), n=st.integers(2, 30), seed=st.integers(0, 2**16))
def test_inside_distance_after_a_join_is_the_joined_members_own(rows, cols, n, seed):
    # Touching members (nearest of n points, some ground), some of them joined; on the border too.
    from tamp_os.relief.objects import InsideDistance

    rng = np.random.default_rng(seed)
    points = np.zeros((rows, cols), np.int32)
    points[rng.integers(0, rows, n), rng.integers(0, cols, n)] = np.arange(1, n + 1)
    _, (iy, ix) = ndimage.distance_transform_edt(points == 0, return_indices=True)
    labels = np.where(rng.random((rows, cols)) < 0.1, 0, points[iy, ix]).astype(np.int32)
    roots = np.arange(n + 1)
    roots[1:] = np.where(rng.random(n) < 0.4, rng.integers(1, n + 1, n), roots[1:])  # some members join another
    joined = roots[labels].astype(np.int32)
    memo = InsideDistance()
    memo(labels)
    memo.joined(labels, joined)
    inside, dist = memo(joined)
    fresh_inside, fresh_dist = InsideDistance()(joined)
    np.testing.assert_array_equal(inside, fresh_inside)
    assert dist.tobytes() == fresh_dist.tobytes()


def test_inside_distance_is_not_taken_over_by_labels_that_are_no_join():
    from tamp_os.relief.objects import InsideDistance

    labels = np.zeros((10, 10), np.int32)
    labels[1:9, 1:5], labels[1:9, 5:9] = 1, 2
    split = labels.copy()
    split[1:9, 3] = 3  # a new border: insides shrink, not a join
    memo = InsideDistance()
    memo(labels)
    memo.joined(labels, split)
    np.testing.assert_array_equal(memo(split)[1], InsideDistance()(split)[1])


def test_the_nearest_member_is_ndimages_and_kept_for_the_same_mask_only(monkeypatch):
    from tamp_os.relief import objects
    from tamp_os.relief.objects import nearest_member

    rng = np.random.default_rng(2)
    mask = rng.random((40, 50)) < 0.05
    dist, (iy, ix) = nearest_member(mask)
    expected, (ey, ex) = ndimage.distance_transform_edt(~mask, return_indices=True)
    np.testing.assert_array_equal(dist, expected)
    np.testing.assert_array_equal(iy, ey)
    np.testing.assert_array_equal(ix, ex)
    assert nearest_member(mask.copy())[0] is dist  # the same members, another array: kept
    with pytest.raises(ValueError):
        dist[0, 0] = 0.0  # shared: read-only
    moved = mask.copy()
    moved[0, 0] = ~moved[0, 0]
    np.testing.assert_array_equal(nearest_member(moved)[0], ndimage.distance_transform_edt(~moved))  # changed: its own
    monkeypatch.setattr(objects, "NEAREST_REMEMBERED_PX", 10)  # a grid too large to keep is computed each time
    assert nearest_member(mask)[0] is not nearest_member(mask)[0]


@settings(max_examples=80, deadline=None)
@given(rows=st.integers(1, 25), cols=st.integers(1, 25), share=st.floats(0.0, 1.0), seed=st.integers(0, 2**16))
def test_grown_marks_are_a_3x3_dilation_of_grid_marks(rows, cols, share, seed):
    # Marks on every second pixel of every second row, odd and even sizes, marks on every border.
    from tamp_os.relief.objects import grown_marks

    marks = np.zeros((rows, cols), bool)
    marks[::2, ::2] = np.random.default_rng(seed).random(marks[::2, ::2].shape) < share
    np.testing.assert_array_equal(grown_marks(marks), ndimage.binary_dilation(marks, structure=np.ones((3, 3))))


@settings(max_examples=60, deadline=None)
@given(rows=st.integers(4, 50), cols=st.integers(4, 50), n=st.integers(1, 10), seed=st.integers(0, 2**16))
def test_convex_fill_fills_as_the_loop_over_hulls_did(rows, cols, n, seed):
    # Nearly convex discs with notches, overlapping hulls, concave ones left alone.
    from tamp_os.relief import objects
    from tamp_os.relief.hull import labelled_hulls

    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:rows, :cols]
    labels = np.zeros((rows, cols), np.int32)
    for k in range(1, n + 1):
        cy, cx, r = rng.integers(0, rows), rng.integers(0, cols), rng.integers(2, 15)
        disc = ((yy - cy) ** 2 + (xx - cx) ** 2 < r * r) & (labels == 0)
        disc &= rng.random((rows, cols)) < rng.choice([0.97, 0.9, 0.6])  # notches, or ragged
        labels[disc] = k
    expected = labels.copy()
    for k, box, hull, solidity in labelled_hulls(labels, np.ones(n + 1, bool)):
        if solidity >= objects.CONVEX_SOLIDITY:
            window = expected[box]
            window[hull & (window == 0)] = k
    np.testing.assert_array_equal(objects._convex_fill(labels), expected)


@pytest.mark.timeout(60)
def test_expanded_labels_where_is_skimages_expand_labels():
    """expanded_labels_where gives np.where(where, expand_labels(...), 0): random labels of
    every density, distances at and between integer square roots, none labelled."""
    from tamp_os.relief.objects import expanded_labels_where, float_sqrt_bound

    rng = np.random.default_rng(11)
    for shape in [(1, 12), (12, 1), (9, 14), (40, 33)]:
        for density in (0.0, 0.01, 0.1, 0.5):
            labels = np.where(rng.random(shape) < density, rng.integers(1, 6, shape), 0).astype(np.int32)
            where = rng.random(shape) < 0.7
            for distance in (0.0, 1.0, 1.5, 2.0, np.sqrt(5.0), 3.999, 4.0, 8.968):
                expected = np.where(where, segmentation.expand_labels(labels, distance=distance), 0)
                got = expanded_labels_where(labels, distance, where)
                assert got.dtype == labels.dtype
                np.testing.assert_array_equal(got, expected, err_msg=f"{shape} {density} {distance}")
    for distance in (0.0, 0.5, 1.0, np.sqrt(2.0), np.nextafter(np.sqrt(2.0), 0), 7.3, 100.0):
        bound = float_sqrt_bound(distance)
        assert np.sqrt(float(bound)) <= distance < np.sqrt(float(bound + 1))
    assert float_sqrt_bound(-1.0) == -1


@pytest.mark.timeout(60)
def test_dilate_and_erode_are_scipys_by_a_disk():
    """objects.py's disk dilation and erosion (row runs of every width from doubled runs) give
    scipy's binary_dilation and binary_erosion by scales.disk, the picture's outside empty
    (or full for a dilation told so), at radii with odd, even and power-of-two row widths."""
    from tamp_os.relief import objects
    from tamp_os.relief.scales import disk

    rng = np.random.default_rng(5)
    for shape in [(1, 1), (1, 17), (17, 1), (13, 19), (50, 41)]:
        for density in (0.0, 0.03, 0.3, 0.9, 1.0):
            mask = rng.random(shape) < density
            for radius in (1.0, 1.5, 2.0, 3.2, 4.0, 5.5, 8.0, 12.0):
                foot = disk(radius)
                for outside in (False, True):
                    expected = ndimage.binary_dilation(mask, foot, border_value=0) if not outside else \
                        ~ndimage.binary_erosion(~mask, foot, border_value=0)
                    np.testing.assert_array_equal(objects._dilate(mask, radius, outside), expected, err_msg=f"{shape} {density} {radius} {outside}")
                np.testing.assert_array_equal(objects._erode(mask, radius), ndimage.binary_erosion(mask, foot, border_value=0))


@pytest.mark.timeout(60)
def test_row_runs_are_maxima_over_windows():
    """row_runs: each window of every width from 1 to the row's length, set where any pixel is."""
    from tamp_os.relief.objects import row_runs

    rng = np.random.default_rng(6)
    mask = rng.random((7, 23)) < 0.15
    runs = row_runs(mask, set(range(1, 24)))
    for w, run in runs.items():
        expected = np.array([[mask[i, j : j + w].any() for j in range(23 - w + 1)] for i in range(7)]).reshape(7, 23 - w + 1)
        np.testing.assert_array_equal(run, expected, err_msg=str(w))
