"""Find foreground objects (particles, spheres, cells, grains) and shape them as domes.

Brightness is not height: in a secondary-electron SEM image a sphere is about as bright as
the ground, outlined by a bright rim on one side and a dark shadow edge on the other. Both are
strong edges, so objects are found as regions *enclosed by edges*, which does not care whether
the object is brighter, darker or as bright as its surroundings (and so works with `invert`).
Where nothing is enclosed, bright compact blobs (an Otsu threshold) are the fallback.
"""

from __future__ import annotations

import hashlib
import threading
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage import filters, segmentation

from ..clean.annotations import filled_holes
from .extrema import h_maxima
from .order import SIGN_BIT, float32_keys, float32_values, sorted_pairs
from .hull import hull_rows, solid_enough
from .scales import disk, gaussian_mm

MAX_COVER = 0.7  # objects covering more than this share of the picture are the background
GAP_MM = 1.5  # rim gaps up to 3 mm wide are bridged
MAX_BORDER_SHARE = 0.2  # objects with more of their outline on the picture's border are ground
MIN_SOLIDITY = 0.7  # pockets of ground enclosed between touching objects are concave: drop them
CONVEX_SOLIDITY = 0.85  # objects at least this solid are filled out to their convex hull
AJAR_RIM_SHARE = 0.85  # a convex part of the ground outlined by edges along this share of its length is an object
MIN_EDGE_RATIO = 2.7  # the steepest gradient near an outline, over the picture's median gradient


@dataclass(frozen=True)
class ObjectMap:
    """Objects found on a grid.

    labels : (rows, cols) int32, 0 = background, 1..count = objects.
    count : number of objects.
    method : 'edges' (enclosed by edges), 'bright' (threshold) or 'none'.
    """

    labels: np.ndarray
    count: int
    method: str

    @property
    def mask(self) -> np.ndarray:
        return self.labels > 0

    @property
    def cover(self) -> float:
        return float(self.mask.mean()) if self.labels.size else 0.0


def find_objects(image01: np.ndarray, *, pitch_mm: float, min_area_mm2: float, nozzle_mm: float = 0.4,
                 blur_ratio: float = 1.0) -> ObjectMap:
    """Label objects in a 0..1 image on a grid of pitch_mm.

    Parameters
    ----------
    image01 : (rows, cols) float, 0..1.
    pitch_mm : grid pitch, mm per pixel.
    min_area_mm2 : smallest object kept (a fingertip-sized area).
    nozzle_mm : the printer's nozzle; smoothing and gap closing work at this scale.
    blur_ratio : how much blurrier the picture is than at the scale the constants were set at
        (>= 1; picture_scale.py): an edge's gradient falls by about this factor, so weaker edge
        pixels, down to the threshold over blur_ratio, are kept where they continue a strong edge.
    """
    smooth = gaussian_mm(image01, max(nozzle_mm, 0.75 * pitch_mm), pitch_mm)
    min_px = max(4, int(min_area_mm2 / pitch_mm**2))
    grad = filters.sobel(smooth)
    labels = _distinct(_enclosed_by_edges(smooth, grad, pitch_mm, nozzle_mm, min_px, blur_ratio), smooth, grad, nozzle_mm / pitch_mm)
    method = "edges"
    if labels.max() == 0 or (labels > 0).mean() > MAX_COVER:
        # Edge strength first (one vectorised pass) so that hulls are drawn only for the few left.
        labels = _keep_solid(_distinct(_bright_blobs(smooth, pitch_mm, nozzle_mm, min_px), smooth, grad, nozzle_mm / pitch_mm))
        method = "bright"
    if labels.max() == 0 or (labels > 0).mean() > MAX_COVER:
        return ObjectMap(np.zeros(image01.shape, np.int32), 0, "none")
    labels = sequential_labels(labels)
    return ObjectMap(labels.astype(np.int32), int(labels.max()), method)


