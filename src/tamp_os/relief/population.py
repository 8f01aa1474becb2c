"""Members of a population (particles, beads, cells, nuclei) found by local, not global, contrast.

A global threshold keeps only the brightest members; here each member is measured against the
ground right around it. The ground is a grey opening of the picture (what is left when every
bright thing narrower than BACKGROUND_MM is shaved off), so a dim bead on a dark corner and a
bright one on a glow both stand out of their own surroundings. Each local maximum standing at
least `h` above its neck (h from the noise) seeds a member, the watershed splits touching
members, and each member is cut at half its own peak (its full width at half maximum), so dim
and bright members get their true size. A member must show object evidence: compact, not a
streak, and darker ground all round it; a glow of shading has none of these. Objects wider than
the ground (measured by their outline, in print mm) would be hollowed by it: they are found again
on a ground wide enough for them, joined across every border that is no neck of their outline.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage import segmentation

from ..clean.annotations import ground_parts
from .hull import solid_enough
from .extrema import h_maxima
from .objects import InsideDistance, dense_ranks, grown_marks, label_max, label_median, sequential_labels, sorted_by_label, sparse_h_maxima

BACKGROUND_MM = 12.0  # members up to about this wide are measured against the ground around them
NOISE_SIGMAS = 3.0  # a member's peak stands this many noise deviations above its neck (swept on the benchmark: 3 or 5)
MIN_CONTRAST = 0.04  # and at least this share of the brightness range
MIN_MEMBER_MM2 = 0.3  # smaller spots are noise at print scale
MAX_MEMBER_SHARE = 0.15  # one member larger than this share of the picture is ground, not a member
MIN_SOLIDITY = 0.75
MIN_ROUNDNESS = 0.2  # minor / major axis: streaks and line pieces are not members
RING_MAX = 0.7  # the ring around a member stays (median) below this share of its own contrast (swept: 0.5, 0.7, 0.9)
SMALL_PX = 30
SADDLE_SHARE = 0.9
TEXTURE_RATIO = 3.0  # measured: keeps exactly the 14 particles of particles_on_texture, 5 of 313 TEM texture grains
NECK_MM = 0.5  # members joined by a neck this much narrower than both are two members
# One object, one dome (issue 32): touching members stay apart only where their outline has a real
# neck (the border they share at most NECK_SHARE of the smaller one's inscribed diameter: a chord
# of two touching discs is always shorter; a particle cracked in halves or quarters by noise in its
# shading has borders 1.2-2 times as wide) or a groove of shading between them (NECK_SADDLE).
NECK_SHARE = 1.0
CRACK_SHARE = 1.5  # a border this many times the smaller one's inscribed diameter is a crack, whatever the shading,
CHIP_SHARE = 0.5  # when the smaller piece is at most this share of the larger (a chip of it; touching particles are alike)
CRACK_MIN_MM = 4.0  # the shading rule joins pieces at least this wide (inscribed, on the print): a large particle's shading varies across it
NECK_SADDLE = 0.8  # and their shading has no groove between them: the saddle stands this share of the lower peak
OUTLINE_NECK = 0.8  # a border where the joint outline is this share of the narrower side's inscribed radius wide is no neck
WIDER_GROUND = 1.5  # objects wider than the local ground are found again on a ground this many times their width


@dataclass(frozen=True)
class Members:
    """labels: (rows, cols) int32, 0 = ground; count; contrast: median top-hat per member (0..1
    units, index k-1); noise: the noise level the threshold came from."""

    labels: np.ndarray
    count: int
    contrast: np.ndarray
    noise: float
    energy: float = 0.0  # share of the top-hat's sum inside the members: how much of the picture's detail they hold

    @property
    def cover(self) -> float:
        return float((self.labels > 0).mean())

    def spread(self, pitch_mm: float) -> float:
        """90th over 10th percentile of the members' equivalent diameters."""
        d = self.diameters_mm(pitch_mm)
        return float(np.percentile(d, 90) / max(np.percentile(d, 10), 1e-9)) if d.size else np.inf

    def diameters_mm(self, pitch_mm: float) -> np.ndarray:
        area = np.bincount(self.labels.ravel(), minlength=self.count + 1)[1:]
        return 2 * np.sqrt(area / np.pi) * pitch_mm


