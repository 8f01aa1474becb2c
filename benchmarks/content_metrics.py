"""Content measures of a relief against a picture's truth (issue 26), all in mm on the print.

- members felt: share of true members whose top (95th percentile of heights) stands at least
  0.5 mm over the median of a 1.5 mm ring around it (ring pixels go to their nearest member).
- lines − enclosed: median height on the true lines minus the median of the areas they enclose
  (pixels over 1 mm from any true line).
- lattice modulation: 95th minus 5th percentile of the heights (away from a 5 mm border).
- grain relief: over neighbouring true grains, the larger of the median height step between
  them and the rise of their shared boundary (1 px band) over their interiors.
- spurious: raised regions (over 0.5 mm above the base, at least 2 mm²) touching no true
  content (members, lines, grains dilated by 1 mm): mesas a finger finds where there is nothing.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

FELT_MM = 0.5
RING_MM = 1.5


def members_felt(h: np.ndarray, labels: np.ndarray, mm: float) -> float:
    felt, present = members_felt_each(h, labels, mm)
    return float(np.mean(felt[present])) if present.any() else float("nan")


def members_felt_each(h: np.ndarray, labels: np.ndarray, mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Per true member (1..n): whether it is felt (see the module's note), and whether it has
    pixels on this grid at all (a member the resampling lost is neither counted nor felt)."""
    n = int(labels.max())
    if n == 0:
        return np.zeros(0, bool), np.zeros(0, bool)
    mask = labels > 0
    dist, (iy, ix) = ndimage.distance_transform_edt(~mask, return_indices=True)
    owner = np.where((~mask) & (dist * mm <= RING_MM), labels[iy, ix], 0)
    index = np.arange(1, n + 1)
    top = np.asarray(ndimage.labeled_comprehension(h, labels, index, lambda v: np.percentile(v, 95), float, np.nan))
    ring = np.asarray(ndimage.median(h, owner, index), dtype=np.float64)
    ring = np.where(np.isfinite(ring), ring, np.median(h[~mask]))
    ok = np.isfinite(top)
    return ok & ((np.where(ok, top, 0) - ring) >= FELT_MM), ok


def lines_over_enclosed(h: np.ndarray, lines: np.ndarray, mm: float) -> float:
    if not lines.any():
        return float("nan")
    far = ndimage.distance_transform_edt(~lines) * mm > 1.0
    return float(np.median(h[lines]) - np.median(h[far]))


def lattice_modulation(h: np.ndarray, mm: float) -> float:
    b = int(round(5 / mm))
    inner = h[b:-b, b:-b] if min(h.shape) > 2 * b + 4 else h
    return float(np.percentile(inner, 95) - np.percentile(inner, 5))


