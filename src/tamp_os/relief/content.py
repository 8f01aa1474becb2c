"""The `content` relief style: translate what the picture shows, not its brightness (issue 26).

Tactile graphics encode a picture: points and particles as domes, outlines as raised lines,
empty space as the ground. This style reads the picture on the working grid and decides:

1. polarity: the detector first (SE, BSE and STEM show matter bright, bright field dark: from the
   file's metadata or its data band's words); else the ground is the most common brightness (the
   histogram's mode at fingertip scale); whichever side of it holds more of the picture's
   deviation is the content (bright beads on black fluorescence, dark strokes on white paper);
   the ground goes to the base. Where that brightness leaves it open (a mid-grey ground, or an
   "empty" bright one that may be flat members), the side whose pieces are compact and convex is
   raised, not the concave shards between them (side_shapes: cells packed on a filter).
2. a line network (ridge filter, skeleton) that encloses at least NETWORK_CELLS regions: raised
   lines LINE_WIDTH_MM wide and LINE_HEIGHT_MM high on a flat ground (lines.py);
3. else a population (local-contrast members, population.py, or the edge-enclosed objects the
   other styles find when they are too large for a local background): every member a dome of
   the same full lift, touching members apart by a groove, small ones drawn at a feelable size
   when few;
4. else a line network too thin for the working grid, found on a finer grid made from the
   source before the print grid's blur (lines.fine_lines), when its regions tile the picture;
5. else weak contrast: the specimen is found against an empty mount, its contrast is equalised
   locally (CLAHE over a tenth of the field) and its grains are outlined by raised lines when
   their boundaries form a network; anything else gets the structure style's shape.

A lattice or grating is recognised by its spectrum's peak and named with its pitch on the print.
Every decision is written into the reason with the measured facts, and `check_sentences` compares
the print with what was found ("found 10 members, all raised at least 1.0 mm").
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.fft
from scipy import ndimage
from skimage import exposure, filters, morphology, segmentation

from ..clean.instrument import matter_is_bright
from ..errors import Decision
from .lines import (
    FINE_PITCH_MM,
    LINE_HEIGHT_MM,
    LINE_WIDTH_MM,
    MIN_GAP_MM,
    NETWORK_WIDTH_RATIO,
    Lines,
    NetworkWidths,
    brighter_than_both_sides,
    draw_lines,
    find_lines,
    fine_lines,
    hessian_ridges,
    textured_lines,
)
from .dense import BlobScale, blob_scale, scale_stack
from .extrema import h_maxima
from .objects import InsideDistance, ObjectMap, dome_profile, label_max, label_median, nearest_member, sequential_labels
from .scales import wide_gaussian
from .population import (
    BACKGROUND_MM,
    Members,
    neckless_pairs,
    roundness,
    find_members,
    local_tophat,
    noise_level,
)

log = logging.getLogger(__name__)

NETWORK_CELLS = 3  # a line network encloses at least this many fingertip-sized regions
LINE_ART_MM = 40.0  # strokes on empty paper this long in all (on the print) are a drawing to raise as lines
NETWORK_STRENGTH = 20.0  # median ridge response on the lines over its MAD: measured 45-240 on networks, 7 on SEM sphere rims
FINE_NETWORK_CELLS = 10  # a network found on the fine grid encloses at least this many regions
FINE_STRENGTH = 8.0  # and its lines' median response stands this many robust deviations above the fine grid's
FINE_MAX_CELL_SHARE = 0.15  # and no region holds more of the enclosed area than this (a network tiles the picture)
MAX_LINE_COVER = 0.45  # drawn lines covering more than this are no network but a texture
MIN_MEMBERS = 2
POPULATION_ENERGY = 0.6
POPULATION_ROUNDNESS = 0.7
POPULATION_SPREAD = 2.5
FELT_MM = 0.5  # a member stands this far above the ground around it to be felt (the check's measure)
MIN_FELT_MM = 2.0  # members narrower than this are drawn this wide when few
FEW_MEMBERS = 60
DENSE_COVER = 0.4  # more members than FEW_MEMBERS covering this share: a dense field (SEM particle layers), measured 0.48 on SiO2 35kx, 0.33 on the STEM spheres (all found)
DENSE_OVER_MEMBERS = 1.5  # a dense field with this many times more blobs than members found is raised as a field
DENSE_TOPHAT_WIDTHS = 2.5  # a dense field's local ground: a square this many members wide (swept 1.5-3: 96-90 % felt on 10kx, 5-0 spurious)
DENSE_LIFT_PCT = 80.0  # its top-hat's scale: this percentile (swept 60-99, clip or tanh, on the 10kx field: 88-93 % felt)
MIN_PITCH_MM = 2.5  # a lattice finer than this on the print is felt as roughness
# A lattice (issue 32): its spectrum is a few sharp peaks (PEAK_BINS frequencies hold PEAK_SHARE of
# the detail's power; particle fields and noisy textures 0.14-0.28, dot lattices and gratings
# 0.9-1.0), in two directions at least LATTICE_ANGLE_DEG apart (a grating has one), repeating at
# least MIN_REPEATS times across the picture. It is raised column by column, evenly.
PEAK_BINS = 24
PEAK_SHARE = 0.5
MIN_REPEATS = 12
LATTICE_ANGLE_DEG = 30.0
SECOND_PEAK = 0.15  # the other direction's peak holds at least this share of the strongest one's power
MIN_COLUMN_PX = 3.0  # columns closer than this many working-grid points cannot be printed apart (a dome and a trough)
COLUMN_SHARE = 0.6  # a column's dome spans this share of the spacing between columns
COLUMN_CONTRAST = 0.25  # a local maximum is a column when it stands this share of a typical column's contrast over its troughs
MIN_COLUMNS = 20  # fewer columns found than this: no lattice to raise
LAYER_SEPARATION = 4.0  # two layers: the columns' brightness falls in two groups this many robust deviations apart
LAYER_COHERENCE = 0.8  # and this share of each column's nearest neighbours lie in its own group (a layer, not alternation)
LAYER_SHARE = 0.1  # and the smaller group holds at least this share of the columns
LAYER_CONTRAST = 0.3  # and the groups differ by at least this share of a column's contrast over the ground
MEMBER_ROUND_MM = 10.0  # dome shoulders (as the objects style); wider members get rounded plateaus
PIN_ASPECT = 2.0  # a member's dome stands at most this many times its inscribed radius (no pins)
EMPTY_GROUND_SHARE = 0.5  # a bright ground this share of the picture lies within 0.06 of is empty (paper, brightfield)
ELECTRON_EMPTY_SHARE = 0.8  # with an electron signal, only a bright ground this empty is the ground
# A specimen whose 5th-95th percentiles span less than this (beside a mount) has weak contrast. Not
# the 1st-99th: a polished alloy's carbides and twin lines (2 % of it, dark and bright) span the
# range while its grains differ by 10-20 grey levels.
WEAK_SPREAD = 0.3
MERGED_SAID_SHARE = 0.01  # the space filled between close lines is said from this share of the picture
GRAIN_LEVELS = 3  # weak-contrast grains become at most this many plateaus
GRAIN_STEP_MM = 0.5  # and the plateaus stand at least this far apart (a step fingers tell apart)
# Grains are structure above the noise: inside the specimen (1.5 mm in from its edge, so its own
# step is not counted), the fingertip-scale variation (a 1 mm blur) must stand this many times over
# the pixel noise (faint grains 3 % apart: 11-30x; a TEM ground of shot noise beside a needle:
# 1.7-1.9x; a flat plateau: no variation at all).
GRAIN_OVER_NOISE = 4.0
EMPTY_MOUNT_SHARE = 0.05  # a dark, featureless area covering at least this share is the mount
SCATTERED_PIECES = 5  # a "specimen" in this many pieces, none holding half of it, is a population on a ground
# Which side is members by shape (issue 53, class 1), when neither the detector nor the ground's
# brightness says. Each side (Otsu at fingertip scale), opened by COMPACT_OPEN_MM so strands and
# slits drop out, is parted at its necks (watershed of its distance); a piece's compactness is the
# diameter of its inscribed circle over its length (major axis): a disc 1, the curvilinear
# triangle between three touching discs about 0.4. Measured on a COMPACT_PITCH_MM grid (the
# picture before the print grid's blur), where the gaps' cusps survive: backscatter cells on a
# filter 0.87-0.96 against their gaps' 0.63-0.67; dark cells on glass 0.97 against the glass's
# 0.75; on the real development files whose ground is mid-grey or empty the sides differ by 0.08
# at most, or one side is thin lines (the Al2O3 grain boundaries: 1 % of the picture), so none is
# decided by shape.
COMPACT_PITCH_MM = 0.2
COMPACT_OPEN_MM = 1.0
COMPACT_MIN_MM2 = 2.0  # pieces smaller than this are specks, not members
COMPACT_SHAPE = 0.85  # the members' side is at least this compact
COMPACT_MARGIN = 0.2  # and this much more compact than the other side
COMPACT_SIDE_SHARE = 0.1  # both sides cover this share after the opening: the gaps are areas, not lines (grain boundaries)


@dataclass(frozen=True)
class ContentHints:
    """File metadata that informs the translation (each None when the file does not say).

    detector : the detector's name as the file gives it ("HE-SE2", "ETD", "HAADF").
    signal : "SE", "BSE" or "STEM": electron images, whose ground is dark unless it is empty and bright;
        "BF": bright field, whose matter is dark (from the file's metadata or its data band's words).
    """

    detector: str | None = None
    signal: str | None = None

    def words(self) -> str:
        parts = []
        if self.detector:
            parts.append(f"detector {self.detector}")
        if self.signal:
            parts.append(f"{self.signal} signal")
        return ", ".join(parts)


@dataclass(frozen=True)
class Polarity:
    bright: bool  # content brighter than the ground
    ground: float  # the ground's brightness, 0..1
    reason: str
    undecided: bool = False  # a mid-grey ground: the members' evidence may turn it over
    empty: bool = False  # an empty bright ground (paper, brightfield): strokes on it are line art
    settled: bool = False  # decided by the members' shape (side_shapes): no later rule turns it over

    def flipped(self, why: str) -> "Polarity":
        side = "bright" if not self.bright else "dark"
        return Polarity(not self.bright, self.ground,
                        f"the ground is mid-grey ({self.ground:.2f} of the range) and {why}, so the {side} parts are raised")


@dataclass(frozen=True)
class Period:
    pitch_mm: float  # period on the print
    share: float  # share of the detail's power in the spectrum's peak


@dataclass(frozen=True)
class Spectrum:
    """The detail's spectrum (lattice_spectrum): its strongest period, if it holds a clear share
    of the detail's power; `peaked`: the share the PEAK_BINS strongest frequencies hold; `two_way`:
    a second strong peak in a direction at least LATTICE_ANGLE_DEG away (a 2-D lattice)."""

    period: Period | None
    peaked: float
    two_way: bool


@dataclass(frozen=True)
class LatticeFound:
    """A lattice raised column by column: `columns` raised, `spacing_mm` apart on the print (median
    nearest neighbour); `picture_columns` the columns the picture shows at its own finest spacing
    `picture_spacing_mm` (more than `columns` when those are too close to print apart and only the
    brighter ones were raised); `layers` (1, or 2 when a brighter layer stands a step higher),
    `upper` the columns of the brighter layer, `step_mm` its step; `drawn` False when no column
    could be printed apart (the lattice is then one flat plateau)."""

    columns: int
    spacing_mm: float
    picture_columns: int
    picture_spacing_mm: float
    layers: int = 1
    upper: int = 0
    step_mm: float = 0.0
    drawn: bool = True
    dome_mm: float = 0.0  # each column's dome height over its ground (the plateau under a brighter layer)


@dataclass(frozen=True)
class ContentMade:
    """What the content style made: relief01 on the working grid (0..1 of the relief; lines stop
    at LINE_HEIGHT_MM / relief), the kind ('lines', 'members', 'grains', 'plateau', 'shape'), labels of the
    members (or None), the reason (facts), and check sentences."""

    relief01: np.ndarray
    kind: str
    labels: np.ndarray | None
    reason: str
    notes: tuple[str, ...]
    line_mask: np.ndarray | None = None
    levels: int = 0  # grains as plateaus: how many grey levels
    lattice: LatticeFound | None = None  # kind 'lattice': what was raised
    split_pairs: int = 0  # touching members with neither a neck nor a groove of shading between them (one object split?)


def content_polarity(work: np.ndarray, pitch_mm: float, within: np.ndarray | None = None, *, signal: str | None = None) -> Polarity:
    """Which side of the ground carries the content (see the module's note 1).

    Dark ground is the rule for SEM, dark field and fluorescence; a bright ground must be empty
    (brightfield, paper): the mode is bright and at least EMPTY_GROUND_SHARE of the picture lies
    within 0.06 of it. A particle field whose particles cover most of it has a bright mode too,
    but a broad one. Between the two, the side holding more deviation from the mode wins. With an
    electron signal (SE, BSE, STEM) from the file, the ground is dark unless it is plainly empty
    and bright (ELECTRON_EMPTY_SHARE within 0.06 of a bright mode, as a bright-field image); with a
    bright-field signal (BF) the matter is dark unless the ground is plainly empty and dark.
    """
    smooth = ndimage.gaussian_filter(work.astype(np.float32), max(0.5, 0.5 / pitch_mm), mode="nearest")
    values = smooth[within] if within is not None and within.any() else smooth.ravel()
    counts, edges = np.histogram(values, bins=64, range=(0.0, 1.0))
    counts = np.convolve(counts, np.ones(3) / 3, mode="same")
    mode = float((edges[:-1] + edges[1:])[int(np.argmax(counts))] / 2)
    near = float(np.mean(np.abs(values - mode) < 0.06))
    up = float(np.mean(np.clip(values - mode, 0, None)))
    down = float(np.mean(np.clip(mode - values, 0, None)))
    matter = matter_is_bright(signal)
    if matter and not (mode >= 0.6 and near >= ELECTRON_EMPTY_SHARE):
        bright, why = True, f"the file's {signal} signal: electron images have a dark ground"
    elif matter is False and not (mode <= 0.4 and near >= ELECTRON_EMPTY_SHARE):
        bright, why = False, f"the file's {signal} signal: in bright-field images matter is dark"
    elif mode >= 0.6:
        bright = near < EMPTY_GROUND_SHARE
        why = (f"an empty bright ground ({near:.0%} of the picture within 0.06 of it)" if not bright
               else f"bright but not empty (only {near:.0%} of the picture within 0.06 of it: a field of bright members)")
    elif mode <= 0.4:
        bright, why = True, "dark"
    else:
        bright = up >= down
        why = f"mid-grey, with more of the picture {'above' if bright else 'below'} it ({max(up, down):.3f} against {min(up, down):.3f})"
        reason = (f"the ground is the most common brightness ({mode:.2f} of the range: {why}), so the "
                  f"{'bright' if bright else 'dark'} parts are raised and the ground sits at the base")
        return Polarity(bright, mode, reason, undecided=True)
    reason = (f"the ground is the most common brightness ({mode:.2f} of the range: {why}), so the "
              f"{'bright' if bright else 'dark'} parts are raised and the ground sits at the base")
    return Polarity(bright, mode, reason, empty=mode >= 0.6 and not bright)


@dataclass(frozen=True)
class SideShapes:
    """How compact each side's pieces are (side_shapes): the area-weighted median compactness of
    the bright side's and the dark side's pieces (nan when a side has none), the share of the
    picture each side covers after the opening, and each side's pieces (labels on the grid they
    were measured on)."""

    bright: float
    dark: float
    bright_share: float
    dark_share: float
    bright_pieces: np.ndarray | None = field(repr=False, compare=False, default=None)
    dark_pieces: np.ndarray | None = field(repr=False, compare=False, default=None)

    @property
    def members_bright(self) -> bool | None:
        """True when the bright side's pieces are the compact members and the dark side's the concave
        gaps between them (COMPACT_SHAPE, COMPACT_MARGIN, both sides COMPACT_SIDE_SHARE), False the
        other way round, None when the shapes do not say."""
        if min(self.bright_share, self.dark_share) < COMPACT_SIDE_SHARE or not np.isfinite([self.bright, self.dark]).all():
            return None
        for bright, (this, other) in ((True, (self.bright, self.dark)), (False, (self.dark, self.bright))):
            if this >= COMPACT_SHAPE and this - other >= COMPACT_MARGIN:
                return bright
        return None

    def words(self) -> str:
        side, other = ("bright", "dark") if self.members_bright else ("dark", "bright")
        this, that = (self.bright, self.dark) if self.members_bright else (self.dark, self.bright)
        return (f"the {side} side's pieces are compact and convex (inscribed circle {this:.2f} of their length; a disc is 1) and "
                f"the {other} side's are concave shards between them ({that:.2f})")

    def members(self, bright: bool, shape: tuple[int, int]) -> np.ndarray | None:
        """The compact side's pieces as members on a grid of `shape` (nearest), when that side is
        `bright`'s and the shapes say so; else None."""
        if self.members_bright is not bright:
            return None
        pieces = self.bright_pieces if bright else self.dark_pieces
        rows = np.linspace(0, pieces.shape[0] - 1, shape[0]).round().astype(int)
        cols = np.linspace(0, pieces.shape[1] - 1, shape[1]).round().astype(int)
        return sequential_labels(pieces[rows][:, cols]).astype(np.int32)