def noise_level(image01: np.ndarray) -> float:
    """Robust standard deviation of pixel noise: MAD of the difference to a 3x3 mean, scaled."""
    residual = image01 - ndimage.uniform_filter(image01, 3, mode="reflect")
    return float(1.4826 * np.median(np.abs(residual - np.median(residual))) * 1.125)  # 1.125: the mean's own share


def local_tophat(bright01: np.ndarray, pitch_mm: float, width_mm: float = BACKGROUND_MM) -> np.ndarray:
    """What stands above the ground around it: the picture minus its grey opening by a square
    `width_mm` wide (separable min and max filters: linear time at any width), smoothed."""
    size = max(3, int(round(width_mm / pitch_mm)) | 1)
    ground = ndimage.maximum_filter(ndimage.minimum_filter(bright01, size, mode="reflect"), size, mode="reflect")
    ground = ndimage.uniform_filter(ground, size, mode="reflect")  # a square's corners are no feature
    return np.maximum(bright01 - np.minimum(ground, bright01), 0.0).astype(np.float32)


def find_members(bright01: np.ndarray, *, pitch_mm: float, noise: float | None = None,
                 background_mm: float = BACKGROUND_MM) -> Members:
    """Members of a population in a 0..1 picture where content is bright (flip it first if not).

    Parameters
    ----------
    bright01 : (rows, cols) float, 0..1, content bright (the working grid).
    pitch_mm : grid pitch in mm per pixel.
    noise : the picture's noise_level, if known (the same for both polarities).
    background_mm : members up to about this wide are measured against the ground around them.
    """
    image = ndimage.gaussian_filter(bright01.astype(np.float32), 0.6, mode="nearest")
    noise = noise_level(bright01.astype(np.float32)) if noise is None else noise
    found = _members_on_ground(image, pitch_mm=pitch_mm, noise=noise, background_mm=background_mm)
    # One object, one dome (issue 32): objects wider than the local ground are hollowed by it (the
    # ground's opening fits inside them) and crack into several members; measured on the print, a
    # ground wide enough for the objects the first members lie in finds them whole.
    width_mm = object_width_mm(image, found.labels, pitch_mm)
    if width_mm > background_mm:
        found = _members_on_ground(image, pitch_mm=pitch_mm, noise=noise, background_mm=WIDER_GROUND * width_mm,
                                   wide_objects=True)
    return found


def object_width_mm(image: np.ndarray, labels: np.ndarray, pitch_mm: float) -> float:
    """The median inscribed diameter (mm) of the solid bright objects (Otsu's foreground, pieces at
    least MIN_SOLIDITY solid and at most MAX_MEMBER_SHARE of the picture) that hold members: how wide the objects are whatever their shading,
    from the outline only (0 when none)."""
    from skimage import filters

    if labels.max() == 0 or float(np.ptp(image)) <= 0:
        return 0.0
    objects, n = ndimage.label(image > filters.threshold_otsu(image))
    held = np.zeros(n + 1, bool)
    held[objects[labels > 0]] = True
    held[0] = False
    held &= np.bincount(objects.ravel(), minlength=n + 1) <= MAX_MEMBER_SHARE * objects.size  # larger: a specimen, not a member
    held = solid_enough(objects, held, MIN_SOLIDITY)
    if not held.any():
        return 0.0
    # The distance transform of the box around the held objects, one pixel wider: each pixel's
    # nearest ground lies within its own object's box one pixel wider (the pixels nearer than it
    # are all its object's, and one of them is its neighbour), so the box's transform is the
    # picture's there.
    rows, cols = np.nonzero(held[objects])
    box = (slice(max(rows.min() - 1, 0), rows.max() + 2), slice(max(cols.min() - 1, 0), cols.max() + 2))
    radius = label_max(ndimage.distance_transform_edt(objects[box] > 0), objects[box], n)
    return float(np.median(2.0 * radius[np.flatnonzero(held)] * pitch_mm))


