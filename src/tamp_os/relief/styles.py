"""Relief styles: from the prepared picture to heights in millimetres, deciding what is raised.

Every style takes the image the pipeline prepares today (`preprocess.prepare`: percentile
stretch on the source, resampled to the grid, blurred, inverted when asked; 0..1, row 0 = top)
and the grid pitch, and returns heights in mm with what it found. So `invert` and the stretch
work with every style, upstream of it.

- reference: today's mapping, base + relief × brightness (bit-identical heights).
- structure: fingertip-scale shape. Edge-preserving smoothing at `detail_mm` gives the large
  shape most of the relief; regions enclosed by strong edges (objects) are lifted; detail
  finer than `detail_mm` stays as a texture at most `texture_mm` high.
- levels: `level_count` plateaus (2–5) from multi-level Otsu thresholds of that shape; regions
  under a fingertip's area are merged into their neighbours; outlines smoothed at nozzle scale.
- objects: objects found (enclosed by edges, else bright blobs) raised as domes or rounded
  plateaus over a flat background carrying only the `texture_mm` texture.
- content: translates what the picture shows (content.py): members of a population raised by
  one lift, line networks as raised lines on a flat ground, weak contrast equalised locally.
- auto: picks one of the above from the picture and says why.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from skimage import exposure, filters

from ..errors import ParameterError, Text
from .heightmap import heights_mm
from .levels import plateau_classes
from .objects import ObjectMap, dome_profile
from .picture_scale import find_objects_in_picture
from .scales import WORK_MAX_POINTS, StyleOptions, WorkGrid, gaussian_mm, large_shape, robust_unit

STYLES = ("reference", "structure", "levels", "objects", "content", "auto")
LEVEL_RANGE = (2, 5)
MIN_STEP_MM = 0.5  # height step fingers tell apart reliably
DOME_ROUND_DETAILS = 5  # domes up to 2 × 5 × detail_mm across; wider objects get rounded plateaus


@dataclass(frozen=True)
class ReliefResult:
    """What a style made.

    heights_mm : (rows, cols) float64 heights in mm, base included.
    style : the style that made them (auto resolves to one of the others).
    reason : one sentence saying why this style (auto) or what it did.
    objects : (rows, cols) int32 labels of the objects found (0 = background), or None.
    levels_mm : heights above the base of the plateaus (`levels`), else ().
    notes : further sentences for the report (adjustments made, nothing found...).
    checks : sentences comparing the print with what was found in the picture ("Found 10 members,
        all raised at least 1.0 mm..."), for the legibility check (content style).
    content_kind : what the content style raised: "members", "lines", "grains", "plateau" or "shape" ("" for
        the other styles), so the description can say it in words.
    """

    heights_mm: np.ndarray
    style: str
    reason: str
    objects: np.ndarray | None = None
    levels_mm: tuple[float, ...] = ()
    notes: tuple[str, ...] = field(default_factory=tuple)
    checks: tuple[str, ...] = field(default_factory=tuple)
    content_kind: str = ""
    lattice_pitch_mm: float | None = None  # content_kind "lattice": the raised columns' spacing on the print

    @property
    def object_count(self) -> int:
        return 0 if self.objects is None else int(self.objects.max())


def check_style(style: str, options: StyleOptions, mm_per_px: float) -> None:
    """Raise one ParameterError naming the parameter, its range and the value, if any is bad."""
    if style not in STYLES:
        raise ParameterError(f"`relief_style`: must be one of {', '.join(STYLES)}; got {style!r}.")
    if not (math.isfinite(options.detail_mm) and options.detail_mm >= mm_per_px and options.detail_mm <= 50):
        raise ParameterError(
            f"`detail_mm`: must be between the grid pitch ({mm_per_px:.3g} mm) and 50 mm; got {options.detail_mm!r}. "
            f"Use a larger `detail_mm` or a finer grid (a higher preset or `resolution_px`)."
        )
    if not (math.isfinite(options.texture_mm) and 0 <= options.texture_mm <= 2):
        raise ParameterError(f"`texture_mm`: must be between 0 and 2 mm; got {options.texture_mm!r}.")
    lo, hi = LEVEL_RANGE
    if isinstance(options.level_count, bool) or not isinstance(options.level_count, (int, np.integer)) or not lo <= options.level_count <= hi:
        raise ParameterError(f"`level_count`: must be a whole number from {lo} to {hi}; got {options.level_count!r}.")
    if not (math.isfinite(options.min_area_mm2) and 0 <= options.min_area_mm2 <= 1000):
        raise ParameterError(f"min_area_mm2: must be between 0 and 1000 mm²; got {options.min_area_mm2!r}.")
    if not (math.isfinite(options.nozzle_mm) and 0.05 <= options.nozzle_mm <= 2):
        raise ParameterError(f"`nozzle_mm`: must be between 0.05 and 2 mm; got {options.nozzle_mm!r}.")


def make_relief(
    image01: np.ndarray,
    *,
    style: str,
    mm_per_px: float,
    base_mm: float,
    relief_mm: float,
    layer_mm: float | None = None,
    options: StyleOptions = StyleOptions(),  # noqa: B008  (frozen: one shared default is safe)
    uniform: bool = False,
    hints=None,
    fine=None,
) -> ReliefResult:
    """Heights in mm from the prepared image, in the given relief style.

    Parameters
    ----------
    image01 : (rows, cols) float, 0..1, from `preprocess.prepare` (row 0 = top of the image).
    style : one of STYLES.
    mm_per_px : grid pitch in mm (`Layout.mm_per_px`).
    base_mm, relief_mm : base thickness and relief height in mm.
    layer_mm : when given, heights are rounded to whole layers (as `heights_mm` does).
    options : StyleOptions.
    uniform : the picture is uniform (prepare's info['uniform']): every style gives a flat plate.
    hints : content.ContentHints (detector, signal) from the file's metadata, or None; the content
        style reads its polarity from it and says it in its reason.
    fine : a function of a column count giving the picture that wide without the print grid's
        blur (`preprocess.Prepared.finer`), or None; the content style looks there for lines too
        thin for the print grid (grain boundaries under a print pixel wide).

    Returns
    -------
    ReliefResult with heights (rows, cols) float64 in mm.
    """
    check_style(style, options, mm_per_px)
    if style == "reference" or uniform:
        reason = "brightness mapped to height, as the reference workflow does" if style == "reference" else "the picture is uniform: a flat plate"
        return ReliefResult(heights_mm(image01, base_mm=base_mm, relief_mm=relief_mm, layer_mm=layer_mm),
                            "reference" if style == "auto" else style, reason)
    # Shape and objects are read at fingertip scale: a grid at the nozzle's pitch carries all of it.
    grid = WorkGrid.plan(image01.shape, mm_per_px, options.nozzle_mm, max_points=WORK_MAX_POINTS)
    work = grid.down(image01)
    # Every style (and auto's choice) reads the same objects: find them once (content asks only if it needs them).
    objects_found = functools.cache(lambda: find_objects_in_picture(work, pitch_mm=grid.pitch_mm, min_area_mm2=options.min_area_mm2,
                                                                    nozzle_mm=options.nozzle_mm))

    if style in ("content", "auto"):
        content = _content_first(image01, grid, work, objects_found, style=style, mm_per_px=mm_per_px, base_mm=base_mm,
                                 relief_mm=relief_mm, layer_mm=layer_mm, options=options, hints=hints, fine=fine)
        if content is not None or style == "content":
            return content
    found = objects_found()
    reason = ""
    if style == "auto":
        style, reason = choose_style(work, pitch_mm=grid.pitch_mm, options=options, found=found)
    made = _STYLE_FUNCS[style](work, grid.pitch_mm, relief_mm, options, found)
    return _on_output_grid(made, style, reason, grid, base_mm=base_mm, relief_mm=relief_mm, layer_mm=layer_mm)


def _content_first(image01, grid, work, found, *, style: str, mm_per_px, base_mm, relief_mm, layer_mm, options, hints,
                   fine) -> ReliefResult | None:
    """The content style's relief; for auto, only when it found content (not the fallback
    shape), else None. Auto tries the content translation first: the benchmark (README, relief
    styles) shows it ahead wherever it finds members, a line network or grains; elsewhere auto
    picks as before."""
    content = _content(image01, grid, work, found, mm_per_px=mm_per_px, base_mm=base_mm, relief_mm=relief_mm,
                       layer_mm=layer_mm, options=options, hints=hints, fallback=style == "content", fine=fine)
    if style == "content" or content is None or content.content_kind == "shape":
        return content if style == "content" else None
    return ReliefResult(content.heights_mm, "content", f"auto chose content ({_KIND_WORDS[content.content_kind]}): {content.reason}",
                        content.objects, (), content.notes, content.checks, content.content_kind, content.lattice_pitch_mm)


def _on_output_grid(made: "_Made", style: str, reason: str, grid, *, base_mm: float, relief_mm: float,
                    layer_mm: float | None) -> ReliefResult:
    """A style's relief (on the working grid) brought to the output grid as heights in mm, with
    its objects' labels and, for levels, the plateaus' heights."""
    relief01 = _full_span(np.clip(grid.up(made.relief01, nearest=style == "levels"), 0.0, 1.0))
    labels = None
    if made.objects is not None and made.objects.count:
        labels = grid.up(made.objects.labels.astype(np.float32), nearest=True).astype(np.int32)
    heights = heights_mm(relief01, base_mm=base_mm, relief_mm=relief_mm, layer_mm=layer_mm)
    levels = ()
    if style == "levels":  # the plateaus' heights, from the few classes on the working grid (no 16M-point sort)
        plateaus = np.unique(np.clip(made.relief01, 0.0, 1.0).astype(np.float32))
        levels = tuple(float(h) for h in heights_mm(plateaus, base_mm=base_mm, relief_mm=relief_mm, layer_mm=layer_mm) - base_mm)
    return ReliefResult(heights, style, reason or made.summary, labels, levels, made.notes)


_KIND_WORDS = {"plateau": "one region against an empty ground", "members": "a population of members found", "lattice": "a lattice found", "lines": "a line network found", "grains": "grains found by their weak contrast"}


def _content(image01, grid, work, found, *, mm_per_px, base_mm, relief_mm, layer_mm, options, hints,
             fallback=True, fine=None) -> ReliefResult | None:
    """The content style (content.py) brought back to the output grid (its `content_kind` says what
    it found), or None when it found nothing and has no fallback. Members reach the full relief;
    lines stop at LINE_HEIGHT_MM (a tactile line's height), so they are not stretched."""
    from .content import check_sentences, make_content

    width_mm = (image01.shape[1] - 1) * mm_per_px
    made = make_content(work, pitch_mm=grid.pitch_mm, relief_mm=relief_mm, width_mm=width_mm, found=found,
                        min_area_mm2=options.min_area_mm2, hints=hints, fallback=fallback, fine=fine)
    if made is None:
        return None
    relief01 = np.clip(grid.up(made.relief01), 0.0, 1.0)
    relief01 = relief01 - float(relief01.min())
    if made.kind in ("members", "shape"):
        relief01 = _full_span(relief01)
    heights = heights_mm(relief01, base_mm=base_mm, relief_mm=relief_mm, layer_mm=layer_mm)
    labels = None
    if made.labels is not None and made.labels.max():
        labels = grid.up(made.labels.astype(np.float32), nearest=True).astype(np.int32)
    # The check reads the heights on the working grid, where the members and lines were found
    # (at 4096² a distance transform of the full grid alone would cost a second).
    checks = check_sentences(grid.down(heights).astype(np.float64), made, grid.pitch_mm, base_mm=base_mm)
    pitch = made.lattice.spacing_mm if made.lattice is not None else None
    return ReliefResult(heights, "content", made.reason, labels, (), made.notes, checks, made.kind, pitch)


def _full_span(relief01: np.ndarray) -> np.ndarray:
    """Stretch to exactly 0..1, so every style reaches the requested relief height (the print's
    bounds are what the user asked for) and the lowest point sits on the base."""
    lo, hi = float(relief01.min()), float(relief01.max())
    return (relief01 - lo) / (hi - lo) if hi > lo else np.zeros_like(relief01)


@dataclass(frozen=True)
class _Made:
    relief01: np.ndarray  # working grid, 0..1 of the relief
    summary: str
    objects: ObjectMap | None = None
    notes: tuple[str, ...] = ()


def fine_texture(work: np.ndarray, pitch_mm: float, options: StyleOptions) -> np.ndarray:
    """Detail between the nozzle and `detail_mm` scales, softly bounded to -0.5..0.5."""
    band = gaussian_mm(work, options.nozzle_mm / 2, pitch_mm) - gaussian_mm(work, options.detail_mm / 2, pitch_mm)
    scale = float(np.percentile(np.abs(band), 99)) if band.size else 0.0
    if scale <= 1e-6:
        return np.zeros_like(band)
    return (0.5 * np.tanh(band / scale)).astype(np.float32)


def _with_texture(shape01: np.ndarray, work, pitch_mm, relief_mm, options) -> np.ndarray:
    """Shape over (relief − texture), plus the texture band on top."""
    share = min(options.texture_mm / relief_mm, 0.5) if relief_mm > 0 else 0.0
    if share <= 0:
        return shape01
    return (1.0 - share) * shape01 + share * (0.5 + fine_texture(work, pitch_mm, options))


def structure_shape(
    work: np.ndarray, pitch_mm: float, options: StyleOptions, *, found: ObjectMap | None = None
) -> tuple[np.ndarray, ObjectMap]:
    """The `structure` style's shape before texture, 0..1, and the objects it lifted.

    Regions enclosed by strong edges read as objects (SEM spheres inside their rims): they are
    lifted by half the relief as domes, keeping their own fingertip-scale shading on top.
    """
    shape = large_shape(work, pitch_mm, options)
    if found is None:
        found = find_objects_in_picture(work, pitch_mm=pitch_mm, min_area_mm2=options.min_area_mm2, nozzle_mm=options.nozzle_mm)
    if found.count:
        domes = dome_profile(found.labels, pitch_mm=pitch_mm, round_mm=DOME_ROUND_DETAILS * options.detail_mm)
        shape = robust_unit(0.5 * shape + 0.5 * domes, 0.5, 99.5)
    return shape, found


def _structure(work, pitch_mm, relief_mm, options, found) -> _Made:
    shape, found = structure_shape(work, pitch_mm, options, found=found)
    summary = f"fingertip-scale shape (detail {options.detail_mm:g} mm) with a texture of at most {options.texture_mm:g} mm"
    if found.count:
        summary += f"; {found.count} enclosed object{'s' * (found.count != 1)} lifted"
    return _Made(_with_texture(shape, work, pitch_mm, relief_mm, options), summary, found)


def _objects(work, pitch_mm, relief_mm, options, found) -> _Made:
    if not found.count:
        made = _structure(work, pitch_mm, relief_mm, options, found)
        note = "objects: no objects were found (nothing enclosed by edges, no compact bright blobs); the structure style was used instead."
        return _Made(made.relief01, made.summary, None, (note,))
    domes = dome_profile(found.labels, pitch_mm=pitch_mm, round_mm=DOME_ROUND_DETAILS * options.detail_mm)
    summary = f"{found.count} object{'s' * (found.count != 1)} raised as domes over a flat, lightly textured background"
    return _Made(_with_texture(domes, work, pitch_mm, relief_mm, options), summary, found)


def _levels(work, pitch_mm, relief_mm, options, found) -> _Made:
    count, notes = options.level_count, []
    while count > 2 and relief_mm / (count - 1) < MIN_STEP_MM:
        count -= 1
    if count != options.level_count:
        notes.append(Text(
            f"`level_count`: {options.level_count} levels in a {relief_mm:g} mm relief would make steps under "
            f"{MIN_STEP_MM} mm, which fingers do not tell apart; {count} levels were used."
        ))
    shape, found = structure_shape(work, pitch_mm, options, found=found)
    classes = plateau_classes(shape, count, pitch_mm=pitch_mm, nozzle_mm=options.nozzle_mm, min_area_mm2=options.min_area_mm2)
    used = int(np.unique(classes).size)
    if used < count:
        notes.append(f"levels: only {used} of {count} levels are large enough to feel in this picture.")
    summary = f"{used} plateaus, {relief_mm / max(count - 1, 1):.2g} mm apart"
    return _Made((classes / max(count - 1, 1)).astype(np.float32), summary, found, tuple(notes))


_STYLE_FUNCS = {"structure": _structure, "objects": _objects, "levels": _levels}


def choose_style(
    work: np.ndarray, *, pitch_mm: float, options: StyleOptions, found: ObjectMap | None = None
) -> tuple[str, str]:
    """(style, one sentence why, with the measured facts) from the picture on the working grid.

    - objects: a population of similar objects (equivalent diameters within MAX_SIZE_SPREAD
      of each other) enclosed by edges, covering 3–60 % of the picture, and hardly brighter
      than the ground (as in secondary-electron SEM): brightness alone would not raise them.
    - levels: at fingertip scale (a Gaussian of detail_mm / 2) the brightness falls into 2–3
      distinct levels: the histogram between them drops below MAX_VALLEY of its peaks and the
      levels hold at least MIN_LEVEL_SHARE of the variance.
    - structure: anything else (continuous tones).
    """
    if found is None:
        found = find_objects_in_picture(work, pitch_mm=pitch_mm, min_area_mm2=options.min_area_mm2, nozzle_mm=options.nozzle_mm)
    facts = _object_facts(work, found)
    if facts is not None and facts.spread <= MAX_SIZE_SPREAD and 0.03 <= found.cover <= MAX_OBJECT_COVER and facts.lift < 0.15:
        return "objects", (
            f"auto chose objects: {found.count} objects of similar size (diameters within a factor {facts.spread:.1f}) "
            f"outlined by edges cover {found.cover:.0%} of the picture and are hardly brighter than the ground "
            f"({facts.lift:+.2f} of the brightness range), as in secondary-electron SEM, so brightness alone would not raise them"
        )
    shape = gaussian_mm(work, options.detail_mm / 2, pitch_mm)
    levels = _distinct_levels(shape, max(2, min(options.level_count, 3)))
    if levels is not None and levels.valley <= MAX_VALLEY and levels.share >= MIN_LEVEL_SHARE:
        return "levels", (
            f"auto chose levels: at fingertip scale the picture falls into {levels.count} distinct brightness levels "
            f"(the histogram between them drops to {levels.valley:.0%} of its peaks) that hold {levels.share:.0%} of its variation"
        )
    why = _why_not_objects(found, facts)
    held = f"{levels.count} levels would hold only {levels.share:.0%} of the variation" if levels is not None else "a flat picture"
    return "structure", (
        f"auto chose structure: continuous tones ({held}; {why}), so the fingertip-scale shape is raised "
        f"and finer detail kept as low texture"
    )


def _why_not_objects(found: ObjectMap, facts: "_ObjectFacts | None") -> str:
    """Half a sentence: the measured reason the objects style was not chosen."""
    many = f"{found.count} object{'s' * (found.count != 1)}"
    if found.count and found.method != "edges":
        return f"{many} found only by brightness, which raises them anyway"
    if facts is None:
        return "only one object outlined by edges" if found.count == 1 else "no objects outlined by edges"
    if facts.spread > MAX_SIZE_SPREAD:
        return f"{many} outlined by edges but of very different sizes (diameters within a factor {facts.spread:.1f})"
    if facts.lift >= 0.15:
        return f"{many} outlined by edges but brighter than the ground ({facts.lift:+.2f}), so brightness raises them"
    return f"{many} outlined by edges but covering {found.cover:.0%} of the picture"


MAX_OBJECT_COVER = 0.6
MAX_SIZE_SPREAD = 2.0  # largest / smallest equivalent diameter of a population of particles
MAX_VALLEY = 0.25  # histogram between two levels, as a share of the lower neighbouring peak
MIN_LEVEL_SHARE = 0.95  # share of the fingertip-scale variance between the levels


@dataclass(frozen=True)
class _ObjectFacts:
    spread: float  # largest / smallest equivalent diameter
    lift: float  # median brightness inside the objects minus outside, 0..1 units


@dataclass(frozen=True)
class _Levels:
    count: int
    valley: float  # histogram at the shallowest valley between levels, over the lower neighbouring peak
    share: float  # share of the variance between the levels (Otsu's separation)


def _object_facts(work: np.ndarray, found: ObjectMap) -> _ObjectFacts | None:
    """Facts about objects found by edges (at least two), else None."""
    if found.count < 2 or found.method != "edges":
        return None
    diameters = np.sqrt(np.bincount(found.labels.ravel())[1:])
    diameters = diameters[diameters > 0]
    lift = float(np.median(work[found.mask]) - np.median(work[~found.mask]))
    return _ObjectFacts(float(diameters.max() / diameters.min()), lift)


def _distinct_levels(shape: np.ndarray, most: int) -> _Levels | None:
    """The 2..most Otsu levels of the image that are most distinct, or None if it is flat."""
    if np.ptp(shape) <= 1e-6:
        return None
    counts, edges = np.histogram(shape, bins=64, range=(float(shape.min()), float(shape.max())))
    counts = np.convolve(counts, np.ones(3) / 3, mode="same")  # a bin of noise is not a valley
    centres = (edges[:-1] + edges[1:]) / 2
    best = None
    fine = exposure.histogram(shape.reshape(-1), 256, source_range="image")  # what multi-Otsu makes itself, once
    for count in range(2, most + 1):
        thresholds = filters.threshold_multiotsu(classes=count, hist=fine)
        side = np.digitize(centres, thresholds)
        if any(not (side == k).any() for k in range(count)):
            continue
        peaks = [counts[side == k].max() for k in range(count)]
        at = np.clip(np.searchsorted(centres, thresholds), 0, len(centres) - 1)
        valley = max(counts[b] / max(min(peaks[k], peaks[k + 1]), 1e-9) for k, b in enumerate(at))
        found = _Levels(count, float(valley), _separation(shape, thresholds))
        if best is None or (found.valley <= MAX_VALLEY, found.share) > (best.valley <= MAX_VALLEY, best.share):
            best = found
    return best


def _separation(image: np.ndarray, thresholds: np.ndarray) -> float:
    """Share of the variance between the Otsu classes (1 = perfectly separate levels)."""
    classes = np.digitize(image, thresholds).ravel()
    values = image.ravel().astype(np.float64)
    total = float(values.var())
    if total <= 0:
        return 0.0
    # Within-class variance from per-class sums, in one pass (a mask per class is 3x slower);
    # values are 0..1, so the sums in float64 lose nothing that matters.
    count = np.bincount(classes)
    sums = np.bincount(classes, weights=values)
    has = count > 0
    # (np.square, not np.dot: a BLAS call wakes OpenBLAS's threads, which then spin on the
    # other core for a while, doubling the CPU time of everything after it.)
    within = (float(np.sum(np.square(values))) - float(np.sum(sums[has] ** 2 / count[has]))) / values.size
    return 1.0 - max(within, 0.0) / total  # rounding must not push a perfect split past 1
