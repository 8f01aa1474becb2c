"""Line networks (grain boundaries, membranes, diagram strokes) found and drawn as raised lines.

A ridge filter finds thin lines brighter than both sides (flip the picture first for dark
lines); its response is thresholded, thinned to a skeleton, and short loose pieces are dropped.
The network is drawn as lines LINE_WIDTH_MM wide (tactile graphics' standard line) on a flat
ground. Where two lines run closer than a finger can tell apart (MIN_GAP_MM between them), the
space they enclose is filled, so they read as one band, and the print width at which they would
come apart is reported.

Ridge filter chosen by measurement (the line pictures of benchmarks/bench_legibility.py at
Medium; recall = share of true line pixels within 1 mm of the skeleton, precision = share of the
skeleton within 1 mm of a true line; CPU time per picture):

| filter | synthetic network R / P | diagram R / P | confocal membranes R / P | ms |
|---|---|---|---|---|
| one-scale Hessian (default) | 1.00 / 1.00 | 1.00 / 1.00 | 0.98 / 0.68 | 11–14 |
| skimage sato, sigmas 0.4 and 0.8 mm | 1.00 / 1.00 | 1.00 / 0.93 | 0.98 / 0.68 | 18–508 |
| skimage meijering, same sigmas | 1.00 / 1.00 | 1.00 / 0.89 | 0.98 / 0.71 | 28–113 |
| narrow white top-hat | 1.00 / 1.00 | 1.00 / 0.97 | 0.97 / 0.80 | 9–17 |

The one-scale Hessian is Sato's measure at the one scale the print needs, written as three
Gaussian derivative filters: as good as sato and 2-40x cheaper. (The top-hat is as fast and more
precise on the membranes, but it answers on any narrow bright blob and closes 6 of the membranes'
cells where the Hessian closes 16.) None finds the Al2O3 grain boundaries on the print grid: a dark
core between bright rims, under a print pixel wide, which the grid's resampling and blur cancel.
`fine_lines` looks for them on a 0.1 mm grid made from the source before the blur (the same
Hessian at the boundaries' own width, a hysteresis threshold), and draws what it finds on the
working grid: there they enclose 140-160 regions and stand +0.96 mm over them (benchmark).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from skimage import filters, morphology

from .objects import label_max, label_median
from .population import label_percentile, noise_level
from .scales import disk

log = logging.getLogger(__name__)

LINE_WIDTH_MM = 1.2  # raised line width on the print (1.0–1.5 mm is the tactile standard)
LINE_HEIGHT_MM = 1.0  # raised line height (0.8–1.2 mm)
MIN_GAP_MM = 2.5  # lines closer than this (edge to edge) merge under a fingertip
MIN_PIECE_MM = 4.0  # loose line pieces shorter than this are noise or texture
RIDGE_SIGMAS_MM = (0.4, 0.8)
RIDGE_SIGMA_MM = 0.5  # the one scale of the default ridge measure (lines 0.5–2 mm wide on the print)
STEP_MARGIN = 0.02  # a line stands at least this far (0..1 of the range) above the brighter side of its band
FINE_PITCH_MM = 0.1  # lines too thin for the working grid are looked for on a grid this fine (or the source's, if coarser)
FINE_SIGMA_MM = 0.1  # the Hessian's scale there: a grain boundary's own width
FINE_LOW_MADS, FINE_HIGH_MADS = 4.0, 10.0  # the hysteresis threshold on the fine ridge response
MANY_PIECES = 200  # more kept pieces than this: their pixels found in one pass over the picture, not box by box
RIDGE_METHODS = ("hessian", "sato", "meijering", "tophat")
# A network on a textured ground (ssTEM membranes between grainy cytoplasm): its regions are at
# least this many times wider than its lines, measured in mm on the print. Gaps between lumps as
# wide as the lumps are no outlines (the ratio is about 1).
NETWORK_WIDTH_RATIO = 2.0
DENSE_GAP_MM = 1.0  # a dense network's region is filled only when narrower than this (a groove a finger still finds: grating threshold ≈ 0.9 mm)


@dataclass(frozen=True)
class Lines:
    """skeleton: (rows, cols) bool, one pixel wide; cells: (rows, cols) int32 labels of the regions
    the lines enclose (0 on the lines); cell_count: cells at least a fingertip's area;
    length_mm: total skeleton length; cover: share of the picture within half a line width of
    the skeleton; merged: bool mask of cells too narrow to feel (filled when drawn); separate_at:
    print-width factor at which 90 % of the cells become feelable (1 = they already are);
    traced: False for lines too weak to be a network (find_lines' min_strength), whose regions
    were not traced: no cells (cell_count 0, cells and merged all 0), separate_at 1."""

    skeleton: np.ndarray
    cells: np.ndarray
    cell_count: int
    length_mm: float
    cover: float
    merged: np.ndarray
    separate_at: float
    strength: float  # median ridge response on the skeleton over the response's noise (MAD)
    traced: bool = True


def ridge_response(bright01: np.ndarray, pitch_mm: float, method: str = "hessian") -> np.ndarray:
    """Ridge strength of lines brighter than both sides, 0 where there is none."""
    sigmas = [max(0.5, s / pitch_mm) for s in RIDGE_SIGMAS_MM]
    if method == "hessian":
        # Sato's measure at one scale: the Hessian's most negative eigenvalue (a bright line's
        # curvature across it), from three Gaussian derivative filters in float32.
        return hessian_ridges(bright01, pitch_mm)[0]
    if method == "sato":
        return filters.sato(bright01, sigmas=sigmas, black_ridges=False, mode="reflect")
    if method == "meijering":
        return filters.meijering(bright01, sigmas=sigmas, black_ridges=False, mode="reflect")
    if method == "tophat":
        size = max(3, int(round(3 * max(RIDGE_SIGMAS_MM) / pitch_mm)) | 1)
        return bright01 - ndimage.grey_opening(bright01, size=(size, size))
    raise ValueError(method)


def hessian_ridges(image01: np.ndarray, pitch_mm: float, sigma_mm: float = RIDGE_SIGMA_MM) -> tuple[np.ndarray, np.ndarray]:
    """The one-scale Hessian ridge response of a picture's bright lines and of its dark lines,
    from one set of derivative filters: the Hessian of 1 - image is minus the image's, so the
    dark lines' response is the largest eigenvalue where the bright lines' is minus the smallest."""
    sigma = max(0.7, sigma_mm / pitch_mm)
    img = image01.astype(np.float32)
    hyy = ndimage.gaussian_filter(img, sigma, order=(2, 0), mode="reflect")
    hxx = ndimage.gaussian_filter(img, sigma, order=(0, 2), mode="reflect")
    hxy = ndimage.gaussian_filter(img, sigma, order=(1, 1), mode="reflect")
    # In place, each step the same float32 operation as written out: (hyy + hxx) / 2 for the mean,
    # sqrt(((hyy - hxx) / 2) ** 2 + hxy * hxy) for the root (fewer fresh arrays on a fine grid).
    mean = hyy + hxx
    mean /= 2
    hyy -= hxx
    hyy /= 2
    root = np.square(hyy, out=hyy)
    root += np.square(hxy, out=hxy)
    np.sqrt(root, out=root)
    scale = np.float32(sigma * sigma)
    bright = np.maximum(root - mean, 0.0)
    bright *= scale
    mean += root
    dark = np.maximum(mean, 0.0, out=mean)
    dark *= scale
    return bright, dark


def find_lines(bright01: np.ndarray, *, pitch_mm: float, min_area_mm2: float = 6.0, method: str = "hessian",
               response: np.ndarray | None = None, noise: float | None = None, min_strength: float | None = None) -> Lines:
    """The line network of a 0..1 picture whose lines are bright (the working grid). `response`
    (the ridge response, from hessian_ridges) and `noise` (noise_level of the picture), when
    given, are not computed again: the content style asks for both polarities of one picture.
    Lines weaker than `min_strength` (if given) are returned untraced (Lines.traced)."""
    image = bright01.astype(np.float32)
    if response is None:
        response = ridge_response(image, pitch_mm, method)
    med = float(np.median(response))
    mad = float(np.median(np.abs(response - med))) * 1.4826 + 1e-9
    thresh = max(filters.threshold_otsu(response) if np.ptp(response) > 0 else np.inf, med + 3 * mad)
    # And above the picture's own noise: a ridge filter answers on pure noise too. (A hysteresis
    # threshold down to median + 3-20 MADs was measured too: it lifts the Al2O3 boundaries'
    # recall only from 0.14 to 0.20 and halves the membranes' precision, so a plain threshold.)
    thresh = max(thresh, 3 * (noise_level(image) if noise is None else noise))
    mask = response > thresh
    skeleton = morphology.skeletonize(mask)
    skeleton = _drop_short(skeleton, MIN_PIECE_MM / pitch_mm)
    skeleton = brighter_than_both_sides(skeleton, image, pitch_mm)
    on = response[skeleton]
    strength = float((np.median(on) - med) / mad) if on.size else 0.0
    if min_strength is not None and strength < min_strength:
        # Too weak to be a network whatever regions it encloses: they are not traced.
        nothing = np.zeros(skeleton.shape, np.int32)
        cover = float(_dilate(skeleton, LINE_WIDTH_MM / 2 / pitch_mm).mean())
        return Lines(skeleton, nothing, 0, float(skeleton.sum() * pitch_mm * 1.12), cover, nothing.astype(bool), 1.0, strength,
                     traced=False)
    return network_of(skeleton, pitch_mm=pitch_mm, min_area_mm2=min_area_mm2, strength=strength)


def network_of(skeleton: np.ndarray, *, pitch_mm: float, min_area_mm2: float, strength: float,
               min_gap_mm: float = MIN_GAP_MM) -> Lines:
    """The Lines of a skeleton on the working grid: the regions it encloses when drawn
    LINE_WIDTH_MM wide, those narrower than `min_gap_mm` (merged: filled when drawn) and the width
    at which they would be MIN_GAP_MM wide."""
    length_mm = float(skeleton.sum() * pitch_mm * 1.12)  # diagonal steps: ~1.12 px per pixel of skeleton
    half = LINE_WIDTH_MM / 2 / pitch_mm
    drawn = _dilate(skeleton, half)
    cells, _ = ndimage.label(~drawn)
    area = np.bincount(cells.ravel())
    area[0] = 0
    min_px = min_area_mm2 / pitch_mm**2
    count = int((area >= min_px).sum())
    # Inscribed radius of each cell: the deepest point of the distance to the lines.
    dist = ndimage.distance_transform_edt(~drawn)
    reach = label_max(dist, cells, area.size - 1)
    gap_mm = 2 * reach * pitch_mm
    narrow = (gap_mm < min_gap_mm) & (area > 0)
    narrow[0] = False
    merged = narrow[cells]
    cells_gap = np.sort(gap_mm[area > 0])
    separate_at = 1.0
    if cells_gap.size:
        # Scaling the print by k scales the distance between line centres (gap + line width)
        # but not the drawn width: the gap reaches MIN_GAP_MM at k = (MIN_GAP + w) / (gap + w).
        tenth = float(cells_gap[int(0.1 * (cells_gap.size - 1))])
        separate_at = max(1.0, (MIN_GAP_MM + LINE_WIDTH_MM) / (tenth + LINE_WIDTH_MM))
    return Lines(skeleton, cells.astype(np.int32), count, length_mm, float(drawn.mean()), merged, separate_at, strength)


@dataclass(frozen=True)
class NetworkWidths:
    """A thresholded ridge response read as a network: its lines' width and its regions' width
    (median inscribed diameter of the regions of at least a fingertip's area), in mm on the print;
    how many such regions, and the largest one's share of their area (a network tiles the picture)."""

    line_mm: float
    region_mm: float
    regions: int
    largest_share: float

    @property
    def ratio(self) -> float:
        return self.region_mm / self.line_mm if self.line_mm > 0 else 0.0


def network_widths(mask: np.ndarray, skeleton: np.ndarray, *, pitch_mm: float, min_area_mm2: float) -> NetworkWidths:
    """The widths of the lines `mask` (with its `skeleton`) and of the regions it leaves. (The
    lines' width is the response's, never much under the filter's scale: read from the picture
    instead, half-way between lines and regions, texture made it worse on the ssTEM section.)"""
    if not skeleton.any():
        return NetworkWidths(0.0, 0.0, 0, 1.0)
    line_mm = 2.0 * float(np.median(ndimage.distance_transform_edt(mask)[skeleton])) * pitch_mm
    regions, n = ndimage.label(~mask)
    area = np.bincount(regions.ravel())[1:]
    big = area * pitch_mm**2 >= min_area_mm2
    if not big.any():
        return NetworkWidths(line_mm, 0.0, 0, 1.0)
    reach = label_max(ndimage.distance_transform_edt(~mask), regions, n)[1:]
    region_mm = 2.0 * float(np.median(reach[big])) * pitch_mm
    return NetworkWidths(line_mm, region_mm, int(big.sum()), float(area.max() / area[big].sum()))


def textured_lines(response: np.ndarray, *, pitch_mm: float, min_area_mm2: float) -> tuple[Lines, NetworkWidths]:
    """The line network of a ridge response on a textured ground, with its widths. A dense
    network's lines are a large share of the picture, so the response's median and deviation
    (find_lines' strength) describe the lines themselves; Otsu of the response parts lines from
    regions instead, and the widths (network_widths) say whether it is a network. Regions are
    filled only under DENSE_GAP_MM: a dense network's cells are its meaning, not a band."""
    thresh = filters.threshold_otsu(response) if np.ptp(response) > 0 else np.inf
    mask = response > thresh
    skeleton = _in_loops(_drop_short(morphology.skeletonize(mask), MIN_PIECE_MM / pitch_mm))
    widths = network_widths(mask, skeleton, pitch_mm=pitch_mm, min_area_mm2=min_area_mm2)
    med = float(np.median(response))
    mad = float(np.median(np.abs(response - med))) * 1.4826 + 1e-9
    strength = float((np.median(response[skeleton]) - med) / mad) if skeleton.any() else 0.0
    lines = network_of(skeleton, pitch_mm=pitch_mm, min_area_mm2=min_area_mm2, strength=strength, min_gap_mm=DENSE_GAP_MM)
    return lines, widths


def fine_lines(fine01: np.ndarray, *, fine_pitch_mm: float, work_shape: tuple[int, int], pitch_mm: float,
               min_area_mm2: float, min_strength: float | None = None) -> dict[bool, Lines]:
    """Line networks found on a grid finer than the working grid (the source before the print
    grid's resampling and blur, which fade lines under a print pixel wide: the Al2O3 grain
    boundaries), drawn on the working grid; {True: bright lines, False: dark lines}. With
    `min_strength`, a polarity whose lines are weaker than that is left out (not drawn at all).

    The one-scale Hessian at FINE_SIGMA_MM (a boundary's own width), a hysteresis threshold in
    robust deviations of the response (FINE_LOW_MADS to FINE_HIGH_MADS: a line's faint stretches
    stay joined to its strong ones), pieces shorter than MIN_PIECE_MM dropped; each remaining
    fine pixel marks the working-grid pixel it falls in, and that mask is thinned to the skeleton
    the print draws LINE_WIDTH_MM wide."""
    ridges = hessian_ridges(fine01, fine_pitch_mm, FINE_SIGMA_MM)
    out = {}
    for bright, response in ((True, ridges[0]), (False, ridges[1])):
        fy, fx, strength = _fine_pieces(response, fine_pitch_mm)
        if min_strength is not None and strength < min_strength:
            log.debug("fine lines (%s): strength %.1f under %.1f, not drawn", "bright" if bright else "dark", strength, min_strength)
            continue
        rows, cols = response.shape
        coarse = np.zeros(work_shape, bool)
        coarse[np.rint(fy * ((work_shape[0] - 1) / max(rows - 1, 1))).astype(np.intp),
               np.rint(fx * ((work_shape[1] - 1) / max(cols - 1, 1))).astype(np.intp)] = True
        skeleton = _drop_short(morphology.skeletonize(coarse), MIN_PIECE_MM / pitch_mm)
        out[bright] = network_of(skeleton, pitch_mm=pitch_mm, min_area_mm2=min_area_mm2, strength=strength)
    return out


def _fine_pieces(response: np.ndarray, fine_pitch_mm: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Rows and columns of the fine grid's line pixels after the hysteresis threshold, and their
    median response in robust deviations over the grid's (the lines' strength)."""
    sample = response[::4, ::4]  # the median and deviation of a sixteenth: the same to 1 %, a fifth of the time
    med = float(np.median(sample))
    mad = float(np.median(np.abs(sample - med))) * 1.4826 + 1e-9
    # Hysteresis in one labelling: pieces above the low threshold that reach the high one
    # somewhere and span at least MIN_PIECE_MM (the larger side of their box stands for length).
    low = response > med + FINE_LOW_MADS * mad
    parts, n = ndimage.label(low, structure=np.ones((3, 3)))
    high = low & (response >= np.float64(med + FINE_HIGH_MADS * mad))
    fy, fx = _long_and_strong(parts, n, high, MIN_PIECE_MM / fine_pitch_mm)
    on = response[fy, fx]  # in the pieces' order, not the picture's: the same median
    strength = float((np.median(on) - med) / mad) if on.size else 0.0
    return fy, fx, strength


def _long_and_strong(parts: np.ndarray, n: int, high: np.ndarray, min_extent_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the pixels of the labelled pieces 1..n that hold a `high` pixel and
    whose box's larger side is at least `min_extent_px`. A piece's peak reaches the high threshold
    exactly when one of its pixels does (compared in float64, as its float64 maximum would be), so
    the labels are marked from the high pixels, and only those few boxes are measured and searched
    for their pixels (a tenth of the pieces; the picture is not scanned again)."""
    keep = np.zeros(n + 1, bool)
    keep[parts[high]] = True
    keep[0] = False
    boxes = ndimage.find_objects(parts)
    for label in np.flatnonzero(keep):
        box = boxes[label - 1]
        keep[label] = max(box[0].stop - box[0].start, box[1].stop - box[1].start) >= min_extent_px
    kept = np.flatnonzero(keep)
    if len(kept) > MANY_PIECES:
        return np.nonzero(keep[parts])
    rows, cols = [np.zeros(0, np.intp)], [np.zeros(0, np.intp)]
    for label in kept:
        box = boxes[label - 1]
        y, x = np.nonzero(parts[box] == label)
        rows.append(y + box[0].start)
        cols.append(x + box[1].start)
    return np.concatenate(rows), np.concatenate(cols)


def draw_lines(lines: Lines, pitch_mm: float) -> np.ndarray:
    """0..1 profile: 1 on lines LINE_WIDTH_MM wide with rounded shoulders, and on merged cells."""
    half = LINE_WIDTH_MM / 2 / pitch_mm
    dist = ndimage.distance_transform_edt(~lines.skeleton)
    # Flat top a nozzle or so wide, then a quarter-round shoulder to the ground.
    t = np.clip((half + 0.5 - dist) / max(half, 1.0), 0.0, 1.0)
    profile = np.sqrt(1.0 - (1.0 - t) ** 2)
    return np.maximum(profile, lines.merged.astype(np.float32)).astype(np.float32)


def brighter_than_both_sides(skeleton: np.ndarray, image: np.ndarray, pitch_mm: float) -> np.ndarray:
    """Keep skeleton pieces that are lines, not step edges: along a line the ground is darker on
    both sides, so even the brighter side of the band 0.8–1.6 mm away (its 80th percentile) stays
    below the line; beside a step edge one side is as bright as the edge itself."""
    parts, n = ndimage.label(skeleton, structure=np.ones((3, 3)))
    if n == 0:
        return skeleton
    dist, (iy, ix) = ndimage.distance_transform_edt(~skeleton, return_indices=True)
    dist_mm = dist * pitch_mm
    band = (dist_mm >= 0.8) & (dist_mm <= 1.6)
    owner = np.zeros_like(parts)
    owner[band] = parts[iy[band], ix[band]]  # the nearest piece looked up in the band only
    on = label_median(image, parts, n)
    side = label_percentile(image, owner, n, pct=80)
    keep = np.concatenate([[False], ~(side >= on - STEP_MARGIN)])  # NaN side (no band): keep
    return keep[parts]


def _in_loops(skeleton: np.ndarray) -> np.ndarray:
    """Skeleton pieces that close at least one loop (Euler number under 1) or run to the picture's
    edge (closed by the frame): a network's lines enclose regions, a texture's loose twigs do not."""
    from skimage.measure import regionprops

    parts, n = ndimage.label(skeleton, structure=np.ones((3, 3)))
    if n == 0:
        return skeleton
    keep = np.zeros(n + 1, bool)
    for props in regionprops(parts):
        keep[props.label] = props.euler_number < 1
    edge = np.concatenate([parts[0], parts[-1], parts[:, 0], parts[:, -1]])
    keep[edge] = True
    keep[0] = False
    return keep[parts]


def _drop_short(skeleton: np.ndarray, min_px: float) -> np.ndarray:
    parts, n = ndimage.label(skeleton, structure=np.ones((3, 3)))
    if n == 0:
        return skeleton
    size = np.bincount(parts.ravel())
    keep = size >= min_px
    keep[0] = False
    return keep[parts]


def _dilate(mask: np.ndarray, radius_px: float) -> np.ndarray:
    if radius_px < 0.5:
        return mask
    return ndimage.binary_dilation(mask, structure=disk(radius_px))