def side_shapes(picture: np.ndarray, pitch_mm: float) -> SideShapes | None:
    """The compactness of the bright and the dark side's pieces at fingertip scale (see
    COMPACT_PITCH_MM), or None for a flat picture."""
    smooth = ndimage.gaussian_filter(picture.astype(np.float32), max(0.5, 0.5 / pitch_mm), mode="nearest")
    if np.ptp(smooth) < 0.05:
        return None
    bright = smooth > filters.threshold_otsu(smooth)
    radius_px = max(1, round(COMPACT_OPEN_MM / 2 / pitch_mm))
    disk = morphology.disk(radius_px)
    (b, b_share, b_pieces), (d, d_share, d_pieces) = [
        _pieces_compactness(ndimage.binary_opening(phase, structure=disk), pitch_mm, radius_px) for phase in (bright, ~bright)]
    return SideShapes(b, d, b_share, d_share, b_pieces, d_pieces)


def _pieces_compactness(phase: np.ndarray, pitch_mm: float, radius_px: int) -> tuple[float, float, np.ndarray]:
    """(area-weighted median compactness of the pieces, the share of the picture the side covers,
    the pieces' labels) of one side: parted at its necks by a watershed of its distance from peaks
    1 mm apart (a shard has one, a chain of touching discs one per disc); pieces under
    COMPACT_MIN_MM2 left out. A piece's length is its major axis (four standard deviations along
    its long direction: a disc's diameter), from its moments in one pass over all pieces."""
    from skimage.feature import peak_local_max

    share = float(phase.mean())
    dist = ndimage.distance_transform_edt(phase)
    # Peaks over the whole side at once (per component, peak_local_max loops: 1 s for 1600 dots).
    peaks = peak_local_max(dist, min_distance=max(1, round(1.0 / pitch_mm)), threshold_abs=radius_px, exclude_border=False)
    pieces = np.zeros(phase.shape, np.int32)
    if len(peaks) == 0:
        return float("nan"), share, pieces
    pieces[tuple(peaks.T)] = np.arange(1, len(peaks) + 1)
    pieces = segmentation.watershed(-dist, pieces, mask=phase).astype(np.int32)
    area = np.bincount(pieces.ravel(), minlength=len(peaks) + 1).astype(np.float64)
    keep = area * pitch_mm**2 >= COMPACT_MIN_MM2
    keep[0] = False
    pieces = np.where(keep[pieces], pieces, 0)
    if not keep.any():
        return float("nan"), share, pieces
    inscribed = label_max(dist, pieces, len(peaks), initial=0.0)
    compact = np.minimum(1.0, 2.0 * inscribed / np.maximum(_major_axis_px(pieces, len(peaks)), 1.0))[keep]
    order = np.argsort(compact)
    half = int(np.searchsorted(np.cumsum(area[keep][order]), 0.5 * area[keep].sum()))
    return float(compact[order][min(half, order.size - 1)]), share, sequential_labels(pieces).astype(np.int32)


def _major_axis_px(labels: np.ndarray, count: int) -> np.ndarray:
    """Per label 0..count: four standard deviations along its longest direction (a disc's diameter)."""
    ys, xs = np.nonzero(labels)
    ids = labels[ys, xs]
    n = np.maximum(np.bincount(ids, minlength=count + 1), 1).astype(np.float64)
    my, mx = np.bincount(ids, ys, count + 1) / n, np.bincount(ids, xs, count + 1) / n
    dy, dx = ys - my[ids], xs - mx[ids]
    syy, sxx, sxy = (np.bincount(ids, w, count + 1) / n for w in (dy * dy, dx * dx, dx * dy))
    return 4.0 * np.sqrt((syy + sxx) / 2 + np.sqrt(((syy - sxx) / 2) ** 2 + sxy**2))


def measured_shapes(work: np.ndarray, pitch_mm: float, *, width_mm: float, fine) -> SideShapes | None:
    """side_shapes of the picture before the print grid's blur, COMPACT_PITCH_MM fine (at most twice
    the working grid), where the gaps between members keep their cusps; of the working grid when
    there is no finer picture."""
    picture, picture_pitch_mm = work, pitch_mm
    want = min(2 * work.shape[1] - 1, round(width_mm / COMPACT_PITCH_MM) + 1)
    if fine is not None and want > work.shape[1]:
        finer = fine(want)
        if finer is not None and finer.shape[1] > work.shape[1]:
            picture, picture_pitch_mm = finer, width_mm / (finer.shape[1] - 1)
    shapes = side_shapes(picture, picture_pitch_mm)
    log.debug("content: side shapes %s", shapes)
    return shapes


def shape_polarity(polarity: Polarity, shapes: SideShapes | None) -> Polarity:
    """The polarity settled by the members' shape when it says (SideShapes.members_bright), else as it was."""
    bright = shapes.members_bright if shapes is not None else None
    if bright is None:
        return polarity
    side = "bright" if bright else "dark"
    reason = (f"the ground's brightness ({polarity.ground:.2f} of the range) does not say which side is matter, but "
              f"{shapes.words()}, so the {side} parts are raised")
    return Polarity(bright, polarity.ground, reason, empty=polarity.empty and not bright, settled=True)


def lattice_spectrum(work: np.ndarray, pitch_mm: float) -> Spectrum:
    """The spectrum of the picture's detail (what a 4 mm blur leaves), windowed: its strongest
    period beyond 12 mm wavelengths when the ring of that frequency holds a clear share (0.35) of
    the detail's power, how peaked it is, and whether it peaks in two directions. One FFT serves
    the content style, the legibility check (on the heights) and the content word of a panel."""
    rows, cols = work.shape
    grid = _frequencies(rows, cols)
    detail = work - wide_gaussian(work, 4.0 / pitch_mm)
    # scipy.fft keeps float32 (numpy's FFT works in float64): half the work, the same peak.
    spectrum = scipy.fft.rfft2((detail * grid.window).astype(np.float32))
    power = spectrum.real**2 + spectrum.imag**2
    freq = grid.cycles_per_px / pitch_mm  # cycles per mm
    # Wavelengths under 12 mm that repeat at least six times across the picture in their own
    # direction (a thin strip's one step between two layers is no period).
    band = (freq > 1 / 12.0) & (freq < 0.5 / pitch_mm) & grid.repeats_six
    inside = power[band]
    total = float(inside.sum())
    if total <= 0 or inside.size <= PEAK_BINS:
        return Spectrum(None, 0.0, False)
    peaked = float(np.partition(inside, inside.size - PEAK_BINS)[-PEAK_BINS:].sum() / total)
    banded = np.where(band, power, 0)
    at = np.unravel_index(np.argmax(banded), power.shape)
    near = band & (np.abs(freq - freq[at]) <= 0.08 * freq[at])  # the ring of that frequency (all orientations)
    share = float(power[near].sum() / total)
    # A second direction: the strongest peak at least LATTICE_ANGLE_DEG from the first (angles
    # modulo 180 degrees: the half-plane spectrum holds each direction once), within an octave.
    # The angles only within that octave band: the modulo over every bin was a third of this step.
    octave = band & (freq >= 0.5 * freq[at]) & (freq <= 2.0 * freq[at])
    turn = np.abs((grid.angle_deg[octave] - grid.angle_deg[at] + 90.0) % 180.0 - 90.0)
    other = banded[octave][turn >= LATTICE_ANGLE_DEG]
    two_way = bool(other.size) and float(other.max()) >= SECOND_PEAK * float(banded[at])
    period = Period(float(1.0 / freq[at]), share) if share >= 0.35 else None
    return Spectrum(period, peaked, two_way)


@dataclass(frozen=True)
class _Frequencies:
    """For a (rows, cols) picture: its Hann window, and the frequency of every bin of its
    half-plane spectrum (rfft2) in cycles per grid point, whether it repeats at least six times
    across the picture in its own direction, and its direction in degrees."""

    window: np.ndarray
    cycles_per_px: np.ndarray
    repeats_six: np.ndarray
    angle_deg: np.ndarray