def _members_on_ground(image: np.ndarray, *, pitch_mm: float, noise: float, background_mm: float,
                       wide_objects: bool = False) -> Members:
    top = local_tophat(image, pitch_mm, background_mm)
    h = max(NOISE_SIGMAS * noise, MIN_CONTRAST)
    seeds, n = ndimage.label(h_maxima(top, h) & (top >= h))
    empty = Members(np.zeros(image.shape, np.int32), 0, np.zeros(0), noise)
    if n == 0:
        return empty
    # Basins only where the top-hat reaches h (fewer pixels for the watershed, the costly step on
    # textured pictures); a member whose peak is under 2h is then cut at h, not at half its peak.
    basins = segmentation.watershed(-top, seeds, mask=top >= h)
    peak = label_max(top, basins, n)
    # Each member at half its own peak: dim and bright members get their true size.
    labels = np.where((basins > 0) & (top >= 0.5 * peak[basins]), basins, 0)
    # Shading's cracks joined first (merge_without_neck), then parted again where the outline has a
    # neck (_split_touching): one object, one dome.
    inside_distance = InsideDistance()  # asked by the merge and the split of the same members when nothing merged
    labels = merge_without_neck(_filled(_merge_shallow(_largest_parts(labels), top)), top, large_px=CRACK_MIN_MM / pitch_mm,
                                inside_distance=inside_distance)
    if wide_objects:  # objects wider than the ground: their shading's cracks are joined by the outline alone
        labels = merge_across_no_neck(labels)
    labels = _split_touching(labels, NECK_MM / pitch_mm, inside_distance=inside_distance)
    labels = _with_evidence(labels, top, pitch_mm, h)
    labels = _solid(_above_texture(labels, top))
    labels = sequential_labels(labels)
    count = int(labels.max())
    if count == 0:
        return empty
    contrast = label_median(top, labels, count)
    energy = float(top[labels > 0].sum() / max(float(top.sum()), 1e-9))
    return Members(labels.astype(np.int32), count, contrast, noise, energy)


def _solid(labels: np.ndarray) -> np.ndarray:
    """Drop concave members (solidity under MIN_SOLIDITY). A hull per member is the costly part,
    so it comes last, for the survivors only, and only for members over SMALL_PX: a blob of a
    few pixels is compact whatever its hull says."""
    n = int(labels.max())
    if n == 0:
        return labels
    area = np.bincount(labels.ravel(), minlength=n + 1)
    keep = area > 0
    keep[0] = False
    small = area < SMALL_PX
    keep = solid_enough(labels, keep & ~small, MIN_SOLIDITY) | (keep & small)
    return np.where(keep[labels], labels, 0)


def _above_texture(labels: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Keep members whose contrast is TEXTURE_RATIO times the ground's texture (the median
    top-hat outside the candidates): on a textured substrate every grain of texture is a local
    maximum with a ring around it, but only particles stand well above that texture."""
    n = int(labels.max())
    if n == 0 or (labels > 0).all():
        return labels
    texture = float(np.median(top[labels == 0]))
    contrast = label_median(top, labels, n)
    keep = np.concatenate([[False], np.nan_to_num(contrast) >= TEXTURE_RATIO * texture])
    return np.where(keep[labels], labels, 0)


def _largest_parts(labels: np.ndarray) -> np.ndarray:
    """The half-maximum cut can leave crumbs of a basin; keep each label's largest 8-connected part."""
    parts, n = ndimage.label(labels > 0, structure=np.ones((3, 3)))
    if n == 0:
        return labels
    # Parts of a label are separate components only if the label spans two of them.
    owner = np.zeros(n + 1, np.int64)
    owner[parts.ravel()] = labels.ravel()
    size = np.bincount(parts.ravel(), minlength=n + 1)
    size[0] = 0
    # Each label's first part in the order of decreasing size (equal sizes in that sort's order).
    order = np.argsort(size)[::-1]
    order = order[(order != 0) & (size[order] > 0)]
    _, first = np.unique(owner[order], return_index=True)
    keep = np.zeros(n + 1, bool)
    keep[order[first]] = True
    return np.where(keep[parts], labels, 0)