def _edges(grad: np.ndarray, blur_ratio: float = 1.0) -> np.ndarray:
    """Strong edges: gradient above a robust noise level and above Otsu's split of gradients
    (with a blurrier picture, also the pixels above that over blur_ratio connected to them)."""
    med = float(np.median(grad))
    mad = float(np.median(np.abs(grad - med))) * 1.4826
    thresh = max(med + 4.0 * mad, filters.threshold_otsu(grad) if np.ptp(grad) > 0 else 0.0)
    if blur_ratio <= 1.0:
        return grad > thresh
    return filters.apply_hysteresis_threshold(grad, thresh / blur_ratio, thresh)


def _enclosed_by_edges(smooth, grad, pitch_mm, nozzle_mm, min_px, blur_ratio=1.0) -> np.ndarray:
    edges = _edges(grad, blur_ratio)
    # Close gaps of about a nozzle width along rims, then fill what the rims enclose.
    closed = _erode(_dilate(edges, 1.5 * nozzle_mm / pitch_mm), 1.5 * nozzle_mm / pitch_mm)
    # Enclosed = every region the edges cut off from the ground (the largest open region).
    # Unlike a plain hole fill, an object cut by the picture's border still counts: the FePt
    # spheres touch the top edge. Concave pockets of ground are dropped later by solidity.
    # Opening the open space by a disk of GAP_MM cuts it at rim gaps narrower than 2 × GAP_MM
    # (where a shaded side fades into its shadow), so a sphere's inside is its own region.
    regions, n = ndimage.label(_dilate(_erode(~closed, GAP_MM / pitch_mm), GAP_MM / pitch_mm))
    if n == 0:
        return regions
    ground = 1 + int(np.argmax(np.bincount(regions.ravel())[1:]))
    filled = _enclosed_parts(regions, ground, closed, pitch_mm)
    # Give back what the opening shaved off the insides (never the ground), then the rim band.
    filled |= _dilate(filled, GAP_MM / pitch_mm) & ~closed & (regions != ground)
    filled |= closed & _dilate(filled, 4 * nozzle_mm / pitch_mm * blur_ratio)
    # Interiors without the edge band, opened so thin unclosed rims vanish; touching objects
    # stay apart because the edge between them is removed here.
    interior = _dilate(_erode(filled & ~closed, 2 * nozzle_mm / pitch_mm), 2 * nozzle_mm / pitch_mm)
    labels, n = ndimage.label(interior)
    if n == 0:
        return labels
    labels = _keep(labels, min_px, filled.size)
    # Give each object back its rim: the edge band around it, never another region's inside.
    # (A blurrier picture has edge bands blur_ratio times wider: its rims are given back as wide.)
    reach_px = 8 * nozzle_mm / pitch_mm * blur_ratio + 1
    return _convex_fill(expanded_labels_where(labels, reach_px, (labels > 0) | (closed & filled)))


def expanded_labels_where(labels: np.ndarray, distance_px: float, where: np.ndarray) -> np.ndarray:
    """np.where(where, segmentation.expand_labels(labels, distance=distance_px), 0) of (rows,
    cols) labels, looked up at the `where` pixels only. The same nearest label pixels (one
    feature transform); the distance test on the integer squared distance, against the largest
    integer whose float square root is within distance_px: what the float distances
    expand_labels compares (square roots of exact sums of integer squares) say, without them."""
    iy, ix = ndimage.distance_transform_edt(labels == 0, return_distances=False, return_indices=True)
    h, w = labels.shape
    dy = iy - np.arange(h, dtype=iy.dtype)[:, None]
    dx = ix - np.arange(w, dtype=ix.dtype)
    dy *= dy
    dx *= dx
    dy += dx
    near = dy <= float_sqrt_bound(distance_px)
    near &= where
    iy *= w
    iy += ix  # each pixel's nearest label pixel, as a flat index
    return np.where(near, labels.ravel().take(iy), 0).astype(labels.dtype, copy=False)


def float_sqrt_bound(distance: float) -> int:
    """The largest integer n (or -1) with np.sqrt(float(n)) <= distance: integers n with
    sqrt(n) <= distance in float64 are exactly those up to it (the float square root is monotone)."""
    if not distance >= 0:
        return -1
    n = int(distance * distance)
    while np.sqrt(np.float64(n + 1)) <= distance:
        n += 1
    while n >= 0 and not np.sqrt(np.float64(n)) <= distance:
        n -= 1
    return n