def grain_relief(h: np.ndarray, grains: np.ndarray, mm: float) -> float:
    n = int(grains.max())
    if n < 2:
        return float("nan")
    med = np.asarray(ndimage.median(h, grains, np.arange(n + 1)), dtype=np.float64)
    pairs = set()
    band = np.zeros(h.shape, bool)
    for a, b, sl_a, sl_b in ((grains[:, 1:], grains[:, :-1], (slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                             (grains[1:], grains[:-1], (slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        differ = (a != b) & (a > 0) & (b > 0)
        pairs |= set(zip(a[differ].tolist(), b[differ].tolist()))
        band[sl_a] |= differ
        band[sl_b] |= differ
    if not pairs:
        return float("nan")
    steps = np.median([abs(med[a] - med[b]) for a, b in pairs])
    interior = (grains > 0) & (ndimage.distance_transform_edt(~band) * mm > 1.5)
    rise = np.median(h[band]) - np.median(h[interior]) if interior.any() else 0.0
    return float(max(steps, rise))


def spurious(h: np.ndarray, content: np.ndarray | None, mm: float, base_mm: float) -> int:
    if content is None:
        return -1
    raised, n = ndimage.label(h - base_mm > FELT_MM)
    if n == 0:
        return 0
    near = ndimage.binary_dilation(content, iterations=max(1, round(1 / mm)))
    area = np.bincount(raised.ravel()) * mm * mm
    touches = np.zeros(n + 1, bool)
    touches[raised[near]] = True
    bad = (~touches) & (area >= 2.0)
    bad[0] = False
    return int(bad.sum())


def members_split(made: np.ndarray | None, labels: np.ndarray) -> tuple[np.ndarray, int]:
    """Per true member, whether the relief split it: (bool per member 1..n, true members the relief
    joined into one). The relief's members (`made`, labels on the same grid) that lie mostly in a
    true member (at least OVERLAP_SHARE of the relief member, or of the true member) are its pieces;
    the true member's pixels go to their nearest piece, and it is split when two pieces share a
    border wider than the smaller one's inscribed diameter (population.neckless_pairs: no neck in
    its outline there). A cut through a real neck of the true outline is no split: a truth mask
    that joins touching members (the HAADF spheres' Otsu clusters) is then a merge of truth, and
    the pieces' count says so (`joined`: true members with more than one piece, all at necks)."""
    from skimage import segmentation

    from tamp_os.relief.population import neckless_pairs

    n = int(labels.max())
    split = np.zeros(n, bool)
    if made is None or n == 0 or not made.max():
        return split, 0
    mask = labels > 0
    # The true member each relief member mostly lies in, and how much of each they share.
    pair = labels[mask].astype(np.int64) * (int(made.max()) + 1) + made[mask]
    keys, shared = np.unique(pair[made[mask] > 0], return_counts=True)
    truth_of, piece = keys // (int(made.max()) + 1), keys % (int(made.max()) + 1)
    made_area = np.bincount(made.ravel(), minlength=int(made.max()) + 1)
    true_area = np.bincount(labels.ravel(), minlength=n + 1)
    ok = (shared >= OVERLAP_SHARE * made_area[piece]) | (shared >= OVERLAP_SHARE * true_area[truth_of])
    ok &= shared >= 2
    joined = 0
    for k in np.unique(truth_of[ok]):
        pieces = piece[ok & (truth_of == k)]
        if pieces.size < 2:
            continue
        sl = ndimage.find_objects((labels == k).astype(np.int32))[0]
        sl = tuple(slice(max(0, s.start - 1), s.stop + 1) for s in sl)
        inside = labels[sl] == k
        seeds = np.where(inside & np.isin(made[sl], pieces), made[sl], 0)
        parts = np.where(inside, segmentation.expand_labels(seeds, distance=max(seeds.shape)), 0)
        parts = segmentation.relabel_sequential(parts)[0].astype(np.int32)
        a, _ = neckless_pairs(parts)
        split[k - 1] = a.size > 0
        joined += a.size == 0
    return split, joined


OVERLAP_SHARE = 0.5


def membranes_on_plate(h: np.ndarray, membranes: np.ndarray, mm: float, exclude: np.ndarray | None = None) -> tuple[float, float]:
    """A source-resolution membrane mask (True = membrane) against plate heights `h` (pitch `mm`):
    (median height on the membranes' centre lines minus the median of the cell interiors, share of
    the centre lines' length raised ≥ FELT_MM over the interiors and on the largest connected
    raised piece). The centre lines are the mask's skeleton, each point mapped to the plate pixel
    it falls in; interiors are plate pixels over 1 mm from any membrane (and off `exclude`,
    e.g. mitochondria, same grid as the mask)."""
    from skimage import morphology

    rows, cols = h.shape
    sy, sx = (rows - 1) / max(membranes.shape[0] - 1, 1), (cols - 1) / max(membranes.shape[1] - 1, 1)
    y, x = np.nonzero(morphology.skeletonize(membranes))
    centre = np.zeros(h.shape, bool)
    centre[np.rint(y * sy).astype(int), np.rint(x * sx).astype(int)] = True
    y, x = np.nonzero(membranes | (exclude if exclude is not None else False))
    near = np.zeros(h.shape, bool)
    near[np.rint(y * sy).astype(int), np.rint(x * sx).astype(int)] = True
    interior = ndimage.distance_transform_edt(~near) * mm > 1.0
    ground = float(np.median(h[interior]))
    raised = h >= ground + FELT_MM
    pieces, n = ndimage.label(raised, structure=np.ones((3, 3)))
    counts = np.bincount(pieces[centre], minlength=2)[1:]
    connected = float(counts.max() / centre.sum()) if n and centre.any() else 0.0
    return float(np.median(h[centre])) - ground, connected