def _with_evidence(labels: np.ndarray, top: np.ndarray, pitch_mm: float, h: float) -> np.ndarray:
    """Keep members that look like objects: big enough, not too big, round enough, contrast h
    over the ground all round (compactness is checked last, in _solid)."""
    n = int(labels.max())
    if n == 0:
        return labels
    area = np.bincount(labels.ravel(), minlength=n + 1).astype(np.float64)
    keep = (area * pitch_mm**2 >= MIN_MEMBER_MM2) & (area <= MAX_MEMBER_SHARE * labels.size)
    keep[0] = False
    keep &= roundness(labels, n) >= MIN_ROUNDNESS
    # Contrast all round: the ring just outside (1 mm, or half the member's radius if wider)
    # stays low. Ring pixels belong to their nearest member.
    inside = label_median(top, labels, n)
    radius_px = np.sqrt(area[1:] / np.pi)
    reach = max(1.0, 1.0 / pitch_mm)
    mask = labels > 0
    dist, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    owner = labels[iy, ix]
    ring = (~mask) & (dist <= np.maximum(reach, 0.5 * np.concatenate([[0], radius_px]))[owner])
    # The median of the ring: in a dense field a neighbour's flank fills part of every ring.
    ring_high = label_median(top, np.where(ring, owner, 0), n)
    clear = np.nan_to_num(ring_high, nan=0.0) <= RING_MAX * inside
    keep[1:] &= clear & (inside >= h * 0.5)
    return np.where(keep[labels], labels, 0)