def _enclosed_parts(regions: np.ndarray, ground: int, closed: np.ndarray, pitch_mm: float) -> np.ndarray:
    """What the rims enclose: open regions other than the ground, and parts left ajar.

    Where a sphere's shaded side meets a neighbour's shadow its rim can stay open over several
    mm (the FePt top sphere), and its inside joins the ground, or a region that runs along the
    picture's border, there. So those are split at their necks (a watershed of the distance to
    the edges, one basin per maximum standing GAP_MM above its neck), and a part that edges
    outline along AJAR_RIM_SHARE of its length and that is convex is an object left ajar.
    Ground pockets between objects are outlined by edges too, but they are concave.
    """
    free = regions > 0
    rim = _dilate(closed, 1.5)
    rim_share, border_share = _outline_shares(regions, rim)
    whole = border_share <= MAX_BORDER_SHARE
    whole[[0, ground]] = False
    dist = ndimage.distance_transform_edt(np.pad(free, 1, constant_values=True))[1:-1, 1:-1]
    parts = split_at_necks(free, GAP_MM / pitch_mm, dist=dist, within=~whole[regions])
    rim_share, border_share = _outline_shares(parts, rim)
    # An object left ajar is wider than its gap (over 2 × GAP_MM, or the opening would have
    # closed it): parts less than 2 × GAP_MM across at their widest are strips between edges.
    reach = label_max(dist, parts, int(parts.max()))
    ajar = (rim_share >= AJAR_RIM_SHARE) & (border_share <= MAX_BORDER_SHARE) & (reach * pitch_mm >= GAP_MM)
    ajar[0] = False
    ajar = solid_enough(parts, ajar, CONVEX_SOLIDITY)
    return whole[regions] | ajar[parts]


def split_at_necks(
    mask: np.ndarray, depth_px: float, dist: np.ndarray | None = None, *, within: np.ndarray | None = None
) -> np.ndarray:
    """Label the mask split at its necks (int32, 0 outside the mask).

    A watershed of the distance to the outside (the picture's border is not an outside), one
    basin per maximum standing `depth_px` above the neck that joins it to a higher one.
    (Splitting wholly on a grid twice as coarse loses the coins' rims left ajar; only the
    maxima are searched there.)
    `dist`, if given, is that distance already computed (the caller needs it too). `within`,
    if given (bool, whole 4-connected parts of the mask), limits the labels to those parts:
    the basins elsewhere are never flooded (the maxima are still searched on all of `dist`).
    """
    if dist is None:
        dist = ndimage.distance_transform_edt(np.pad(mask, 1, constant_values=True))[1:-1, 1:-1]
    peaks, count = ndimage.label(sparse_h_maxima(dist, depth_px) & mask)
    if count == 0:
        return np.zeros(mask.shape, np.int32)
    basins = mask if within is None else mask & within
    return segmentation.watershed(-dist, np.where(basins, peaks, 0), mask=basins).astype(np.int32)


def sparse_h_maxima(dist: np.ndarray, depth_px: float) -> np.ndarray:
    """Maxima of `dist` (rows, cols) standing `depth_px` above their necks: bool markers.

    Searched on every second pixel of every second row (h_maxima's reconstruction is the
    costly part of the split, and 4x fewer pixels make it 4x cheaper), so each maximum is
    marked by the grid points of its plateau; the watershed that grows basins from these
    markers still runs at full resolution, so the split lines (and the coins' rims) keep
    their full detail. A marker sits within a pixel of its true maximum, and its height there
    may be up to about a pixel lower, so a maximum right at the depth could be missed: on the
    benchmark's 15 pictures the objects found are pixel-for-pixel the same as at full grid.
    """
    small = np.ascontiguousarray(dist[::2, ::2])
    peaks = h_maxima(small, depth_px).astype(bool)
    out = np.zeros(dist.shape, bool)
    out[::2, ::2] = peaks
    return out