@functools.lru_cache(maxsize=8)
def _frequencies(rows: int, cols: int) -> _Frequencies:
    """The same few grid shapes recur (the working grid, the fine grid, the heights): the window
    and each bin's frequency and direction computed once per shape (2.5 ms at 375 x 499)."""
    fy = np.fft.fftfreq(rows)[:, None]
    fx = np.fft.rfftfreq(cols)[None, :]
    shape = (rows, cols // 2 + 1)
    angle = np.degrees(np.arctan2(np.broadcast_to(fy, shape), np.broadcast_to(fx, shape)))
    window = np.outer(np.hanning(rows), np.hanning(cols)).astype(np.float32)
    grid = _Frequencies(window, np.hypot(fy, fx), np.hypot(fy * rows, fx * cols) >= 6.0, angle)
    for array in (grid.window, grid.cycles_per_px, grid.repeats_six, grid.angle_deg):
        array.flags.writeable = False  # shared between calls
    return grid


def lattice_period(work: np.ndarray, pitch_mm: float) -> Period | None:
    """The strongest period of the picture's detail (spectrum peak beyond 12 mm wavelengths), if
    its peak holds a clear share of the detail's power; else None."""
    return lattice_spectrum(work, pitch_mm).period


def is_lattice(spectrum: Spectrum, width_mm: float) -> bool:
    """A 2-D lattice: a few sharp peaks (PEAK_SHARE), in two directions, repeating at least
    MIN_REPEATS times across the print."""
    return (spectrum.period is not None and spectrum.peaked >= PEAK_SHARE and spectrum.two_way
            and spectrum.period.pitch_mm * MIN_REPEATS <= width_mm)


def make_content(work: np.ndarray, *, pitch_mm: float, relief_mm: float, width_mm: float, found,
                 min_area_mm2: float, hints: ContentHints | None = None, fallback: bool = True,
                 fine=None) -> ContentMade | None:
    """The content relief on the working grid (see the module's notes). `found`: the edge-enclosed
    objects (an ObjectMap, or a function that finds them: only asked for when needed). `hints`:
    file metadata that helps the choice (detector, signal), said in the reason. Without
    `fallback`, None when the picture holds no population, no line network and no weak-contrast
    specimen (auto then chooses among the other styles, and the shape is not made for nothing).
    `fine`: a function of a column count giving the picture without the print grid's blur
    (Prepared.finer), where lines under a print pixel wide are looked for when nothing else was
    found (fine_lines)."""
    specimen = find_specimen(work, pitch_mm)
    if not specimen.any():  # no specimen found (a picture all mount, or flat): the whole picture is the specimen
        specimen = np.ones_like(specimen)
    hints = hints or ContentHints()
    polarity = content_polarity(work, pitch_mm, None if specimen.all() else specimen, signal=hints.signal)
    spectrum = lattice_spectrum(work, pitch_mm)
    meta = f"; file metadata: {hints.words()}" if hints.words() else ""
    ask = _Ask(work, pitch_mm, relief_mm, width_mm, min_area_mm2, _lattice_words(spectrum.period, width_mm) + meta)
    if not specimen.all():
        lo, hi = np.percentile(work[specimen], [5, 95])
        if hi - lo < WEAK_SPREAD:
            x = work if polarity.bright else 1.0 - work
            return _weak_contrast(work, x, pitch_mm, relief_mm, width_mm, min_area_mm2, polarity, ask.extra, specimen)
    finder = _Finder(work, pitch_mm, min_area_mm2)
    made, polarity = _lattice_made(ask, spectrum, fine, finder, polarity, meta)
    if made is not None:
        return made
    shapes = None
    if specimen.all() and _ground_leaves_it_open(work, pitch_mm, polarity, hints.signal):
        # Which side is members by their shape: decides where nothing else does, and parts them.
        # (After the lattice: its columns' side is read from its detail's skew.)
        shapes = measured_shapes(work, pitch_mm, width_mm=width_mm, fine=fine)
        if hints.signal is None and (polarity.undecided or polarity.empty):
            polarity = shape_polarity(polarity, shapes)
    polarity, lines, members = _settled_polarity(finder, polarity, hints.signal, pitch_mm)
    made = _lines_or_members(ask, finder, polarity, lines, members, spectrum.period, _compact_members(shapes, polarity, members, finder))
    if made is None:
        made = _other_content(ask, finder, polarity, lines, specimen, found, fine)
    if made is not None or not fallback:
        return made
    return _weak_contrast(work, finder.picture(polarity.bright), pitch_mm, relief_mm, width_mm, min_area_mm2, polarity, ask.extra,
                          None if specimen.all() else specimen, grains=False)


def _ground_leaves_it_open(work: np.ndarray, pitch_mm: float, polarity: Polarity, signal: str | None) -> bool:
    """Whether the ground's brightness alone leaves open which side is matter or what its members
    are: a mid-grey ground, a bright "empty" one that may be flat members packed edge to edge, or
    a bright one that is a field of bright members (with a signal, as the brightness would have
    said without it). Their shape then decides, or parts the members."""
    by_brightness = polarity if signal is None else content_polarity(work, pitch_mm)
    field_of_members = by_brightness.bright and by_brightness.ground >= 0.6
    return by_brightness.undecided or by_brightness.empty or field_of_members


def _compact_members(shapes: SideShapes | None, polarity: Polarity, members: Members, finder: "_Finder") -> Members | None:
    """The raised side's compact pieces (SideShapes.members) as the members, when the shapes say that
    side is members and its pieces are at least PACKED_MIN_MEMBERS, far more than local contrast
    parts (members packed edge to edge, of one flat grey, have no local peak of their own); else None."""
    labels = shapes.members(polarity.bright, finder.work.shape) if shapes is not None else None
    count = int(labels.max()) if labels is not None else 0
    if count < PACKED_MIN_MEMBERS or members.count >= 0.8 * count:
        return None
    detail = local_tophat(finder.picture(polarity.bright).astype(np.float32), finder.pitch_mm)
    energy = float(detail[labels > 0].sum() / max(float(detail.sum()), 1e-9))
    return Members(labels, count, np.ones(count, np.float32), finder.noise, energy)


@dataclass(frozen=True)
class _Ask:
    """What every way of making the content relief is given: the working grid and its pitch, the
    relief, the print's width, the smallest area, and the words every reason ends with (a lattice's
    pitch, the file's metadata)."""

    work: np.ndarray
    pitch_mm: float
    relief_mm: float
    width_mm: float
    min_area_mm2: float
    extra: str


def _lattice_made(ask: _Ask, spectrum: Spectrum, fine, finder: "_Finder", polarity: Polarity,
                  meta: str) -> tuple[ContentMade | None, Polarity]:
    """A lattice (atomic columns, a dot grid) raised column by column, evenly, or None; and the
    polarity, turned over when the lattice's columns say so. (Found as members one by one, a dim
    column on a dark patch goes missing and noise cracks the rest.)"""
    found_lattice = _lattice_picture(ask.work, spectrum, fine, ask.pitch_mm, ask.width_mm, finder.noise)
    if found_lattice is None:
        return None, polarity
    picture, picture_pitch_mm, picture_period, picture_noise = found_lattice
    if polarity.undecided:
        # A mid-grey ground: the columns are the side whose detail is skewed (sharp peaks over
        # broad troughs), bright dots on a dark ground or dark ones on a bright one.
        detail = picture - ndimage.gaussian_filter(picture, picture_period.pitch_mm / picture_pitch_mm, mode="nearest")
        bright = float(np.mean(detail**3)) >= 0.0
        if bright != polarity.bright:
            polarity = polarity.flipped("the lattice's columns are on that side (its detail is skewed that way)")
    return _as_lattice(ask.work.shape, picture if polarity.bright else 1.0 - picture, picture_pitch_mm, ask.pitch_mm,
                       picture_period, ask.relief_mm, ask.width_mm, polarity, meta, picture_noise), polarity


def _settled_polarity(finder: "_Finder", polarity: Polarity, signal: str | None, pitch_mm: float) -> tuple[Polarity, Lines, Members]:
    """The polarity the ground's brightness gave, turned over where the content says otherwise,
    with the lines and members of the side it raises."""
    lines = finder.lines(polarity.bright)
    members = finder.members(polarity.bright)
    if polarity.undecided and not _is_population(members, pitch_mm):
        # A mid-grey ground: a dense field of one side's blobs (dense.py; its peaks stand out, the
        # other side's are the gaps between them) is the content; else the side whose members
        # hold more of the detail.
        here = finder.blobs(polarity.bright)
        there = None if here is not None and here.dense else finder.blobs(not polarity.bright)
        other = finder.members(not polarity.bright)
        was = polarity.bright
        if there is not None and there.dense:
            polarity = polarity.flipped(f"the other side's blobs are a dense field (peaks {there.asymmetry:.2f} × its troughs)")
        elif (here is None or not here.dense) and other.energy > members.energy:
            polarity = polarity.flipped(f"members of the other side hold more of the detail ({other.energy:.0%} against {members.energy:.0%})")
        if polarity.bright != was:
            members, lines = finder.members(polarity.bright), finder.lines(polarity.bright)
    elif signal is None and not polarity.settled and not _is_population(members, pitch_mm):
        # The ground's brightness said one side, but nothing stands out there while the other side
        # holds round members of one size (dark cells on a glass whose noise hid that it is empty):
        # those are the content. Only a population by shape turns it over, never one that merely
        # splits into more pieces (gaps between packed cells are uneven and angular).
        other = finder.members(not polarity.bright)
        if _is_round_population(other, pitch_mm):
            side = "dark" if polarity.bright else "bright"
            polarity = Polarity(not polarity.bright, polarity.ground,
                                f"the ground looked {'bright' if polarity.bright else 'dark'} ({polarity.ground:.2f} of the range), but "
                                f"nothing stands out there, while the {side} side holds {other.count} round members of one size, "
                                f"so the {side} parts are raised")
            members, lines = other, finder.lines(polarity.bright)
    return polarity, lines, members


def _lines_or_members(ask: _Ask, finder: "_Finder", polarity: Polarity, lines: Lines, members: Members,
                      period: Period | None, compact: Members | None = None) -> ContentMade | None:
    """Compact members parted at their necks (`compact`), a line network (of either polarity), a
    packed field of bright members, or a population; None when the picture holds none of them."""
    pitch_mm, relief_mm, extra = ask.pitch_mm, ask.relief_mm, ask.extra
    if compact is not None:
        # The side the shapes call members, parted where its pieces narrow (bright ones packed edge to
        # edge said as such); thin strands over them and their gaps (fibrin) are raised as lines by
        # _with_fibres, never the gaps as members.
        packed = _packed_bright_field(ask.work, pitch_mm) if polarity.bright else None
        if packed is not None:
            return _packed_made(packed, ask, finder, polarity)
        made = _as_members(compact.labels, pitch_mm, relief_mm, polarity, extra,
                           what=f"{compact.count} compact members, parted where they narrow (their side's pieces at fingertip scale)")
        return _with_fibres(made, finder, polarity.bright, pitch_mm, relief_mm)
    network = _is_network(lines) and not _members_explain(members, lines, pitch_mm)
    if not network:
        # A network of the other polarity (dark lines between bright grains whose own brightness
        # varies, so the ground did not look empty) is content too: lines read better than cells.
        other = finder.lines(not polarity.bright)
        if _is_network(other):
            lines, network = other, True
            polarity = Polarity(not polarity.bright, polarity.ground,
                                f"{'dark' if polarity.bright else 'bright'} lines form a network ({other.cell_count} regions), so they are "
                                f"raised and the regions they enclose sit at the base")
    if network:
        return _as_lines(lines, pitch_mm, relief_mm, ask.width_mm, polarity, extra, "lines")
    packed = _packed_bright_field(ask.work, pitch_mm) if polarity.empty and not _is_population(members, pitch_mm) else None
    if packed is not None:
        return _packed_made(packed, ask, finder, polarity)
    if _is_population(members, pitch_mm) and not _dense_field_beats(finder.blobs(polarity.bright), members, pitch_mm):
        blobs = finder.blobs(polarity.bright)
        made = _as_members(members.labels, pitch_mm, relief_mm, polarity, extra, picture=finder.picture(polarity.bright),
                           dense_field=blobs is not None and blobs.dense and period is None,  # a lattice is found whole
                           what=f"{members.count} members found by local contrast (each against the ground around it, cut at half its own peak; "
                           f"dimmest {np.min(members.contrast):.2f}, brightest {np.max(members.contrast):.2f} of the range)")
        return _with_fibres(made, finder, polarity.bright, pitch_mm, relief_mm)
    return None


# A textured network's lines stand out of the ridge response's spread (robust deviations): noise
# over smooth grains traces a "network" too, at 1.0; the ssTEM membranes 1.9, synthetic ones 2.8.
TEXTURED_MIN_STRENGTH = 1.5


def _textured_network(ask: _Ask, finder: "_Finder", polarity: Polarity) -> ContentMade | None:
    """A line network on a textured ground (membranes between grainy cells), of either polarity,
    raised as lines; None when neither side's lines are much narrower than the regions they
    enclose (_is_textured_network). Asked last, after members, populations and dense fields:
    lumps and packed particles stay lumps (the gaps of a dense field also read as narrow lines)."""
    found = [(widths.ratio, bright, lines, widths) for bright in (False, True)
             for lines, widths in [textured_lines(finder.ridges()[0 if bright else 1], pitch_mm=ask.pitch_mm,
                                                  min_area_mm2=ask.min_area_mm2)]
             if _is_textured_network(lines, widths)]
    for ratio, bright, lines, widths in found:
        log.debug("textured network (%s): %d regions %.1f mm wide, lines %.1f mm (ratio %.1f)",
                  "bright" if bright else "dark", widths.regions, widths.region_mm, widths.line_mm, ratio)
    if not found:
        return None
    _, bright, lines, widths = max(found, key=lambda f: f[0])
    side = "bright" if bright else "dark"
    polarity = Polarity(bright, polarity.ground, f"the {side} lines form a network on a textured ground, so they are raised and "
                                                f"the regions they enclose sit at the base")
    return _as_lines(lines, ask.pitch_mm, ask.relief_mm, ask.width_mm, polarity, ask.extra, "lines",
                     what=(f"a network of {side} lines {widths.line_mm:.1f} mm wide enclosing {widths.regions} regions "
                           f"{widths.region_mm:.1f} mm wide ({widths.ratio:.1f} times their lines; {lines.length_mm:.0f} mm of line)"))


def _is_textured_network(lines: Lines, widths: NetworkWidths) -> bool:
    """Many regions that tile the picture (FINE_NETWORK_CELLS, FINE_MAX_CELL_SHARE, as a fine
    network's), lines covering no more than MAX_LINE_COVER, and regions at least
    NETWORK_WIDTH_RATIO times wider than the lines (refuses gaps between lumps as wide as they),
    and lines that stand out of the response (TEXTURED_MIN_STRENGTH: refuses noise's grain)."""
    return (widths.regions >= FINE_NETWORK_CELLS and widths.largest_share <= FINE_MAX_CELL_SHARE
            and lines.cover <= MAX_LINE_COVER and widths.ratio >= NETWORK_WIDTH_RATIO
            and lines.strength >= TEXTURED_MIN_STRENGTH)


def _packed_made(packed: tuple[np.ndarray, float], ask: _Ask, finder: "_Finder", polarity: Polarity) -> ContentMade:
    """A packed field of bright round members (_packed_bright_field: cells on a filter, sintered
    spheres) raised, the dark gaps between them, which split into more pieces, at the base."""
    labels, wider = packed
    polarity = Polarity(True, polarity.ground, f"the bright side is no empty ground but {int(labels.max())} round members of one "
                                              f"size packed edge to edge ({wider:.1f} times as wide as the dark gaps between "
                                              f"them), so the members are raised and the gaps sit at the base")
    made = _as_members(labels, ask.pitch_mm, ask.relief_mm, polarity, ask.extra, picture=finder.picture(True),
                       what=f"{int(labels.max())} packed members, parted where their outlines meet")
    return _with_fibres(made, finder, True, ask.pitch_mm, ask.relief_mm)


def _other_content(ask: _Ask, finder: "_Finder", polarity: Polarity, lines: Lines, specimen: np.ndarray, found,
                   fine) -> ContentMade | None:
    """Line art, objects wider than the local ground, a network thinner than the print grid, or a
    dense field of small members; None when the picture holds none of them."""
    pitch_mm, relief_mm, width_mm, extra = ask.pitch_mm, ask.relief_mm, ask.width_mm, ask.extra
    if _is_line_art(lines, polarity, specimen):
        # Strokes on empty paper (a diagram, a drawing) are raised as lines however few regions
        # they enclose: tactile graphics raise the lines, never groove them.
        return _as_lines(lines, pitch_mm, relief_mm, width_mm, polarity, extra, "lines",
                         what=f"line art: {lines.length_mm:.0f} mm of strokes on an empty ground "
                              f"(ridge strength {lines.strength:.0f} × noise)")
    # Objects wider than the local ground (the FePt spheres) are found by the edges around them.
    big = _large_edge_objects(found() if callable(found) else found, pitch_mm)
    if big is not None:
        return _as_members(big, pitch_mm, relief_mm, polarity, extra,
                           f"{int(big.max())} objects outlined by edges, wider than the {BACKGROUND_MM:g} mm local ground")
    thin = _fine_network(fine, ask.work.shape, pitch_mm, width_mm, ask.min_area_mm2)
    if thin is not None:
        bright, fine_pitch_mm, found_lines = thin
        side = "bright" if bright else "dark"
        polarity = Polarity(bright, polarity.ground, f"the {side} lines form the network, so they are raised and the regions "
                                                    f"they enclose sit at the base")
        return _as_lines(found_lines, pitch_mm, relief_mm, width_mm, polarity, extra, "lines",
                         what=(f"a network of {side} lines thinner than the print grid, found on a {fine_pitch_mm:.2f} mm grid "
                               f"before the print's blur, enclosing {found_lines.cell_count} regions ({found_lines.length_mm:.0f} mm "
                               f"of line, ridge strength {found_lines.strength:.0f} × noise)"))
    made = _fibre_field(ask, finder, polarity)
    if made is not None:
        return made
    # A dense field of small members the segmentation could not part (dense.py): one size, as
    # particles have and texture has not.
    blobs = finder.blobs(polarity.bright)
    if blobs is not None and blobs.dense:
        made = _as_dense_field(blobs, finder.picture(polarity.bright), pitch_mm, relief_mm, polarity, extra)
        if made.labels is not None and made.labels.max():
            return made
    return _textured_network(ask, finder, polarity)


class _Finder:
    """Lines and members of either polarity of one picture, each found once: the ridge filters
    and the noise level serve both polarities (the Hessian of 1 - x is minus that of x)."""

    def __init__(self, work: np.ndarray, pitch_mm: float, min_area_mm2: float):
        self.work, self.pitch_mm, self.min_area_mm2 = work, pitch_mm, min_area_mm2
        self.noise = noise_level(work.astype(np.float32))
        self._ridges: tuple[np.ndarray, np.ndarray] | None = None
        self._lines: dict[bool, Lines] = {}
        self._members: dict[bool, Members] = {}
        self._blobs: dict[bool, BlobScale | None] = {}
        self._stack: np.ndarray | None = None

    def picture(self, bright: bool) -> np.ndarray:
        return self.work if bright else 1.0 - self.work

    def ridges(self) -> tuple[np.ndarray, np.ndarray]:
        """The ridge response of bright lines and of dark ones (hessian_ridges), computed once."""
        if self._ridges is None:
            self._ridges = hessian_ridges(self.work, self.pitch_mm)
        return self._ridges

    def lines(self, bright: bool) -> Lines:
        """Lines brighter than both sides in the picture (bright) or in its inverse."""
        if bright not in self._lines:
            # Lines under NETWORK_STRENGTH are neither a network (_is_network) nor line art
            # (_is_line_art), the only questions asked of them: their regions are not traced.
            self._lines[bright] = find_lines(self.picture(bright), pitch_mm=self.pitch_mm, min_area_mm2=self.min_area_mm2,
                                             response=self.ridges()[0 if bright else 1], noise=self.noise,
                                             min_strength=NETWORK_STRENGTH)
        return self._lines[bright]

    def blobs(self, bright: bool) -> BlobScale | None:
        """The blobs of either polarity (dense.py), from one scale stack."""
        if bright not in self._blobs:
            if self._stack is None:
                self._stack = scale_stack(self.work, self.pitch_mm)
            stack = None if self._stack is None else (self._stack if bright else -self._stack)
            self._blobs[bright] = None if stack is None else blob_scale(self.picture(bright), self.pitch_mm, stack)
        return self._blobs[bright]

    def members(self, bright: bool) -> Members:
        """Members found by local contrast on the working grid, in print mm. (On the picture grid,
        picture_scale.py, a plateau wider than the local ground, blurred by a narrow print's
        upsampling, left arcs of its rim that passed as members: the 60 and 80 mm test disc.)"""
        if bright not in self._members:
            self._members[bright] = find_members(self.picture(bright), pitch_mm=self.pitch_mm, noise=self.noise)
        return self._members[bright]


def _fine_network(fine, shape: tuple[int, int], pitch_mm: float, width_mm: float,
                  min_area_mm2: float) -> tuple[bool, float, Lines] | None:
    """(bright, the fine grid's pitch, the lines on the working grid) of the strongest line
    network found on the fine grid, or None: no fine picture, the working grid already as fine
    as FINE_PITCH_MM allows (the fine grid must be at least twice as fine), or no network."""
    if fine is None:
        return None
    want = round(width_mm / FINE_PITCH_MM) + 1
    if want < 2 * shape[1]:
        return None
    picture = fine(want)
    if picture is None or picture.shape[1] < 2 * shape[1]:
        return None
    fine_pitch_mm = width_mm / (picture.shape[1] - 1)
    # Lines weaker than FINE_STRENGTH are no fine network (_is_fine_network): not drawn at all.
    found = fine_lines(picture, fine_pitch_mm=fine_pitch_mm, work_shape=shape, pitch_mm=pitch_mm, min_area_mm2=min_area_mm2,
                       min_strength=FINE_STRENGTH)
    for bright, lines in found.items():
        log.debug("fine lines (%s, %.2f mm grid): %d regions, strength %.1f, cover %.2f", "bright" if bright else "dark",
                  fine_pitch_mm, lines.cell_count, lines.strength, lines.cover)
    best = [(lines.strength, bright) for bright, lines in found.items() if _is_fine_network(lines)]
    if not best:
        return None
    bright = max(best)[1]
    return bright, fine_pitch_mm, found[bright]


def _is_fine_network(lines: Lines) -> bool:
    """Many regions, lines clear of the noise, and regions that tile the picture: no one of them
    holds more than FINE_MAX_CELL_SHARE of it (measured: the Al2O3 grains 0.05, where a portrait's
    sky, a fundus's background or an SEM field's ground, whose outlines the fine grid finds too,
    hold 0.26-0.99)."""
    if lines.cell_count < FINE_NETWORK_CELLS or lines.cover > MAX_LINE_COVER or lines.strength < FINE_STRENGTH:
        return False
    area = np.bincount(lines.cells.ravel())[1:]
    return bool(area.size) and float(area.max()) <= FINE_MAX_CELL_SHARE * float(area.sum())


def _is_network(lines: Lines) -> bool:
    return lines.cell_count >= NETWORK_CELLS and lines.cover <= MAX_LINE_COVER and lines.strength >= NETWORK_STRENGTH


def _is_line_art(lines: Lines, polarity: Polarity, specimen: np.ndarray) -> bool:
    """Strong thin strokes on an empty bright ground, long enough to follow by touch."""
    return (polarity.empty and lines.strength >= NETWORK_STRENGTH and lines.cover <= MAX_LINE_COVER
            and lines.length_mm >= LINE_ART_MM)


def _is_population(members: Members, pitch_mm: float) -> bool:
    """A population, not the peaks of a continuous picture: the members hold most of the detail
    (POPULATION_ENERGY of the top-hat), or they are round (POPULATION_ROUNDNESS, median minor /
    major axis), of similar size (POPULATION_SPREAD) and hold a clear part of it. Measured: a
    portrait 0.42, stained tissue 0.48-0.54, SEM and STEM particle fields 0.63-0.80; beads 0.51
    and particles on a textured substrate 0.22, but round (0.85-0.99) and within a factor 1.5 in
    size, where pieces of vessels, terraces' noise and tissue are not (0.32-0.64)."""
    if members.count < MIN_MEMBERS:
        return False
    if members.energy >= POPULATION_ENERGY:
        return True
    round_ = float(np.median(roundness(members.labels, members.count)[1:]))
    return members.spread(pitch_mm) <= POPULATION_SPREAD and members.energy >= 0.15 and round_ >= POPULATION_ROUNDNESS


def _dense_field_beats(blobs: BlobScale | None, members: Members, pitch_mm: float) -> bool:
    """A dense field whose members the segmentation parted only a few of: many more blobs of the
    members' own size than members (DENSE_OVER_MEMBERS), and the members hold less than
    POPULATION_ENERGY of the detail. (Four beads on a noisy max projection make a "dense field" of
    noise blobs a third of their size, and hold most of the detail: they stay a population.)"""
    if blobs is None or not blobs.dense or members.count == 0:
        return False
    same_size = float(np.median(members.diameters_mm(pitch_mm))) <= 2.0 * blobs.diameter_mm
    return same_size and blobs.count >= DENSE_OVER_MEMBERS * members.count and members.energy < POPULATION_ENERGY


ROUND_POPULATION = dict(count=5, roundness=0.85, spread=2.0, energy=0.5)  # a population by its shape alone


def _is_round_population(members: Members, pitch_mm: float) -> bool:
    """Round members of one size holding most of the picture's detail (ROUND_POPULATION): beads,
    cells, particles, whichever side of the ground they lie on."""
    r = ROUND_POPULATION
    if members.count < r["count"] or members.energy < r["energy"] or members.spread(pitch_mm) > r["spread"]:
        return False
    return float(np.median(roundness(members.labels, members.count)[1:])) >= r["roundness"]


PACKED_COVER = (0.45, 0.92)  # the bright phase of a packed field covers most of the picture, not all of it
PACKED_MIN_MEMBERS = 12
PACKED_MIN_DIAMETER_MM = 2.0  # members a fingertip finds one by one
PACKED_OVER_GAPS = 1.5  # the members are this many times wider than the gaps between them (median)
PACKED_ROUNDNESS = 0.6  # median minor / major axis of the parted members
PACKED_SPREAD = 3.5  # 90th over 10th percentile of their widths
PACKED_EVENER = 0.5  # and at most half the gaps' spread


def _packed_bright_field(work: np.ndarray, pitch_mm: float) -> tuple[np.ndarray, float] | None:
    """(labels, the members' median width over the gaps') when the picture's bright phase is a
    packed field of round members of one size, else None. The bright phase (Otsu at fingertip
    scale) is parted by a watershed of its distance to the dark phase; it is a packed field when
    its pieces are round and even (PACKED_ROUNDNESS, PACKED_SPREAD), clearly wider than the dark
    pieces between them (PACKED_OVER_GAPS) and far more even in size (PACKED_EVENER). An empty ground (glass, paper,
    vacuum) parts into pieces of every size and shape; dark cells packed on glass make the glass's
    pieces the narrow, uneven ones, so the rule does not turn them over."""
    from skimage.feature import peak_local_max

    smooth = ndimage.gaussian_filter(work.astype(np.float32), max(0.5, 0.5 / pitch_mm), mode="nearest")
    phase = smooth > filters.threshold_otsu(smooth)
    if not PACKED_COVER[0] <= float(phase.mean()) <= PACKED_COVER[1]:
        return None
    gaps, n_gaps = ndimage.label(~phase)
    if n_gaps < PACKED_MIN_MEMBERS:
        return None
    gap_members = Members(gaps.astype(np.int32), n_gaps, np.ones(n_gaps), 0.0)
    dist = ndimage.distance_transform_edt(phase)
    radius_px = PACKED_MIN_DIAMETER_MM / 2 / pitch_mm
    peaks = peak_local_max(dist, min_distance=max(2, round(radius_px)), threshold_abs=radius_px, exclude_border=False)
    if len(peaks) < PACKED_MIN_MEMBERS:
        return None
    markers = np.zeros(work.shape, np.int32)
    markers[tuple(peaks.T)] = np.arange(1, len(peaks) + 1)
    labels = segmentation.watershed(-dist, markers, mask=phase).astype(np.int32)
    members = Members(labels, int(labels.max()), np.ones(int(labels.max())), 0.0)
    round_ = float(np.median(roundness(labels, members.count)[1:]))
    wider = float(np.median(members.diameters_mm(pitch_mm)) / max(float(np.median(gap_members.diameters_mm(pitch_mm))), 1e-9))
    # Parted by a watershed, packed discs come out less round and less even than found members do
    # (PACKED_ROUNDNESS, PACKED_SPREAD); the gaps decide, by being far less even still.
    spread = members.spread(pitch_mm)
    if round_ < PACKED_ROUNDNESS or spread > PACKED_SPREAD or spread > PACKED_EVENER * gap_members.spread(pitch_mm) or wider < PACKED_OVER_GAPS:
        return None
    return labels, wider


def _members_explain(members: Members, lines: Lines, pitch_mm: float) -> bool:
    """A dense population looks like a network of the gaps between members: the members explain
    the picture when they cover more than the lines do and they are a population. Speckle inside
    the cells of a membrane network (the Nikon widefield stack: 55 pieces holding 43 % of the
    detail, sizes spread 2.4-fold) is no population: the membranes are the content."""
    return members.count >= NETWORK_CELLS and members.cover > 1.5 * lines.cover and _is_population(members, pitch_mm)


def _large_edge_objects(found: ObjectMap, pitch_mm: float) -> np.ndarray | None:
    """Objects the edge finder outlined that are too wide for the local ground (the FePt spheres)."""
    if found.method != "edges" or found.count < 2:
        return None
    area = np.bincount(found.labels.ravel())[1:]
    diameters = 2 * np.sqrt(area / np.pi) * pitch_mm
    similar = np.percentile(diameters, 90) <= POPULATION_SPREAD * np.percentile(diameters, 10)
    return found.labels if similar and float(np.median(diameters)) > BACKGROUND_MM else None


def _lattice_words(period: Period | None, width_mm: float) -> str:
    if period is None:
        return ""
    if period.pitch_mm >= MIN_PITCH_MM:
        return f"; a lattice of {period.pitch_mm:.1f} mm pitch on the print, kept (feelable, not roughness)"
    return (f"; a lattice of {period.pitch_mm:.1f} mm pitch on the print, too fine to feel: it becomes feelable "
            f"at a print width of {width_mm * MIN_PITCH_MM / period.pitch_mm:.0f} mm")


def _as_members(labels: np.ndarray, pitch_mm, relief_mm, polarity, extra, what, picture: np.ndarray | None = None,
                dense_field: bool = False) -> ContentMade:
    count = int(labels.max())
    area = np.bincount(labels.ravel(), minlength=count + 1)[1:]
    diam = 2 * np.sqrt(area / np.pi) * pitch_mm
    notes = []
    small = diam < MIN_FELT_MM
    if small.any() and count <= FEW_MEMBERS:
        # Few members under a fingertip: draw each at least MIN_FELT_MM across (into free ground only).
        grown = segmentation.expand_labels(labels, distance=max(1.0, (MIN_FELT_MM - float(diam[small].min())) / 2 / pitch_mm))
        keep_small = np.concatenate([[False], small])
        labels = np.where((labels == 0) & keep_small[grown], grown, labels)
        notes.append(Decision(f"content: {int(small.sum())} members narrower than {MIN_FELT_MM:g} mm were drawn {MIN_FELT_MM:g} mm wide, so a finger finds them."))
    elif small.any():
        notes.append(Decision(f"content: {int(small.sum())} of {count} members are narrower than {MIN_FELT_MM:g} mm; with so many they read as a texture of small domes."))
    before = int(labels.max())
    labels = _with_interior(labels)
    if int(labels.max()) < before:
        notes.append(Decision(f"content: {before - int(labels.max())} members too thin to carry a dome were left flat."))
    # No pins: a member's dome stands at most PIN_ASPECT times its inscribed radius (a member a grid
    # point or two wide, raised the full relief, is 0.4-0.8 mm wide and 3 mm tall: it prints badly
    # and a finger finds a prick, not a dome).
    inside_distance = InsideDistance()  # the domes and the count of neckless pairs below measure the same members
    domes = dome_profile(labels, pitch_mm=pitch_mm, round_mm=MEMBER_ROUND_MM, pin_aspect=PIN_ASPECT, relief_mm=relief_mm,
                         inside_distance=inside_distance)
    count = int(labels.max())
    cover = float((labels > 0).mean())
    if picture is not None and count > FEW_MEMBERS and (cover >= DENSE_COVER or dense_field):
        # A dense field: the members the segmentation could not part lie in the gaps between the
        # found ones, so each point also rises by its own local contrast (a top-hat three members
        # wide, full lift at its 95th percentile): a texture of small domes under the found ones.
        diam = float(np.median(2 * np.sqrt(np.bincount(labels.ravel())[1:] / np.pi))) * pitch_mm
        texture = local_tophat(picture.astype(np.float32), pitch_mm, max(3 * diam, 2 * MIN_FELT_MM))
        scale = float(np.percentile(texture, 95))
        if scale > 0:
            domes = np.maximum(domes, np.clip(texture / scale, 0.0, 1.0)).astype(np.float32)
            notes.append(Decision(f"content: a dense field ({count} members over {cover:.0%} of the picture): the members not "
                                  f"parted from their neighbours rise by their local contrast, as a texture of small domes."))
    reason = f"content: {what}; each raised as a dome by the same lift, touching ones apart by a groove; {polarity.reason}{extra}"
    split = 0 if picture is None else int(neckless_pairs(labels, local_tophat(picture.astype(np.float32), pitch_mm),
                                                         inside_distance=inside_distance)[0].size)
    return ContentMade(domes, "members", labels, reason, tuple(notes), split_pairs=split)


FIBRE_GROUND_MM = 12.0  # straight lines run this far in all over the ground between members (1 mm clear of them): fibres
FIBRE_PIECE_MM = 1.5  # in pieces at least this long (a fibre crossing a gap between two members)
FIBRE_STRAIGHT = 0.8  # each this straight (end-to-end over its length along the skeleton): fibres, not rims or specks
FIBRE_BROAD_MM = 1.5  # a fibre answers the ridge filter more at its fine scale (lines.RIDGE_SIGMA_MM) than at this
FIBRE_DETAIL_SHARE = 0.5  # fibres alone (no members, no network) carry this share of the ridge response within 1 mm
FIBRE_GAP_MM = 4.0  # a fibre goes on along its ridge this far past its straight pieces (through crossings)
FIBRE_COVER = 0.6  # a fibre's pieces run along this share of its course over the clear ground
FIBRE_SLENDER = 0.5  # a member this slender (minor / major axis) may be a piece of a fibre
FIBRE_MADS = 6.0  # the ridge response over the ground stands this many robust deviations above its median


def _with_fibres(made: ContentMade, finder: "_Finder", bright: bool, pitch_mm: float, relief_mm: float) -> ContentMade:
    """Members with the thin fibres that cross them and the ground between them raised as lines
    (issue 32, class 1: fibres over cells on a filter are raised lines, not lost in the ground).
    Over the ground clear of every member (1 mm away), the ridge response above the noise
    (FIBRE_MADS robust deviations of the response there, and 3 × the picture's noise) is thinned;
    straight pieces (FIBRE_STRAIGHT, at least FIBRE_PIECE_MM long) are fibres when they run
    FIBRE_GROUND_MM in all; they are drawn
    LINE_WIDTH_MM wide and LINE_HEIGHT_MM high (the members' domes stand over them where they
    cross). Members' rims and the bridges between touching members lie within 1 mm of them."""
    if made.labels is None or not made.labels.max() or relief_mm <= 0:
        return made
    # Elongated members (a fibre's piece between two cells, found as a member) do not hide it.
    count_members = int(made.labels.max())
    slender = np.concatenate([[False], roundness(made.labels, count_members)[1:] < FIBRE_SLENDER])
    solid = (made.labels > 0) & ~slender[made.labels]
    clear = ~ndimage.binary_dilation(solid, iterations=max(1, round(1.0 / pitch_mm)))
    fibres, count = _fibre_lines(finder, bright, pitch_mm, clear)
    if not count:
        return made
    from dataclasses import replace

    from .lines import network_of

    drawn = draw_lines(network_of(fibres, pitch_mm=pitch_mm, min_area_mm2=1e9, strength=0.0), pitch_mm)
    height = min(LINE_HEIGHT_MM, relief_mm)
    labels, relief01 = _without_fibre_pieces(made, slender, fibres)
    relief01 = np.maximum(relief01, drawn * height / relief_mm).astype(np.float32)
    length_mm = float(fibres.sum() * pitch_mm * 1.12)
    reason = (f"{made.reason}; {count} thin fibres ({length_mm:.0f} mm of line over the ground) cross the members "
              f"and the ground between them: raised as lines {LINE_WIDTH_MM:g} mm wide and {height:.1f} mm high")
    return replace(made, relief01=relief01, reason=reason, line_mask=fibres, labels=labels)


def _fibre_lines(finder: "_Finder", bright: bool, pitch_mm: float, clear: np.ndarray) -> tuple[np.ndarray, int]:
    """(skeleton, count) of the thin straight fibres over `clear` (see _with_fibres); count 0 when
    there are none. The ridge response above the noise there (FIBRE_MADS robust deviations, and
    3 × the picture's noise), finer than FIBRE_BROAD_MM, thinned, apart at crossings; its straight
    pieces collinear with FIBRE_GROUND_MM of others (_straight_runs)."""
    none = np.zeros(clear.shape, bool), 0
    if clear.sum() < 100:
        return none
    response = finder.ridges()[0 if bright else 1]
    ground = response[clear]
    med = float(np.median(ground))
    mad = 1.4826 * float(np.median(np.abs(ground - med))) + 1e-9
    mask = clear & (response > max(med + FIBRE_MADS * mad, 3 * finder.noise))
    if not mask.any():
        return none
    # Thin: the ridge answers more at the fine scale than at FIBRE_BROAD_MM (both scale-normalised);
    # the edges of broad bands (a coarse picture's blocks, shading) answer more at the broad one.
    broad = hessian_ridges(finder.work, pitch_mm, sigma_mm=FIBRE_BROAD_MM)[0 if bright else 1]
    whole = morphology.skeletonize(mask & (response >= broad))
    # Apart at crossings (skeleton points with three or more neighbours): two fibres that cross
    # are two straight pieces, not one bent one.
    neighbours = ndimage.convolve(whole.astype(np.uint8), np.ones((3, 3), np.uint8), mode="constant") - 1
    skeleton = whole & ~ndimage.binary_dilation(whole & (neighbours >= 3))
    # Lines, not the flanks of a brighter line (the Hessian answers there for the other side).
    skeleton = brighter_than_both_sides(skeleton, finder.picture(bright), pitch_mm)
    parts, n = ndimage.label(skeleton, structure=np.ones((3, 3)))
    if n == 0:
        return none
    fibres, count, lines = _straight_runs(skeleton, parts, n, pitch_mm, clear)
    if not count:
        return none
    # Where fibres cross at a small angle their ridge is broad, and the crossings were cut out
    # above: the fibres go on along the ridge skeleton (without the fineness rule) up to
    # FIBRE_GAP_MM from their straight pieces, along their own lines.
    yy, xx = np.mgrid[0 : clear.shape[0], 0 : clear.shape[1]]
    along = np.zeros(clear.shape, bool)
    for theta, dist in lines:
        along |= np.abs(xx * np.cos(theta) + yy * np.sin(theta) - dist) <= 1.5
    loose = (morphology.skeletonize(mask) | whole) & along
    for _ in range(max(1, round(FIBRE_GAP_MM / pitch_mm))):
        grown = fibres | (loose & ndimage.binary_dilation(fibres, structure=np.ones((3, 3), bool)))
        if grown.sum() == fibres.sum():
            break
        fibres = grown
    return fibres, count


def _fibre_field(ask: _Ask, finder: "_Finder", polarity: Polarity) -> ContentMade | None:
    """Straight fibres with no members and no network (stress fibres, collagen bundles,
    microtubules in one channel) raised as oriented lines, not the plateaus their mesh of
    crossings makes of the picture's shape; None when they run less than LINE_ART_MM in all. On
    a mid-grey ground the side whose fibres run longer is raised."""
    everywhere = np.ones(ask.work.shape, bool)
    sides = [polarity.bright, not polarity.bright] if polarity.undecided else [polarity.bright]
    found = [(float(mask.sum()), bright, mask, count) for bright in sides
             for mask, count in [_fibre_lines(finder, bright, ask.pitch_mm, everywhere)] if count]
    if not found:
        return None
    length_px, bright, fibres, count = max(found, key=lambda f: f[0])
    if length_px * ask.pitch_mm * 1.12 < LINE_ART_MM:
        return None
    # The fibres are what the picture shows: they carry most of its lines of that side (the ridge
    # response; a photograph's straight edges, a tripod's legs, carry little of it).
    response = finder.ridges()[0 if bright else 1]
    near = ndimage.binary_dilation(fibres, iterations=max(1, round(1.0 / ask.pitch_mm)))
    if float(response[near].sum()) < FIBRE_DETAIL_SHARE * float(response.sum()):
        return None
    if bright != polarity.bright:
        side = "bright" if bright else "dark"
        polarity = Polarity(bright, polarity.ground, f"the {side} lines are straight fibres, so they are raised and the ground "
                                                    f"between them sits at the base")
    from .lines import network_of

    found_lines = network_of(fibres, pitch_mm=ask.pitch_mm, min_area_mm2=ask.min_area_mm2, strength=0.0)
    return _as_lines(found_lines, ask.pitch_mm, ask.relief_mm, ask.width_mm, polarity, ask.extra, "lines",
                     what=f"{count} straight fibres ({found_lines.length_mm:.0f} mm of line), no members and no network")


def _without_fibre_pieces(made: ContentMade, slender: np.ndarray, fibres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(labels, relief01) without the slender members lying along a fibre (at least half of them
    within 2 points of it): they were pieces of it, drawn as the line, not as domes."""
    count = int(made.labels.max())
    near = ndimage.binary_dilation(fibres, iterations=2)
    on_fibre = np.bincount(made.labels[near], minlength=count + 1) >= 0.5 * np.bincount(made.labels.ravel(), minlength=count + 1)
    dropped = slender & on_fibre
    dropped[0] = False
    if not dropped.any():
        return made.labels, made.relief01
    gone = dropped[made.labels]
    labels = sequential_labels(np.where(gone, 0, made.labels)).astype(np.int32)
    return labels, np.where(gone | (ndimage.binary_dilation(gone, iterations=2) & (labels == 0)), 0.0, made.relief01)


def _covers_its_line(parts: np.ndarray, ids: np.ndarray, theta: float, dist: float, clear: np.ndarray) -> bool:
    """Whether the pieces `ids` run along FIBRE_COVER of their line's course over the clear ground
    between their ends: a fibre is continuous where nothing lies over it; a row of dashes (the
    banding of a coarse picture, a chain of specks) is not."""
    ys, xs = np.nonzero(np.isin(parts, ids))
    direction = np.array([-np.sin(theta), np.cos(theta)])  # along the line, (x, y)
    t = xs * direction[0] + ys * direction[1]
    steps = np.arange(float(t.min()), float(t.max()) + 1.0)
    px = np.rint(dist * np.cos(theta) + steps * direction[0]).astype(int)
    py = np.rint(dist * np.sin(theta) + steps * direction[1]).astype(int)
    inside = (px >= 0) & (py >= 0) & (px < clear.shape[1]) & (py < clear.shape[0])
    course = int(clear[py[inside], px[inside]].sum())
    return ys.size >= FIBRE_COVER * max(course, 1)


def _straight_runs(skeleton: np.ndarray, parts: np.ndarray, n: int, pitch_mm: float,
                   clear: np.ndarray) -> tuple[np.ndarray, int, list[tuple[float, float]]]:
    """(mask, how many lines, the lines as (theta, distance) of their normal) of the skeleton's pieces that lie along straight lines carrying FIBRE_GROUND_MM of it in all
    (a Hough transform's peaks: a fibre crosses the ground in many pieces between the members it
    passes over, all on one line), each piece at least FIBRE_PIECE_MM long, straight
    (FIBRE_STRAIGHT) and running along its line (within 25 degrees). Halos and rims around
    members are arcs: no straight line collects enough of them."""
    from skimage.transform import hough_line, hough_line_peaks

    size = np.bincount(parts.ravel(), minlength=n + 1)
    pieces = np.zeros(n + 1, bool)
    angle = np.zeros(n + 1)
    for k, box in enumerate(ndimage.find_objects(parts), 1):
        if box is None or size[k] * pitch_mm * 1.12 < FIBRE_PIECE_MM:
            continue
        ys, xs = np.nonzero(parts[box] == k)
        if float(np.hypot(np.ptp(ys), np.ptp(xs))) >= FIBRE_STRAIGHT * ys.size:
            pieces[k] = True
            cov = np.cov(np.stack([xs, ys]).astype(np.float64)) if ys.size > 2 else np.eye(2)
            _, vecs = np.linalg.eigh(cov)
            angle[k] = float(np.arctan2(vecs[1, -1], vecs[0, -1]))
    candidates = pieces[parts]
    votes = FIBRE_GROUND_MM / (pitch_mm * 1.12)
    if candidates.sum() < votes:
        return np.zeros_like(skeleton), 0, []
    accumulator, thetas, dists = hough_line(candidates, theta=np.linspace(-np.pi / 2, np.pi / 2, 180, endpoint=False))
    votes_at, peak_thetas, peak_dists = hough_line_peaks(accumulator, thetas, dists, threshold=votes, min_distance=3, min_angle=5)
    log.debug("fibre lines: %s votes each, %d candidate px", [int(v) for v in votes_at], int(candidates.sum()))
    keep = np.zeros(n + 1, bool)
    count = 0
    lines: list[tuple[float, float]] = []
    yy, xx = np.nonzero(candidates)
    for theta, dist in zip(peak_thetas, peak_dists):
        on = np.abs(xx * np.cos(theta) + yy * np.sin(theta) - dist) <= 1.5
        ids = np.unique(parts[yy[on], xx[on]])
        # the line's direction is perpendicular to its normal theta; a piece along it, not across
        along = np.abs(np.sin(angle[ids] - (theta + np.pi / 2))) <= np.sin(np.radians(25))
        if size[ids[along]].sum() >= votes and _covers_its_line(parts, ids[along], theta, dist, clear):
            keep[ids[along]] = True
            count += 1
            lines.append((theta, dist))
    return keep[parts], count, lines


def _as_dense_field(blobs: BlobScale, picture: np.ndarray, pitch_mm: float, relief_mm: float, polarity: Polarity, extra: str) -> ContentMade:
    """A dense field of small members (dense.py): each point rises by its own local contrast (a
    top-hat DENSE_TOPHAT_WIDTHS members wide, its DENSE_LIFT_PCT percentile at tanh(1) of the lift), so
    every particle is a small dome and the gaps between them stay low; the members the check
    counts are the domes a finger finds (each FELT_MM over the saddle to a higher one)."""
    width_mm = max(DENSE_TOPHAT_WIDTHS * blobs.diameter_mm, 2 * MIN_FELT_MM)
    texture = local_tophat(picture.astype(np.float32), pitch_mm, width_mm)
    scale = float(np.percentile(texture, DENSE_LIFT_PCT))
    # tanh, not a clip: the brightest clusters keep their domes instead of flat tops.
    relief01 = np.tanh(texture / scale).astype(np.float32) if scale > 0 else np.zeros_like(texture)
    # The members a finger finds: each dome standing FELT_MM over the saddle to a higher one,
    # down to a quarter of the lift.
    seeds, _ = ndimage.label(h_maxima(relief01, min(FELT_MM / relief_mm, 1.0) if relief_mm > 0 else 1.0))
    labels = segmentation.watershed(-relief01, seeds, mask=relief01 >= 0.25).astype(np.int32)
    labels = sequential_labels(labels).astype(np.int32)
    reason = (f"content: a dense field of small members ({blobs.words()}: one size, as particles have and texture has "
              f"not); each point raised by its local contrast over {width_mm:.1f} mm, so every member is a small dome and "
              f"the gaps stay low; {polarity.reason}{extra}")
    note = (f"content: a dense field of {int(labels.max())} domes (members) {blobs.diameter_mm:.1f} mm across, too many and too "
            f"close to draw one by one: they read as a texture of small domes.")
    return ContentMade(relief01, "members", labels, reason, (note,))


def find_columns(x: np.ndarray, pitch_mm: float, spacing_mm: float, *, noise: float, apart_mm: float = 0.0) -> np.ndarray:
    """(n, 2) row, col of a lattice's columns on the working grid (content bright in `x`): the
    local maxima at least half a `spacing_mm` apart that stand COLUMN_CONTRAST of a typical
    column's contrast (its 75th percentile) and three noise deviations over the troughs within
    three quarters of a spacing; dim columns stay, the noise in the troughs does not. With
    `apart_mm`, only the brightest columns at least that far apart (a coarser sublattice)."""
    from skimage.feature import peak_local_max

    d_px = spacing_mm / pitch_mm
    smooth = ndimage.gaussian_filter(x.astype(np.float32), max(0.5, 0.12 * d_px), mode="nearest")
    apart = int(np.ceil(apart_mm / pitch_mm)) - 1 if apart_mm > 0 else 0
    peaks = peak_local_max(smooth, min_distance=max(1, int(0.5 * d_px), apart), exclude_border=False)
    if len(peaks) == 0:
        return peaks
    trough = ndimage.minimum_filter(smooth, size=2 * int(np.ceil(0.75 * d_px)) + 1, mode="nearest")
    contrast = smooth[tuple(peaks.T)] - trough[tuple(peaks.T)]
    keep = contrast >= max(3.0 * noise, COLUMN_CONTRAST * float(np.percentile(contrast, 75)))
    return peaks[keep]


def _spacing_px(peaks: np.ndarray) -> float:
    from scipy.spatial import cKDTree

    return float(np.median(cKDTree(peaks).query(peaks, k=2)[0][:, 1])) if len(peaks) >= 2 else 0.0


def _layers(values: np.ndarray, peaks: np.ndarray, contrast: np.ndarray) -> np.ndarray | None:
    """Which columns belong to a brighter layer (bool per column), or None for one layer: the
    columns' brightness in two groups (Otsu) LAYER_SEPARATION robust deviations apart, the smaller
    holding at least LAYER_SHARE, and each column's four nearest neighbours mostly of its own group
    (a layer; alternating bright and dim columns are one lattice, raised evenly)."""
    from scipy.spatial import cKDTree

    if len(values) < MIN_COLUMNS or np.ptp(values) <= 1e-6:
        return None
    upper = values > filters.threshold_otsu(values)
    share = float(upper.mean())
    if not LAYER_SHARE <= share <= 1 - LAYER_SHARE:
        return None
    hi, lo = values[upper], values[~upper]
    spread = 1.4826 * float(np.median(np.concatenate([np.abs(hi - np.median(hi)), np.abs(lo - np.median(lo))])))
    gap = float(np.median(hi) - np.median(lo))
    if gap < LAYER_SEPARATION * max(spread, 1e-6) or gap < LAYER_CONTRAST * float(np.median(contrast)):
        return None
    _, near = cKDTree(peaks).query(peaks, k=5)
    same = float(np.mean(upper[near[:, 1:]] == upper[:, None]))
    return upper if same >= LAYER_COHERENCE else None


def _lattice_picture(work: np.ndarray, spectrum: Spectrum, fine, pitch_mm: float, width_mm: float, noise: float):
    """(picture, its pitch in mm, its Period, its noise) to find a lattice's columns on, or None:
    the working grid when its spectrum is a lattice's (is_lattice) with columns at least
    2 * MIN_COLUMN_PX grid points apart; else, as the print grid's blur fades closer columns
    (atomic columns 1.3-1.8 mm apart at 100 mm), the picture before that blur (Prepared.finer) on
    a grid twice as fine, when its spectrum is a lattice's."""
    on_work = (work, pitch_mm, spectrum.period, noise) if is_lattice(spectrum, width_mm) else None
    # Columns fewer than 2 * MIN_COLUMN_PX grid points apart are faded by the print grid's blur:
    # found on the finer picture when there is one.
    if on_work is not None and (fine is None or spectrum.period.pitch_mm >= 2 * MIN_COLUMN_PX * pitch_mm):
        return on_work
    if fine is None:
        return on_work
    picture = fine(2 * work.shape[1] - 1)
    if picture is None or picture.shape[1] < 2 * work.shape[1] - 1:
        return on_work
    fine_pitch_mm = width_mm / (picture.shape[1] - 1)
    found = lattice_spectrum(picture, fine_pitch_mm)
    if not is_lattice(found, width_mm):
        return on_work
    return picture, fine_pitch_mm, found.period, noise_level(picture.astype(np.float32))


def _column_domes(shape: tuple[int, int], peaks: np.ndarray, upper: np.ndarray | None, radius: float, pitch_mm: float,
                  relief_mm: float) -> tuple[np.ndarray, np.ndarray, float, float]:
    """(relief01, labels, step_mm, dome_mm) of a lattice's columns at `peaks` on the working grid.
    A brighter layer (`upper`) stands on a plateau a step higher (the cells of its columns); every
    column is a domed cap of one height (as a braille dot), at most PIN_ASPECT times its radius
    tall: a 3 mm spike on a 1 mm base is a prick, not a dome, and does not print."""
    step_mm = min(max(GRAIN_STEP_MM, relief_mm / 4), relief_mm / 3) if upper is not None and relief_mm > 0 else 0.0
    dome_mm = min(relief_mm - step_mm, PIN_ASPECT * (radius + 0.5) * pitch_mm)
    on_plateau = np.zeros(len(peaks) + 1, np.float32)
    if upper is not None:
        on_plateau[1:][upper] = step_mm
    ids = np.zeros(shape, np.int32)
    ids[tuple(peaks.T)] = np.arange(1, len(peaks) + 1)
    dist, (iy, ix) = ndimage.distance_transform_edt(ids == 0, return_indices=True)
    owner = ids[iy, ix]
    cap = np.sqrt(np.clip(1.0 - (dist / (radius + 0.5)) ** 2, 0.0, 1.0))  # down to the ground at radius + 0.5 px
    relief01 = ((on_plateau[owner] + dome_mm * cap) / max(relief_mm, 1e-9)).astype(np.float32)
    labels = np.where(dist <= radius, owner, 0).astype(np.int32)
    return relief01, labels, step_mm, dome_mm


def _as_lattice(shape: tuple[int, int], x: np.ndarray, x_pitch_mm: float, pitch_mm: float, period: Period, relief_mm: float,
                width_mm: float, polarity: Polarity, extra: str, noise: float) -> ContentMade | None:
    """A lattice raised column by column (issue 32): every column a dome of the same lift,
    COLUMN_SHARE of the spacing across, on a flat ground; a brighter layer's columns a step
    (GRAIN_STEP_MM, or a quarter of the relief) higher. Columns closer than MIN_COLUMN_PX grid
    points cannot be printed apart: then the brighter columns at least that far apart are raised
    (a coarser sublattice) and the sentences say how many the picture shows and at what width
    every one would be printed; if none can, the lattice is one flat plateau, and said so. None
    when fewer than MIN_COLUMNS columns are found (the picture is no lattice to raise)."""
    fine_peaks = find_columns(x, x_pitch_mm, period.pitch_mm, noise=noise)
    if len(fine_peaks) < MIN_COLUMNS:
        return None
    fine_spacing_mm = _spacing_px(fine_peaks) * x_pitch_mm
    peaks = fine_peaks
    if fine_spacing_mm < MIN_COLUMN_PX * pitch_mm:
        peaks = find_columns(x, x_pitch_mm, period.pitch_mm, noise=noise, apart_mm=MIN_COLUMN_PX * pitch_mm)
    spacing_mm = _spacing_px(peaks) * x_pitch_mm
    if peaks is fine_peaks and abs(period.pitch_mm - spacing_mm) <= 0.25 * spacing_mm:
        spacing_mm = fine_spacing_mm = period.pitch_mm  # the spectrum's period: finer than the grid's rounding
    resolve_mm = width_mm * MIN_PITCH_MM / max(fine_spacing_mm, 1e-9)
    if len(peaks) < MIN_COLUMNS or spacing_mm < 0.9 * MIN_COLUMN_PX * pitch_mm:
        found = LatticeFound(0, fine_spacing_mm, len(fine_peaks), fine_spacing_mm, drawn=False)
        reason = (f"content: a lattice of {fine_spacing_mm:.1f} mm pitch on the print ({len(fine_peaks)} columns), too close to "
                  f"print apart on a {pitch_mm:.1f} mm grid: raised as one flat plateau; at a print width of about "
                  f"{_round_up(resolve_mm)} mm its columns would be {MIN_PITCH_MM:g} mm apart and printed one by one; "
                  f"{polarity.reason}{extra}")
        return ContentMade(np.full(shape, 0.5, np.float32), "lattice", None, reason, (), lattice=found)
    smooth = ndimage.gaussian_filter(x.astype(np.float32), max(0.5, 0.12 * spacing_mm / x_pitch_mm), mode="nearest")
    upper = _layers(smooth[tuple(peaks.T)], peaks, smooth[tuple(peaks.T)] - float(np.percentile(smooth, 5)))
    radius = max(1.0, COLUMN_SHARE * spacing_mm / pitch_mm / 2)  # on the working grid
    # The columns on the working grid (found on a finer picture, if so).
    scale = (np.array(shape, np.float64) - 1) / (np.array(x.shape, np.float64) - 1)
    peaks = np.clip(np.rint(peaks * scale).astype(np.int64), 0, np.array(shape) - 1)
    relief01, labels, step_mm, dome_mm = _column_domes(shape, peaks, upper, radius, pitch_mm, relief_mm)
    found = LatticeFound(len(peaks), spacing_mm, len(fine_peaks), fine_spacing_mm, 1 if upper is None else 2,
                         0 if upper is None else int(upper.sum()), step_mm, dome_mm=dome_mm)
    what = (f"a lattice of {spacing_mm:.1f} mm pitch on the print: {len(peaks)} columns, each raised as a dome {dome_mm:.1f} mm "
            f"high and {2 * (radius + 0.5) * pitch_mm:.1f} mm across")
    if len(peaks) < len(fine_peaks):
        what += (f" (the brighter of the picture's {len(fine_peaks)} columns: those {fine_spacing_mm:.1f} mm apart are too close "
                 f"to print apart on a {pitch_mm:.1f} mm grid)")
    if upper is not None:
        what += f"; a brighter layer of {int(upper.sum())} columns stands on a plateau {step_mm:.1f} mm high"
    notes = []
    if fine_spacing_mm < MIN_PITCH_MM or len(peaks) < len(fine_peaks):
        notes.append(Decision(f"content: the lattice's columns are {fine_spacing_mm:.1f} mm apart on the print, under the "
                              f"{MIN_PITCH_MM:g} mm a fingertip tells apart (braille dots' spacing): it is felt as a fine, even "
                              f"grain; at a print width of about {_round_up(resolve_mm)} mm every column is {MIN_PITCH_MM:g} mm "
                              f"from the next."))
    reason = (f"content: {what}, on a flat ground (its spectrum peaks at {period.pitch_mm:.1f} mm, {period.share:.0%} of the detail); "
              f"{polarity.reason}{extra}")
    return ContentMade(relief01, "lattice", labels, reason, tuple(notes), lattice=found)


def _round_up(mm: float, to: float = 10.0) -> int:
    return int(np.ceil(mm / to) * to)


def _with_interior(labels: np.ndarray) -> np.ndarray:
    """Drop members that are all outline (a pixel-wide sliver has no dome to feel), renumbered."""
    from .objects import inner_outline

    n = int(labels.max())
    has = np.zeros(n + 1, bool)
    has[labels[(labels > 0) & ~inner_outline(labels)]] = True
    out = np.where(has[labels], labels, 0)
    return sequential_labels(out).astype(np.int32)


def _as_lines(lines: Lines, pitch_mm, relief_mm, width_mm, polarity, extra, kind, what: str = "") -> ContentMade:
    height = min(LINE_HEIGHT_MM, relief_mm)
    profile = draw_lines(lines, pitch_mm) * (height / relief_mm if relief_mm > 0 else 0.0)
    notes = []
    share = float(lines.merged.mean())
    if share >= MERGED_SAID_SHARE:  # a few filled pixels change nothing a reader must act on
        notes.append(Decision(
            f"content: some lines run closer than {MIN_GAP_MM:g} mm, which a finger cannot separate; the space between them "
            f"({share:.0%} of the picture) was filled so they read as one band; at a print width of about "
            f"{width_mm * lines.separate_at:.0f} mm nine in ten of the regions they enclose would be felt apart."
        ))
    what = what or f"a network of lines enclosing {lines.cell_count} regions ({lines.length_mm:.0f} mm of line, ridge strength {lines.strength:.0f} × noise)"
    reason = (f"content: {what}, raised as lines {LINE_WIDTH_MM:g} mm wide and {height:.1f} mm high on a flat ground; "
              f"{polarity.reason}{extra}")
    return ContentMade(profile.astype(np.float32), kind, None, reason, tuple(notes), lines.skeleton)


def find_specimen(work: np.ndarray, pitch_mm: float) -> np.ndarray:
    """The specimen (bool) against an empty mount: a dark, featureless area (Otsu of the picture at
    fingertip scale, the darker side with almost no detail) of at least EMPTY_MOUNT_SHARE; else all."""
    smooth = ndimage.gaussian_filter(work, 1.0 / pitch_mm, mode="nearest")
    if np.ptp(smooth) < 0.05:
        return np.ones(work.shape, bool)
    dark = smooth < filters.threshold_otsu(smooth)
    if dark.mean() < EMPTY_MOUNT_SHARE or dark.mean() > 0.8:
        return np.ones(work.shape, bool)
    detail = np.abs(work - smooth)
    if np.median(detail[dark]) > 0.5 * np.median(detail[~dark]) + 0.01 or np.median(work[dark]) > 0.25:
        return np.ones(work.shape, bool)
    specimen = ndimage.binary_opening(~dark, iterations=2)
    # A specimen on a mount is one piece, or a few large ones; many small pieces with none holding
    # most of them are a population on an empty ground (cells on a filter, beads, particles), whose
    # ground the whole picture's polarity finds: taken as a specimen, the members' own brightness
    # would be its "ground" and the members would go to the base.
    pieces, n = ndimage.label(specimen)
    if n >= SCATTERED_PIECES and float(np.bincount(pieces.ravel())[1:].max()) < 0.5 * float(specimen.sum()):
        return np.ones(work.shape, bool)
    return specimen


def has_grain_structure(work: np.ndarray, specimen: np.ndarray, pitch_mm: float) -> bool:
    """Whether the specimen holds grey-level structure a finger could be given (GRAIN_OVER_NOISE)."""
    inner = ndimage.binary_erosion(specimen, iterations=max(1, round(1.5 / pitch_mm)))
    pairs = inner[:, 2:] & inner[:, :-2]
    if inner.sum() < 16 or not pairs.any():
        return False
    blurred = ndimage.gaussian_filter(work, 1.0 / pitch_mm, mode="nearest")[inner]
    if float(work[inner].std()) < 1e-3:  # flat: one grey level (a step, not grains)
        return False
    diff = (work[:, 2:] - work[:, :-2])[pairs]  # neighbours two points apart: the resampling blur leaves their noise apart
    noise = 1.4826 * float(np.median(np.abs(diff - np.median(diff)))) / np.sqrt(2)
    return float(blurred.std()) >= GRAIN_OVER_NOISE * noise


def _one_plateau(work, specimen, pitch_mm, min_area_mm2, polarity, extra) -> ContentMade:
    """Two regions and no structure inside either (a needle on an empty ground, one grey step):
    the side the polarity raises becomes one flat plateau, the other stays at the base."""
    raised = specimen if polarity.bright == bool(np.median(work[specimen]) >= np.median(work[~specimen])) else ~specimen
    # Opened to drop specks, with the picture's edge not taken as ground (a region running off the
    # picture keeps its corners).
    raised = ndimage.binary_dilation(ndimage.binary_erosion(raised, iterations=2, border_value=1), iterations=2) & raised
    labels, n = ndimage.label(raised)
    if n:
        area = np.bincount(labels.ravel())[1:] * pitch_mm**2
        keep = np.concatenate([[0], np.cumsum(area >= min_area_mm2) * (area >= min_area_mm2)])
        labels = keep[labels].astype(np.int32)
    count = int(labels.max())
    reason = (f"content: two regions with no structure beyond the noise inside either, so the "
              f"{'bright' if polarity.bright else 'dark'} side is raised as {count} flat plateau{'s' * (count != 1)} "
              f"and the other stays at the base; {polarity.reason}{extra}")
    return ContentMade((labels > 0).astype(np.float32), "plateau", labels, reason, ())


def _weak_contrast(work, x, pitch_mm, relief_mm, width_mm, min_area_mm2, polarity, extra, specimen=None, grains=True) -> ContentMade:
    """Weak contrast: local equalisation inside the specimen, then its grains outlined as raised
    lines (when `grains` and their boundaries form a network), else the fingertip-scale shape."""
    from .levels import plateau_classes
    from .scales import StyleOptions, large_shape

    specimen = find_specimen(work, pitch_mm) if specimen is None else specimen
    if grains and specimen.any() and not specimen.all() and not has_grain_structure(work, specimen, pitch_mm):
        return _one_plateau(work, specimen, pitch_mm, min_area_mm2, polarity, extra)
    inside = work[specimen]
    lo, hi = (np.percentile(inside, [5, 95]) if inside.size else (0.0, 1.0))  # as WEAK_SPREAD: small inclusions aside
    spread = max(float(hi - lo), 1e-6)
    local = np.clip((work - lo) / spread, 0, 1)
    # CLAHE over about a tenth of the field: grains a few percent apart become distinct.
    kernel = max(8, int(min(work.shape) / 10))
    equal = exposure.equalize_adapthist(np.where(specimen, local, float(np.median(local[specimen]) if specimen.any() else 0)),
                                        kernel_size=kernel, clip_limit=0.02).astype(np.float32)
    edges = filters.sobel(ndimage.gaussian_filter(equal, 0.7))
    edges = np.where(ndimage.binary_erosion(specimen, iterations=2), edges, 0)
    lines = find_lines(edges / max(float(edges.max()), 1e-6), pitch_mm=pitch_mm, min_area_mm2=min_area_mm2)
    where = ("the specimen was found against an empty mount (kept at the base)" if not specimen.all()
             else "no empty mount")
    if grains and lines.cell_count >= NETWORK_CELLS and lines.cover <= MAX_LINE_COVER:
        made = _as_lines(lines, pitch_mm, relief_mm, width_mm, polarity, extra, "grains",
                         what=(f"weak contrast (the specimen spans {spread:.2f} of the range; {where}): after local equalisation "
                               f"its boundaries outline {lines.cell_count} grains"))
        profile = np.where(specimen, made.relief01, 0.0)
        return ContentMade(profile.astype(np.float32), "grains", None, made.reason, made.notes, lines.skeleton)
    shape = large_shape(equal, pitch_mm, StyleOptions())
    if grains and specimen.any() and not specimen.all():
        # Weak contrast on a specimen against an empty mount, no outlines: the grains differ in
        # grey level, so after the local equalisation they become distinct plateaus (the mount
        # stays at the base, every grain stands above it by at least one step).
        count = GRAIN_LEVELS if relief_mm / GRAIN_LEVELS >= GRAIN_STEP_MM else 2
        inside_shape = np.where(specimen, shape, float(np.median(shape[specimen])))
        classes = plateau_classes(inside_shape, count, pitch_mm=pitch_mm, nozzle_mm=0.4, min_area_mm2=min_area_mm2)
        used = np.unique(classes[specimen])
        if used.size >= 2:
            rank = np.zeros(count, np.float32)
            rank[used] = np.arange(1, used.size + 1, dtype=np.float32) / used.size
            profile = np.where(specimen, rank[classes], 0.0).astype(np.float32)
            step_mm = relief_mm / used.size
            reason = (f"content: weak contrast (the specimen spans {spread:.2f} of the range; {where}): after local equalisation "
                      f"its grains fall into {used.size} grey levels, raised as plateaus {step_mm:.1f} mm apart above the mount, "
                      f"the brighter grains higher{extra}")  # the specimen's grey levels decide, not a ground's polarity
            return ContentMade(profile, "grains", None, reason, (), None, int(used.size))
    shape = np.where(specimen, shape, 0.0).astype(np.float32)
    reason = (f"content: no population and no line network; contrast equalised locally ({where}) and its "
              f"fingertip-scale shape raised; {polarity.reason}{extra}")
    return ContentMade(shape, "shape", None, reason, ())


def check_sentences(heights_mm: np.ndarray, made: ContentMade, mm_per_px: float, *, base_mm: float) -> tuple[str, ...]:
    """Compare the print with what was found: how many members and how high the lowest stands
    above the ground around it; the lines' height over what they enclose."""
    if made.kind == "lattice" and made.lattice is not None:
        return lattice_sentences(heights_mm, made, mm_per_px)
    if made.kind == "members" and made.labels is not None and made.labels.max():
        lifts = member_tops(heights_mm, made.labels, mm_per_px)
        n = lifts.size
        felt = int((lifts >= 0.5).sum())
        if felt == n:
            out = [f"Found {n} member{'s' * (n != 1)}, all raised at least {lifts.min():.1f} mm above the ground around them."]
        else:
            out = [f"Found {n} members; {felt} stand at least 0.5 mm above the ground around them, {n - felt} do not "
                   f"(lowest {lifts.min():.1f} mm): a finger may miss them⟦; a taller `relief_mm` raises them further⟧."]
        split = made.split_pairs
        if split and split >= max(2, 0.1 * n):
            out.append(f"{split} pairs of touching domes share a border as wide as the domes themselves, with no neck between "
                       f"them: one object of the picture may have been split into several domes⟦; `relief_style` objects "
                       f"raises one dome per outlined object⟧.")
        return tuple(out)
    if made.kind == "plateau" and made.labels is not None and made.labels.max():
        n = int(made.labels.max())
        lift = float(np.median(member_tops(heights_mm, made.labels, mm_per_px)))
        return (f"{'One' if n == 1 else n} flat region{'s' * (n != 1)} raised {lift:.1f} mm above the ground around {'it' if n == 1 else 'them'}.",)
    if made.kind == "grains" and made.levels:
        return (f"Grains: {made.levels} levels, raised as plateaus above the mount.",)
    if made.line_mask is not None and made.line_mask.any():
        on = heights_mm[made.line_mask]
        off = heights_mm[~ndimage.binary_dilation(made.line_mask, iterations=3)]
        rise = float(np.median(on) - (np.median(off) if off.size else base_mm))
        what = "grain outlines" if made.kind == "grains" else "a network of lines"
        return (f"{what[0].upper() + what[1:]}, raised {rise:.1f} mm over the areas they enclose.",)
    return ()


def lattice_sentences(heights_mm: np.ndarray, made: ContentMade, mm_per_px: float) -> tuple[str, ...]:
    """The lattice as printed against the picture: how many columns stand FELT_MM over the troughs
    beside them (a ring half a spacing wide), how evenly, and how many the picture shows; what
    may be wrong and the one option that changes it."""
    found = made.lattice
    width_mm = (heights_mm.shape[1] - 1) * mm_per_px
    resolve = _round_up(width_mm * MIN_PITCH_MM / max(found.picture_spacing_mm, 1e-9))
    if not found.drawn or made.labels is None or not made.labels.max():
        return (f"The picture shows a lattice of about {found.picture_columns} columns {found.picture_spacing_mm:.1f} mm apart on "
                f"the print, too close to print apart: the print is one flat plateau where they are; a wider print "
                f"⟦(`width_mm` {resolve}) ⟧raises every column.",)
    lifts = member_tops(heights_mm, made.labels, mm_per_px, ring_mm=max(mm_per_px, 0.5 * found.spacing_mm))
    n = lifts.size
    felt = int((lifts >= FELT_MM).sum())
    out = [f"A lattice of {n} columns {found.spacing_mm:.1f} mm apart: {felt} of them ({felt / max(n, 1):.0%}) stand at least "
           f"{FELT_MM:g} mm over the troughs beside them (median {float(np.median(lifts)):.1f} mm, lowest {float(lifts.min()):.1f} mm)."]
    if found.layers == 2:
        out.append(f"The {found.upper} columns of the brighter layer stand on a plateau {found.step_mm:.1f} mm high: a step a "
                   f"finger finds at the interface.")
    if felt < 0.9 * found.picture_columns:
        out.append(f"The picture shows about {found.picture_columns} columns {found.picture_spacing_mm:.1f} mm apart; the print raises "
                   f"{felt}, so columns may be missing; a wider print ⟦(`width_mm` {resolve}) ⟧raises every one of them.")
    elif found.picture_spacing_mm < MIN_PITCH_MM:
        out.append(f"Its columns are {found.picture_spacing_mm:.1f} mm apart, under the {MIN_PITCH_MM:g} mm a fingertip tells apart: "
                   f"felt as an even grain; a wider print ⟦(`width_mm` {resolve}) ⟧spaces them {MIN_PITCH_MM:g} mm apart.")
    return tuple(out)


def member_tops(heights_mm: np.ndarray, labels: np.ndarray, mm_per_px: float, *, ring_mm: float = 1.5) -> np.ndarray:
    """Per member: its top (highest point: what a finger finds) minus the median of a ring ring_mm
    wide around it (ring pixels belong to their nearest member)."""
    n = int(labels.max())
    mask = labels > 0
    dist, (iy, ix) = nearest_member(mask)
    owner = np.where((~mask) & (dist * mm_per_px <= ring_mm), labels[iy, ix], 0)
    top = label_max(heights_mm, labels, n, initial=-np.inf)[1:]
    ring = label_median(heights_mm, owner, n)
    ring = np.where(np.isfinite(ring), ring, float(np.median(heights_mm[~mask])) if (~mask).any() else 0.0)
    return top - ring