def _merge_shallow(labels: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Merge touching members whose saddle stands above SADDLE_SHARE of the lower one's peak: two
    maxima of noise on one dim bead's top are one bead. (Touching members with a real neck come
    apart again at it in _split_touching.)"""
    n = int(labels.max())
    if n < 2:
        return labels
    peak = label_max(top, labels, n)

    # The saddle of each touching pair: the highest of min(top) over the pixel pairs joining them.
    touching = border_levels(labels, top, n)
    if touching is None:
        return labels
    x_of, y_of, saddle = touching
    shallow = saddle >= SADDLE_SHARE * np.minimum(peak[x_of], peak[y_of])
    roots = joined_roots(n, x_of[shallow].tolist(), y_of[shallow].tolist())
    return roots[labels].astype(labels.dtype)


def joined_roots(n: int, xs, ys) -> np.ndarray:
    """For labels 0..n, the smallest label of the group each ends in when every pair (xs[i], ys[i])
    is joined: index it with a label image to merge the groups. Each pair hooks the larger of its
    two roots under the smaller, then every label jumps to its root's root, until the pairs agree
    (a few rounds of array operations, not a loop over labels)."""
    root = np.arange(n + 1)
    xs, ys = np.asarray(xs, np.intp), np.asarray(ys, np.intp)
    while xs.size:
        rx, ry = root[xs], root[ys]
        apart = rx != ry
        if not apart.any():
            break
        np.minimum.at(root, np.maximum(rx, ry)[apart], np.minimum(rx, ry)[apart])
        while True:  # hooks only ever point to a smaller label: every chain ends at its group's smallest
            jumped = root[root]
            if np.array_equal(jumped, root):
                break
            root = jumped
    return root


def neckless_pairs(labels: np.ndarray, top: np.ndarray | None = None, large_px: float = 0.0, *,
                   inside_distance: InsideDistance | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Touching members (a, b arrays) whose shared border is wider than NECK_SHARE of the smaller
    one's inscribed diameter: no neck between them, so one object was split (by shading, not by
    its outline). The border's width counts the 4-neighbour pixel pairs across it (per row or
    column crossed: a straight border of length L gives L). With `top` (the local contrast), only
    pairs whose shading has no groove between them either (the saddle at least NECK_SADDLE of the
    lower one's peak): touching particles are parted by a groove of shading, cracks are not."""
    n = int(labels.max())
    if n < 2:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    keys, levels = [], []
    for a, b, sa, sb in ((labels[:, 1:], labels[:, :-1], (slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                         (labels[1:], labels[:-1], (slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        touch = (a != b) & (a > 0) & (b > 0)
        if touch.any():
            pa, pb = a[touch].astype(np.int64), b[touch].astype(np.int64)
            keys.append(np.minimum(pa, pb) * (n + 1) + np.maximum(pa, pb))
            if top is not None:
                levels.append(np.minimum(top[sa][touch], top[sb][touch]))
    if not keys:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pair, where, width = np.unique(np.concatenate(keys), return_inverse=True, return_counts=True)
    # Each member's inscribed diameter: twice its largest distance to anything not itself.
    _, dist = (inside_distance or InsideDistance())(labels)
    diameter = 2.0 * (label_max(dist, labels, n) + 0.5)
    a, b = pair // (n + 1), pair % (n + 1)
    ratio = width / np.minimum(diameter[a], diameter[b])
    wide = ratio > NECK_SHARE
    if top is not None:
        peak = label_max(top, labels, n)
        saddle = label_max(np.concatenate(levels), where.reshape(-1), pair.size - 1, initial=-1.0)
        area = np.bincount(labels.ravel(), minlength=n + 1)
        chip = np.minimum(area[a], area[b]) <= CHIP_SHARE * np.maximum(area[a], area[b])
        # Both rules join pieces of large objects only (a piece CRACK_MIN_MM wide: both pieces for
        # the shading's rule, the larger one for a chip): small members are parted by their seeds.
        large = np.minimum(diameter[a], diameter[b]) >= large_px
        chip &= np.maximum(diameter[a], diameter[b]) >= large_px
        wide &= ((saddle >= NECK_SADDLE * np.minimum(peak[a], peak[b])) & large) | ((ratio > CRACK_SHARE) & chip)
    return a[wide], b[wide]


def border_levels(labels: np.ndarray, values: np.ndarray, n: int):
    """For each pair of labels that touch (4-connected): (first labels, second labels, the highest of
    min(values) over the pixel pairs joining them), or None when none touch. One sort over pair keys,
    not a loop over pixels."""
    keys, levels = [], []
    for a, b, va, vb in ((labels[:, 1:], labels[:, :-1], values[:, 1:], values[:, :-1]), (labels[1:], labels[:-1], values[1:], values[:-1])):
        touch = (a != b) & (a > 0) & (b > 0)
        if touch.any():
            pa, pb = a[touch].astype(np.int64), b[touch].astype(np.int64)
            keys.append(np.minimum(pa, pb) * (n + 1) + np.maximum(pa, pb))
            levels.append(np.minimum(va[touch], vb[touch]))
    if not keys:
        return None
    pair, where = np.unique(np.concatenate(keys), return_inverse=True)
    level = label_max(np.concatenate(levels), where.reshape(-1), pair.size - 1, initial=-1.0)
    return pair // (n + 1), pair % (n + 1), level


def merge_without_neck(labels: np.ndarray, top: np.ndarray | None = None, rounds: int = 1, *, large_px: float = 0.0,
                       inside_distance: InsideDistance | None = None) -> np.ndarray:
    """Members split where their outline has no neck (neckless_pairs) joined again, renumbered;
    again on the joined ones (a particle cracked in many pieces joins piece by piece), up to
    `rounds` times."""
    for _ in range(rounds):
        joined = _merge_once(labels, top, large_px, inside_distance=inside_distance)
        if joined is labels:
            break
        labels = joined
    return labels


def merge_across_no_neck(labels: np.ndarray) -> np.ndarray:
    """Touching members joined where the border between them is no neck of their joint outline:
    the joint foreground's half-width along the border (its distance transform, the most across
    the border) reaches OUTLINE_NECK of the narrower side's inscribed radius. A crack of shading
    through one object, or a chip of its rim, runs where the object is as wide as anywhere; two
    touching or sintered particles meet at a waist. Decided by the outline alone, not by shading."""
    n = int(labels.max())
    if n < 2:
        return labels
    dist = ndimage.distance_transform_edt(labels > 0).astype(np.float32)
    touching = border_levels(labels, dist, n)
    if touching is None:
        return labels
    a, b, across = touching
    radius = label_max(dist, labels, n)
    join = across >= OUTLINE_NECK * np.minimum(radius[a], radius[b])
    if not join.any():
        return labels
    roots = joined_roots(n, a[join].tolist(), b[join].tolist())
    return sequential_labels(roots[labels]).astype(labels.dtype)


def _merge_once(labels: np.ndarray, top: np.ndarray | None, large_px: float = 0.0, *,
                inside_distance: InsideDistance | None = None) -> np.ndarray:
    a, b = neckless_pairs(labels, top, large_px, inside_distance=inside_distance)
    if a.size == 0:
        return labels
    roots = joined_roots(int(labels.max()), a.tolist(), b.tolist())
    joined = sequential_labels(roots[labels]).astype(labels.dtype)
    if inside_distance is not None:  # the split asks for the joined members' next
        inside_distance.joined(labels, joined)
    return joined


def _filled(labels: np.ndarray) -> np.ndarray:
    """Fill each member's holes (SEM particles glow at their rims, so half their peak can be a
    ring): hole pixels go to the member around them. Only holes no larger than the member
    itself: a closed line around a wide cell is a line, not a particle."""
    holes, n = _holes(labels)
    if n == 0:
        return labels
    member_area = np.bincount(labels.ravel(), minlength=int(labels.max()) + 1)
    hole_area = np.bincount(holes.ravel(), minlength=n + 1)
    # A hole pixel's nearest member pixel borders the hole (the pixels nearer than it are all the
    # hole's, and one of them is its neighbour). So a hole bordered by one member only goes to
    # that member, whichever of its pixels is nearest: no distance transform needed.
    lowest, highest = _members_around(holes, labels, n)
    one = (lowest == highest) & (lowest > 0)
    fill = np.where(one & (hole_area <= member_area[lowest]), lowest, 0)
    fill[0] = 0
    out = np.where(fill[holes] > 0, fill[holes], labels).astype(labels.dtype, copy=False)
    if not one[1:].all():
        _fill_between(out, labels, holes, ~one, hole_area, member_area)
    return out


def _members_around(holes: np.ndarray, labels: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per hole 0..n: the lowest and highest label of the members beside it (4-neighbours)."""
    lowest = np.full(n + 1, np.iinfo(np.int64).max)
    highest = np.zeros(n + 1, np.int64)
    for hole, member in ((holes[1:], labels[:-1]), (holes[:-1], labels[1:]), (holes[:, 1:], labels[:, :-1]),
                         (holes[:, :-1], labels[:, 1:])):
        beside = (hole > 0) & (member > 0)
        np.minimum.at(lowest, hole[beside], member[beside].astype(np.int64))
        np.maximum.at(highest, hole[beside], member[beside].astype(np.int64))
    return np.where(highest > 0, lowest, 0), highest


def _fill_between(out: np.ndarray, labels: np.ndarray, holes: np.ndarray, which: np.ndarray, hole_area: np.ndarray,
                  member_area: np.ndarray) -> None:
    """Fill the holes `which` (bool per hole) bordered by several members, in `out`: each pixel to
    its nearest member (a distance transform of the hole's box, one pixel wider: the members
    around a hole border it there), when the hole is no larger than its last pixel's nearest."""
    n = which.size - 1
    # That member is one of those beside the last pixel (4-neighbours, one pixel away: the pixels
    # below and right of it are members). A hole larger than all of those is kept without asking which.
    inside = np.flatnonzero(holes)
    last = np.zeros(n + 1, np.intp)
    np.maximum.at(last, holes.ravel()[inside], inside)
    width = labels.shape[1]
    beside = labels.ravel()[last[1:, None] + np.array([-width, -1, 1, width])]
    largest = np.concatenate([[0], member_area[beside].max(axis=1, where=beside > 0, initial=0)])
    for k, box in enumerate(ndimage.find_objects(holes), 1):
        if box is None or not which[k] or hole_area[k] > largest[k]:
            continue
        box = tuple(slice(b.start - 1, b.stop + 1) for b in box)  # a hole never touches the picture's border
        window = labels[box]
        iy, ix = _nearest_in_window(window == 0)
        hole = holes[box] == k
        nearest = window[iy[hole], ix[hole]]
        if hole_area[k] <= member_area[nearest[-1]]:  # the member around it (its last pixel's nearest, as before)
            out[box][hole] = nearest


# Small holes between members (a pixel or a few where three basins meet) come in a few shapes: their
# boxes' nearest-member indices are remembered by the box's pattern of ground, up to this many pixels.
WINDOW_REMEMBERED_PX = 36
_window_nearest: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def _nearest_in_window(ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ndimage.distance_transform_edt(ground, return_distances=False, return_indices=True) of a
    small bool window; the same pattern's answer is computed once (read-only, shared)."""
    key = None
    if ground.size <= WINDOW_REMEMBERED_PX:
        key = (ground.shape, np.packbits(ground, axis=None).tobytes())
        known = _window_nearest.get(key)
        if known is not None:
            return known
    iy, ix = ndimage.distance_transform_edt(ground, return_distances=False, return_indices=True)
    if key is not None and len(_window_nearest) < 4096:  # at most 2^36 patterns exist; a few dozen occur
        iy.flags.writeable = ix.flags.writeable = False
        _window_nearest[key] = (iy, ix)
    return iy, ix


def _holes(labels: np.ndarray) -> tuple[np.ndarray, int]:
    """The holes of the members (ground not reached from the picture's border through ground,
    4-connected, as ndimage.binary_fill_holes): labelled (any numbering), and their count. One
    labelling of the ground, not a fill by repeated dilation and a labelling."""
    ground, open_ = ground_parts(labels == 0)
    if open_.size == 1:
        return ground, 0
    open_[0] = True
    if open_.all():
        return np.zeros_like(ground), 0
    renumber = np.cumsum(~open_) * ~open_
    return renumber[ground].astype(ground.dtype, copy=False), int(renumber.max())


def _split_touching(labels: np.ndarray, depth_px: float, *, inside_distance: InsideDistance | None = None) -> np.ndarray:
    """Split members whose tops merged (touching beads, both saturated) at their necks: a
    watershed of the distance to the outside, one basin per maximum `depth_px` above its neck.
    Only members holding two maxima or more are flooded (most hold one: nothing to split)."""
    if labels.max() == 0:
        return labels
    inside, dist = (inside_distance or InsideDistance())(labels)
    # sparse_h_maxima marks every second pixel of a plateau: a 3x3 dilation joins those marks again.
    marks = grown_marks(sparse_h_maxima(dist, max(depth_px, 0.5)))
    markers, n = ndimage.label(marks & inside)
    if n == 0:
        return labels
    # Members with two markers or more: the only ones a watershed can split.
    owner = np.zeros(n + 1, np.int64)
    owner[markers.ravel()] = labels.ravel()
    per_member = np.bincount(owner[1:], minlength=int(labels.max()) + 1)
    per_member[0] = 0
    several = per_member >= 2
    if not several.any():
        return labels
    split = several[labels]
    parts = segmentation.watershed(-dist, np.where(split, markers, 0), mask=split)
    # A new label for every (member, basin) pair; pixels no basin reached keep their member.
    pair = labels.astype(np.int64) * (n + 1) + parts
    out = dense_ranks(pair).astype(np.int32) + (0 if (labels == 0).any() else 1)  # ground is pair 0
    return np.where(labels > 0, out, 0)


def label_percentile(values: np.ndarray, labels: np.ndarray, n: int, *, pct: float) -> np.ndarray:
    val, starts, counts = sorted_by_label(values, labels, n)
    out = np.full(n, np.nan)
    has = counts > 0
    out[has] = val[starts[has] + ((counts[has] - 1) * pct / 100).astype(np.int64)]
    return out


def roundness(labels: np.ndarray, n: int) -> np.ndarray:
    """Minor over major axis of each label's second moments (index 0 = ground), in one pass."""
    rows, cols = np.nonzero(labels)
    lab = labels[rows, cols]
    count = np.maximum(np.bincount(lab, minlength=n + 1), 1)

    def mean(v):
        return np.bincount(lab, weights=v, minlength=n + 1) / count

    my, mx = mean(rows.astype(np.float64)), mean(cols.astype(np.float64))
    dy, dx = rows - my[lab], cols - mx[lab]
    syy, sxx, sxy = mean(dy * dy) + 1 / 12, mean(dx * dx) + 1 / 12, mean(dx * dy)
    root = np.sqrt(((syy - sxx) / 2) ** 2 + sxy**2)
    big, small = (syy + sxx) / 2 + root, (syy + sxx) / 2 - root
    return np.sqrt(np.maximum(small, 0) / np.maximum(big, 1e-12))