def grown_marks(marks: np.ndarray) -> np.ndarray:
    """A (rows, cols) bool mask set on every second pixel of every second row at most (as
    sparse_h_maxima's), each set pixel grown to its 3 x 3 square: ndimage.binary_dilation by a
    3 x 3 square, as nine strided copies of the grid (no pass over every pixel's neighbours)."""
    small = marks[::2, ::2]
    out = np.zeros(marks.shape, bool)
    for dy in (-1, 0, 1):
        i0 = 1 if dy < 0 else 0  # the first grid row landing inside the picture
        n = min(small.shape[0] - i0, (marks.shape[0] - (2 * i0 + dy) + 1) // 2)
        for dx in (-1, 0, 1):
            j0 = 1 if dx < 0 else 0
            m = min(small.shape[1] - j0, (marks.shape[1] - (2 * j0 + dx) + 1) // 2)
            r, c = 2 * i0 + dy, 2 * j0 + dx
            out[r : r + 2 * n : 2, c : c + 2 * m : 2] |= small[i0 : i0 + n, j0 : j0 + m]
    return out


def _dilate(mask: np.ndarray, radius_px: float, outside: bool = False) -> np.ndarray:
    """Binary dilation of a (rows, cols) bool mask by `disk(radius_px)`; pixels outside the
    picture count as `outside`.

    The disk is taken row by row: a 1-D run along each row for each of its widths (row_runs),
    shifted up or down and combined. scipy's 2-D binary morphology visits every disk pixel for
    every image pixel; this gives the same pixels 2-3x faster at r = 2-4.
    """
    footprint = disk(radius_px)
    r = footprint.shape[0] // 2
    rows, cols = mask.shape
    padded = np.pad(mask, r, constant_values=outside)
    out = np.zeros(mask.shape, bool)
    widths = [int(width) for width in footprint.sum(axis=1)]
    runs = row_runs(padded, set(widths))
    for dy, width in enumerate(widths):
        # run[:, j] covers padded columns j .. j + width - 1: centred (as maximum_filter1d's
        # window) on column j + width // 2; the pad (r >= width // 2) keeps every window inside
        out |= runs[width][dy : dy + rows, r - width // 2 : r - width // 2 + cols]
    return out


def row_runs(mask: np.ndarray, widths: set[int]) -> dict[int, np.ndarray]:
    """Per width w: (rows, cols - w + 1) bool, whether any of mask[:, j : j + w] is set. Runs
    of powers of two by doubling, a run of w as two overlapping runs of the largest power of
    two within it: a few whole-array ORs, where maximum_filter1d copies every row to a float
    buffer (the same pixels, 3-5x sooner on the objects' grid)."""
    powers = {1: mask}
    k = 1
    while 2 * k <= max(widths):
        powers[2 * k] = powers[k][:, :-k] | powers[k][:, k:]
        k *= 2
    runs = {}
    for w in widths:
        m = 1 << (w.bit_length() - 1)  # the largest power of two <= w
        run = powers[m]
        runs[w] = run[:, : run.shape[1] - (w - m)] | run[:, w - m :]
    return runs


def _erode(mask: np.ndarray, radius_px: float) -> np.ndarray:
    """Binary erosion by `disk(radius_px)`, outside the picture counted as empty (as
    scipy's border_value=0): the complement of the background's dilation."""
    return ~_dilate(~mask, radius_px, outside=True)


def _outline_shares(labels: np.ndarray, rim: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per label (index 0 = none): the shares of its outline along `rim` and along the
    picture's border."""
    count = int(labels.max())
    on_border = np.zeros(labels.shape, bool)
    on_border[[0, -1], :] = on_border[:, [0, -1]] = True
    outline = (inner_outline(labels) | on_border) & (labels > 0)
    length = np.maximum(np.bincount(labels[outline], minlength=count + 1), 1)
    along_rim = np.bincount(labels[outline & rim], minlength=count + 1) / length
    along_border = np.bincount(labels[outline & on_border], minlength=count + 1) / length
    return along_rim, along_border


def inner_outline(labels: np.ndarray) -> np.ndarray:
    """Labelled pixels (labels != 0) with a 4-neighbour of another value, (rows, cols) bool.

    The same pixels as skimage's find_boundaries(labels, mode="inner") (the picture's edge
    is not an outline), by comparing shifted arrays: 3-4x faster than its grey morphology.
    """
    differs = np.zeros(labels.shape, bool)
    vertical = labels[1:, :] != labels[:-1, :]
    differs[1:, :] |= vertical
    differs[:-1, :] |= vertical
    horizontal = labels[:, 1:] != labels[:, :-1]
    differs[:, 1:] |= horizontal
    differs[:, :-1] |= horizontal
    return differs & (labels != 0)


def _convex_fill(labels: np.ndarray) -> np.ndarray:
    """Fill each nearly convex object out to its convex hull (on free ground only).

    Where a rim meets a shadow the edge band is wide, and the interior grown back from it
    leaves a notch; particles, spheres and cells are convex, so the hull is the better guess.
    All hulls at once (hull.py hull_rows); where two overlap on the ground, the lower label's
    (filled first, label by label, before).
    """
    out = labels.copy()
    n = int(labels.max())
    which = np.ones(n + 1, bool)
    which[0] = False
    rows = hull_rows(labels, which) if n > 0 else None
    if rows is None:
        return out
    lab, row, lo, hi = rows
    width = np.maximum(hi - lo + 1, 0)
    area = np.bincount(labels.ravel(), minlength=n + 1)
    hull = np.bincount(lab, weights=width, minlength=n + 1)
    solid = np.zeros(n + 1, bool)
    solid[hull > 0] = area[hull > 0] / hull[hull > 0] >= CONVEX_SOLIDITY
    take = solid[lab] & (width > 0)
    lab, row, lo, width = lab[take], row[take], lo[take], width[take]
    # Every pixel of the solid hulls: each row's run, from its first column.
    run_start = np.repeat(np.cumsum(width) - width, width)
    cols = np.repeat(lo, width) + np.arange(int(width.sum())) - run_start
    where = np.repeat(row, width) * labels.shape[1] + cols
    lowest = np.full(labels.size, n + 1, np.int64)
    np.minimum.at(lowest, where, np.repeat(lab, width))
    free = (labels.ravel() == 0) & (lowest <= n)
    out.ravel()[free] = lowest[free]
    return out


def _bright_blobs(smooth, pitch_mm, nozzle_mm, min_px) -> np.ndarray:
    if np.ptp(smooth) <= 1e-6:
        return np.zeros(smooth.shape, np.int32)
    bright = smooth > filters.threshold_otsu(smooth)
    # Two nozzle widths: a particle touching a bright speck of texture comes apart from it.
    bright = _dilate(_erode(bright, 2 * nozzle_mm / pitch_mm), 2 * nozzle_mm / pitch_mm)
    bright = filled_holes(bright)  # binary_fill_holes by one labelling of the ground (tested there)
    labels, n = ndimage.label(bright)
    return _keep_sized(labels, min_px, bright.size) if n else labels


def _distinct(labels: np.ndarray, smooth: np.ndarray, grad: np.ndarray, reach_px: float) -> np.ndarray:
    """Keep objects whose outline is a real edge, and that are not dark pockets.

    Texture and noise enclose blobs too, but their outlines are barely steeper than the rest
    of the picture (measured: at most 1.9 on noisy TEM-like texture and 2.4 on textured ground; 3.0–3.9 for particles, 7–8 for SEM sphere rims). A region
    darker than most of the ground is a shadow or a hole, not an object: it stays flat.
    """
    n = int(labels.max())
    if n == 0:
        return labels
    typical = max(float(np.median(grad)), 1e-6)
    outline = inner_outline(labels)
    # The steepest gradient within reach of each outline point (the outline may sit at the
    # outer foot of the rim), then the median along the outline.
    near = ndimage.grey_dilation(grad, footprint=disk(reach_px))
    edge = label_median(near, np.where(outline, labels, 0), n)
    level = label_median(smooth, labels, n)
    ground = smooth[labels == 0]
    # Clearly darker than most of the ground (a tenth of the range below its median).
    dark = min(float(np.percentile(ground, 25)), float(np.median(ground)) - 0.1) if ground.size else -np.inf
    keep = np.concatenate([[False], (np.nan_to_num(edge) >= MIN_EDGE_RATIO * typical) & (level >= dark)])
    return np.where(keep[labels], labels, 0)


def _keep(labels: np.ndarray, min_px: int, total_px: int) -> np.ndarray:
    """Drop objects smaller than min_px, larger than half the picture, or concave pockets."""
    return _keep_solid(_keep_sized(labels, min_px, total_px))


def _keep_sized(labels: np.ndarray, min_px: int, total_px: int) -> np.ndarray:
    """Drop objects smaller than min_px, larger than half the picture, or cut off by its border.

    Counted for all labels at once: noise makes hundreds of tiny ones.
    """
    n = int(labels.max())
    area = np.bincount(labels.ravel(), minlength=n + 1)
    # Pixels on the picture's border, per object: ground cut off by the border is not an object.
    rim = np.concatenate([labels[0], labels[-1], labels[1:-1, 0], labels[1:-1, -1]])
    on_border = np.bincount(rim, minlength=n + 1)
    keep = (area >= min_px) & (area <= 0.5 * total_px) & (on_border <= MAX_BORDER_SHARE * _perimeters(labels, n))
    keep[0] = False
    return np.where(keep[labels], labels, 0)


def _keep_solid(labels: np.ndarray) -> np.ndarray:
    """Drop concave objects (pockets of ground between objects); the hull, the costly part,
    only where area / bounding-box area (a lower bound of solidity) leaves it in doubt."""
    keep = np.ones(int(labels.max()) + 1, bool)
    keep[0] = False
    keep = solid_enough(labels, keep, MIN_SOLIDITY)
    return np.where(keep[labels], labels, 0)


def _perimeters(labels: np.ndarray, n: int) -> np.ndarray:
    """Outline length in pixels of each label 0..n, sides on the picture's border included.

    Counts the pixel sides between a label and anything else (crack length) and scales by
    π/4, the mean ratio of Euclidean to 4-connected length: close to regionprops' perimeter
    for round objects and strips alike, in one vectorised pass instead of one per label.
    """
    padded = np.pad(labels, 1, constant_values=-1)
    counts = np.zeros(n + 2)
    for a, b in ((padded[1:, :], padded[:-1, :]), (padded[:, 1:], padded[:, :-1])):
        differ = a != b
        counts += np.bincount(a[differ] + 1, minlength=n + 2) + np.bincount(b[differ] + 1, minlength=n + 2)
    return counts[1:] * np.pi / 4


# The relief's check of its members' lifts and the legibility check ask for the ground's nearest
# member of the same members on the same grid; grids up to this size are remembered (one).
NEAREST_REMEMBERED_PX = 1 << 21
_nearest_last: tuple[tuple, tuple] | None = None
_nearest_lock = threading.Lock()


def nearest_member(mask: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """ndimage.distance_transform_edt(~mask, return_indices=True) of a bool (rows, cols) mask of
    members: each pixel's distance to the nearest member pixel and that pixel's (rows, cols).
    The last grid's answer is kept (by the mask's content, read-only), so two checks of the
    same members pay for one transform."""
    global _nearest_last
    key = None
    if mask.size <= NEAREST_REMEMBERED_PX:
        key = (mask.shape, hashlib.blake2b(np.packbits(mask, axis=None).tobytes(), digest_size=16).digest())
        with _nearest_lock:
            last = _nearest_last
        if last is not None and last[0] == key:
            return last[1]
    dist, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    for array in (dist, iy, ix):
        array.flags.writeable = False  # shared by the callers
    if key is not None:
        with _nearest_lock:
            _nearest_last = (key, (dist, (iy, ix)))
    return dist, (iy, ix)


class InsideDistance:
    """The members' insides (each less its outline pixels) and their distance to anything not
    themselves, for the last labels asked, by identity (label arrays are never changed in place
    here). Merging and then splitting members, or doming them and counting their necks, ask
    for it of the same labels: one distance transform instead of two."""

    def __init__(self):
        self._labels: np.ndarray | None = None
        self._value: tuple[np.ndarray, np.ndarray] | None = None

    def __call__(self, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if labels is not self._labels or self._value is None:
            inside = (labels > 0) & ~inner_outline(labels)
            dist = ndimage.distance_transform_edt(inside)
            inside.flags.writeable = dist.flags.writeable = False  # shared by the callers
            self._labels, self._value = labels, (inside, dist)
        return self._value

    def joined(self, labels: np.ndarray, joined: np.ndarray) -> None:
        """Remember the value for `joined`, `labels` with some touching members joined (the last
        labels asked): their insides only grow (the borders between joined members), and a pixel's
        distance changes only in the parts of the insides that grew (4-connected; a pixel's
        nearest outside lies beside the pixels of its part nearer than it, so within its part's
        box one pixel wider). Only those boxes are transformed again."""
        if labels is not self._labels or self._value is None:
            return
        was_inside, was_dist = self._value
        inside = (joined > 0) & ~inner_outline(joined)
        if (was_inside & ~inside).any():  # not a join after all: leave it to the next call
            return
        grown = inside & ~was_inside
        dist = was_dist
        if grown.any():
            parts, n = ndimage.label(inside)
            changed = np.zeros(n + 1, bool)
            changed[parts[grown]] = True
            where = changed[parts]
            rows, cols = np.nonzero(where)
            box = (slice(max(rows.min() - 1, 0), rows.max() + 2), slice(max(cols.min() - 1, 0), cols.max() + 2))
            dist = was_dist.copy()
            dist[box][where[box]] = ndimage.distance_transform_edt(inside[box])[where[box]]
        inside.flags.writeable = dist.flags.writeable = False
        self._labels, self._value = joined, (inside, dist)


def sequential_labels(labels: np.ndarray) -> np.ndarray:
    """The labels renumbered 1..k in their order, 0 kept, in `labels`' dtype: what
    skimage.segmentation.relabel_sequential gives, by a lookup table (a third of its time on a
    working grid; it maps through a general hash table)."""
    present = np.zeros(int(labels.max(initial=0)) + 1, bool)
    present[labels.ravel()] = True
    present[0] = False
    return (np.cumsum(present) * present)[labels].astype(labels.dtype, copy=False)


def dense_ranks(keys: np.ndarray) -> np.ndarray:
    """Each non-negative integer key's rank among the distinct keys (np.unique's inverse), by a
    lookup table when the keys are no larger than a few times their count (a fifth of the sort's
    time), else by np.unique."""
    top = int(keys.max(initial=0))
    if top > 4 * keys.size + 1024:
        return np.unique(keys, return_inverse=True)[1].reshape(keys.shape)
    present = np.zeros(top + 1, bool)
    present[keys.ravel()] = True
    return (np.cumsum(present) - 1)[keys]


def label_max(values: np.ndarray, labels: np.ndarray, n: int, *, initial: float = 0.0) -> np.ndarray:
    """Largest of `values` over each label 0..n (`initial` where a label has none or all are
    lower), float64. ufunc.at with the values' own dtype and intp indices: with a cast on the way
    (float32 values into a float64 array, int32 labels) numpy takes a slow path, 20x slower."""
    out = np.full(n + 1, initial, dtype=values.dtype)
    np.maximum.at(out, labels.ravel().astype(np.intp, copy=False), values.ravel())
    return out.astype(np.float64)


def label_median(values: np.ndarray, labels: np.ndarray, n: int) -> np.ndarray:
    """Median of `values` over each label 1..n (NaN for an empty label), in one sort.

    scipy.ndimage.median selects per label and is about 50x slower with many labels.
    """
    val, starts, counts = sorted_by_label(values, labels, n)
    out = np.full(n, np.nan)
    has = counts > 0
    lo = starts[has] + (counts[has] - 1) // 2
    hi = starts[has] + counts[has] // 2
    out[has] = 0.5 * (val[lo].astype(np.float64) + val[hi])
    return out


def scipy_label_median(values: np.ndarray, labels: np.ndarray, n: int) -> np.ndarray:
    """ndimage.median(values, labels, 1..n), the same numbers from one sort of the labelled
    pixels only (SciPy sorts every pixel, the ground too, by label and value: 5x slower on a
    dense field). As in SciPy: the middle pair averaged in the values' type (float64 for
    integers), and a label without pixels given the first value of that sort, the smallest of
    the lowest label present."""
    val, starts, counts = sorted_by_label(values, labels, n)
    if np.issubdtype(val.dtype, np.integer) or val.dtype == bool:
        val = val.astype(np.float64)
    empty = counts == 0
    lo = np.where(empty, 0, starts + (counts - 1) // 2)
    hi = np.where(empty, 0, starts + counts // 2)
    if not val.size:
        val = np.zeros(1, val.dtype)
    out = (val[lo] + val[hi]) / 2.0
    if empty.any():
        ground = labels == 0
        first = values[ground].min() if ground.any() else val[0]
        out[empty] = first
    return out


def sorted_by_label(values: np.ndarray, labels: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The values inside labels 1..n grouped by label, each group sorted by value; with each
    group's start and count (the order statistics of every label in one sort)."""
    flat = labels.ravel()
    inside = flat > 0
    lab, val = flat[inside], values.ravel()[inside]
    counts = np.bincount(lab, minlength=n + 1)[1:]
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    packed = _sorted_float32(val, lab, n)
    if packed is not None:
        return packed, starts, counts
    if n < 1 << 16:
        # By value, then by label with a stable sort of 16-bit keys (a radix sort): 2x faster
        # than np.lexsort. Equal values may swap places, which leaves every order statistic the same.
        order = np.argsort(val)
        order = order[np.argsort(lab[order].astype(np.uint16), kind="stable")]
    else:
        order = np.lexsort((val, lab))
    return val[order], starts, counts


def _sorted_float32(val: np.ndarray, lab: np.ndarray, n: int) -> np.ndarray | None:
    """float32 values sorted by label, then by value, as one sort of 64-bit keys (the label above
    the value's ordered bits; NumPy's SIMD sort, 3-4 times faster than the two argsorts), or None
    for other values, NaN, or -0.0 (its key is 0.0's: the sort could not tell which one it was)."""
    if val.dtype != np.float32 or n >= 1 << 31 or np.any(val.view(np.uint32) == SIGN_BIT):
        return None
    bits = float32_keys(val)
    if bits is None:
        return None
    return float32_values(sorted_pairs(lab, bits)[1])  # the labels widened once, into the keys


def dome_profile(labels: np.ndarray, *, pitch_mm: float, round_mm: float, pin_aspect: float | None = None,
                 relief_mm: float | None = None, inside_distance: InsideDistance | None = None) -> np.ndarray:
    """Height profile 0..1 of each object: a circular-arc dome, flattened into a plateau
    with rounded shoulders when the object is wider than 2 × round_mm.

    Parameters
    ----------
    labels : (rows, cols) int, 0 = background.
    pitch_mm : grid pitch in mm per pixel.
    round_mm : largest shoulder radius in mm.
    pin_aspect, relief_mm : when given, each object's top stands at most pin_aspect times its
        inscribed radius (of relief_mm, the full height), so an object a point or two wide is a
        low dome, not a pin.

    Returns
    -------
    (rows, cols) float32 in 0..1, 0 on the background.
    """
    n = int(labels.max())
    if n == 0:
        return np.zeros(labels.shape, np.float32)
    # Distance to the nearest pixel of another label or the background, so touching objects
    # get a groove between them instead of merging into one hill.
    inside, dist = (inside_distance or InsideDistance())(labels)
    dist = dist + inside  # +1 px: the outline pixel itself
    reach = label_max(dist, labels, n)  # one pass; ndimage.maximum sorts per label
    radius = np.minimum(reach[1:], round_mm / pitch_mm)
    r = np.concatenate([[1.0], np.maximum(radius, 1.0)])[labels]
    t = np.clip(dist / r, 0.0, 1.0)
    profile = np.where(labels > 0, np.sqrt(1.0 - (1.0 - t) ** 2), 0.0).astype(np.float32)
    if pin_aspect is None or not relief_mm or relief_mm <= 0:
        return profile
    cap = np.concatenate([[1.0], np.clip(pin_aspect * (reach[1:] * pitch_mm) / relief_mm, 0.0, 1.0)]).astype(np.float32)
    return (profile * cap[labels]).astype(np.float32)
