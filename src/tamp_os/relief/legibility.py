"""How a relief will read under a fingertip, measured on the final heights in millimetres.

Figures (all on the print): the share of the relief's variance finer than a fingertip (what a
Gaussian low-pass of sigma = 1 mm leaves), the height levels used and the smallest step between
neighbouring regions, the area of features narrower than two nozzle widths, the steepest slope,
and the objects' lift above the ground around them; then plain sentences with advice.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import ndimage
from skimage import measure

from ..errors import Text
from ..facts import Facts
from .objects import nearest_member, scipy_label_median
from .scales import WORK_MAX_POINTS, WorkGrid, disk

FINGERTIP_SIGMA_MM = 1.0
FINE_SHARE_WARN = 0.2  # above this, the print feels like sandpaper
STEP_MM = 0.5  # steps fingers tell apart reliably
MANY_LEVELS = 8  # more distinct levels than this read as a continuous surface
NARROW_HEIGHT_MM = 0.25  # narrow features lower than this are texture, not features
LIFT_MM = 1.0  # an object should stand at least this far above its surroundings


@dataclass(frozen=True)
class Legibility(Facts):
    """The legibility figures of one relief (lengths in mm, areas in mm²).

    fine_share : variance finer than a fingertip ÷ total variance (0..1).
    levels_used : distinct heights (to `quantum_mm`) that each cover at least a fingertip's area.
    smallest_step_mm : smallest height step between neighbouring fingertip-sized regions, or None.
    narrow_area_mm2 : area of raised or sunk features narrower than two nozzle widths.
    narrow_share : that area ÷ the relief's area.
    steepest_slope_deg : steepest slope (99.9th percentile, so one pixel cannot decide it).
    object_count : objects given to the report (found by a style, or known).
    object_lift_mm : median over objects of (object median height − ground around it), or None.
    lowest_lift_mm : the least-lifted object's lift, or None.
    relief_span_mm : 1st to 99th percentile of the heights.
    verdicts : plain sentences with advice.
    period_mm : pitch of a lattice or grating in the heights that a finger can feel (>= 2.5 mm), or None:
        its fine share is shape (as braille is), not roughness.
    """

    fine_share: float
    levels_used: int
    smallest_step_mm: float | None
    narrow_area_mm2: float
    narrow_share: float
    steepest_slope_deg: float
    object_count: int
    object_lift_mm: float | None
    lowest_lift_mm: float | None
    relief_span_mm: float
    verdicts: tuple[str, ...]
    levels_mm: tuple[float, ...] | None = None  # the plateaus of the relief style, when it made plateaus (set by the pipeline)
    period_mm: float | None = None

    def as_dict(self) -> dict:
        out = asdict(self)
        out["verdicts"] = list(self.verdicts)
        if self.levels_mm is None:
            del out["levels_mm"]
        else:
            out["levels_mm"] = list(self.levels_mm)
        return out


ASSESS_MAX_POINTS = 4 * WORK_MAX_POINTS  # legibility is measured on at most this many points


def assess(
    heights_mm: np.ndarray,
    mm_per_px: float,
    *,
    nozzle_mm: float = 0.4,
    layer_mm: float | None = None,
    objects: np.ndarray | None = None,
    min_area_mm2: float = 6.0,
    style: str | None = None,
) -> Legibility:
    """Measure a relief's legibility.

    Parameters
    ----------
    heights_mm : (rows, cols) heights in mm (base included; only differences matter).
    mm_per_px : grid pitch in mm.
    nozzle_mm : nozzle diameter in mm (narrow features are those under 2 × nozzle_mm).
    layer_mm : layer height; heights are compared to this quantum (default 0.1 mm).
    objects : (rows, cols) labels or bool mask of objects (0/False = ground), or None.
    min_area_mm2 : a fingertip-sized area: smaller regions are not counted as levels.
    style : the relief style that made the heights, so the advice never suggests that same style.
    """
    h = np.asarray(heights_mm, dtype=np.float64)
    if h.size > ASSESS_MAX_POINTS:
        # A plate wider than about 500 mm at High: measured on every `step`-th point (0.4 mm at
        # 1000 mm), which still resolves features two nozzles wide; the full 5001 x 3751 grid took
        # half a GB of the conversion's peak here (quantised levels, their regions, a low-pass).
        step = math.ceil(math.sqrt(h.size / ASSESS_MAX_POINTS))
        h, mm_per_px = h[::step, ::step], mm_per_px * step
        objects = None if objects is None else np.asarray(objects)[::step, ::step]
    grid = WorkGrid.plan(h.shape, mm_per_px, nozzle_mm / 4)  # narrow features need nozzle/4
    work = grid.down(h).astype(np.float64)
    pitch = grid.pitch_mm
    low, high = np.percentile(h, [1, 99])  # one copy and partition for both: the same order statistics
    span = float(high - low)
    quantum = max(layer_mm or 0.1, 1e-3)
    fine = _fine_share(h, mm_per_px)
    levels, step = _levels_and_step(h, quantum, max(1, int(min_area_mm2 / mm_per_px**2)))
    narrow_mm2 = _narrow_area(work, pitch, nozzle_mm)
    gy, gx = np.gradient(work, pitch)
    slope = float(np.degrees(np.arctan(np.percentile(np.hypot(gx, gy), 99.9))))
    count, lift, lowest = _lifts(h, objects, mm_per_px)
    area = h.size * mm_per_px**2
    period = _feelable_period(work, pitch) if fine > FINE_SHARE_WARN else None
    figures = dict(
        fine_share=fine, levels_used=levels, smallest_step_mm=step, narrow_area_mm2=narrow_mm2,
        narrow_share=narrow_mm2 / area if area else 0.0, steepest_slope_deg=slope, object_count=count,
        object_lift_mm=lift, lowest_lift_mm=lowest, relief_span_mm=span, period_mm=period,
    )
    return Legibility(**figures, verdicts=verdicts(figures, nozzle_mm, style))


def _feelable_period(work: np.ndarray, pitch_mm: float) -> float | None:
    """A lattice's pitch in the heights when a finger can feel it (>= MIN_PITCH_MM), else None."""
    from .content import MIN_PITCH_MM, lattice_period

    span = float(np.ptp(work))
    if span <= 1e-9:
        return None
    found = lattice_period((work - work.min()) / span, pitch_mm)
    return found.pitch_mm if found is not None and found.pitch_mm >= MIN_PITCH_MM else None


def _fine_share(h: np.ndarray, mm_per_px: float) -> float:
    total = float(h.var())
    if total <= 1e-12:
        return 0.0
    low = ndimage.gaussian_filter(h, FINGERTIP_SIGMA_MM / mm_per_px, mode="nearest")
    return float((h - low).var() / total)


def _levels_and_step(h: np.ndarray, quantum: float, min_px: int) -> tuple[int, float | None]:
    """Distinct quantised heights covering >= min_px, and the smallest step between
    neighbouring regions (connected areas of one quantised height) that are both that big."""
    q = np.round((h - h.min()) / quantum).astype(np.int64)
    values, counts = np.unique(q, return_counts=True)
    levels = int((counts >= min_px).sum())
    if levels < 2:
        return levels, None
    regions = measure.label(q, background=-1, connectivity=1)
    big = (np.bincount(regions.ravel()) >= min_px)[regions]
    steps = []
    for a, b, ok in ((q[:, 1:], q[:, :-1], big[:, 1:] & big[:, :-1]), (q[1:], q[:-1], big[1:] & big[:-1])):
        d = np.abs(a - b)[ok]
        d = d[d > 0]
        if d.size:
            steps.append(int(d.min()))
    return levels, (min(steps) * quantum if steps else None)


def _narrow_area(work: np.ndarray, pitch: float, nozzle_mm: float) -> float:
    """Area of ridges and grooves that an opening/closing two nozzle widths wide removes."""
    foot = disk(nozzle_mm / pitch)
    ridges = work - ndimage.grey_opening(work, footprint=foot)
    grooves = ndimage.grey_closing(work, footprint=foot) - work
    return float(((ridges > NARROW_HEIGHT_MM) | (grooves > NARROW_HEIGHT_MM)).sum() * pitch**2)


def _lifts(h: np.ndarray, objects, mm_per_px: float) -> tuple[int, float | None, float | None]:
    """Each object's median height minus the median of the ground 1–3 mm around it."""
    if objects is None:
        return 0, None, None
    labels = np.asarray(objects)
    if labels.dtype == bool:
        labels = ndimage.label(labels)[0]
    n = int(labels.max())
    if n == 0:
        return 0, None, None
    if labels.size > WORK_MAX_POINTS:
        # A plate wider than about 500 mm: every `step`-th point (0.8 mm at 1000 mm, High), so the
        # dilations, the distance transform and the medians stay within WORK_MAX_POINTS (on the
        # 5001 x 3751 grid they took 11 s and most of the 2 GB peak). Objects narrower than a step
        # may drop out; they are not counted.
        step = math.ceil(math.sqrt(labels.size / WORK_MAX_POINTS))
        h, labels, mm_per_px = h[::step, ::step], labels[::step, ::step], mm_per_px * step
        present = np.unique(labels)
        present = present[present > 0]
        if present.size == 0:
            return 0, None, None
        labels = ((np.searchsorted(present, labels) + 1) * (labels > 0)).astype(np.int32)
        n = int(present.size)
    mask = labels > 0
    near = ndimage.binary_dilation(mask, iterations=max(1, round(3 / mm_per_px)))
    ground = near & ~ndimage.binary_dilation(mask, iterations=max(1, round(1 / mm_per_px)))
    # Each ground pixel belongs to its nearest object.
    _, (iy, ix) = nearest_member(mask)
    owner = np.where(ground, labels[iy, ix], 0)
    inside = scipy_label_median(h, labels, n)
    around = scipy_label_median(h, owner, n).astype(np.float64)
    around = np.where(np.isfinite(around), around, np.median(h[~mask]) if (~mask).any() else 0.0)
    lifts = inside - around
    return n, float(np.median(lifts)), float(lifts.min())


def verdicts(f: dict, nozzle_mm: float, style: str | None = None) -> tuple[str, ...]:
    """Plain sentences, each with advice where something reads badly (never to use the style in use)."""
    if f["relief_span_mm"] < 0.05 and f["levels_used"] <= 1:
        return ("This print is a flat plate: there is nothing raised to feel.",)
    out = [_fine_verdict(f, style)]
    out += _level_verdicts(f)
    out += _narrow_verdicts(f, nozzle_mm, style)
    if f["object_count"] and style != "content":  # the content style's own check says how high its members stand (once)
        out.append(_object_verdict(f, style))
    out.append(f"The steepest slope is {f['steepest_slope_deg']:.0f} degrees.")
    return tuple(out)


def _fine_verdict(f: dict, style: str | None) -> str:
    """How much of the relief is finer than a fingertip resolves, and what that is."""
    share = f["fine_share"]
    if share > FINE_SHARE_WARN and f.get("period_mm"):
        return (
            f"{share:.0%} of this relief's height variation is finer than a 1 mm low-pass keeps, but it is a lattice of "
            f"{f['period_mm']:.1f} mm pitch, which fingers feel as a pattern (braille dots are 2.5 mm apart), not as roughness."
        )
    if share > FINE_SHARE_WARN and style == "content":
        # The content style draws lines and members' edges on purpose: advice to smooth them
        # away would erase the main content.
        return (
            f"{share:.0%} of this relief's height variation is finer than a fingertip resolves (about 1 mm): it is the "
            f"edges of the drawn content (raised lines, members' outlines), kept on purpose; a wider print spreads it out."
        )
    if share > FINE_SHARE_WARN and style == "channels":
        # the channels' textures (ridges, dots) are drawn at a set spacing on purpose; detail_mm and the
        # relief style do not reach them, so there is nothing to advise
        return (f"{share:.0%} of this relief's height variation is finer than a fingertip resolves (about 1 mm): it is "
                f"the edges of the channels' textures, drawn so on purpose and named in the key.")
    if share > FINE_SHARE_WARN:
        return Text(
            f"{share:.0%} of this relief's height variation is finer than a fingertip resolves (about 1 mm), so it is "
            f"felt as roughness, not as shape"
            + ("⟦; try a larger `detail_mm` or a lower `texture_mm`⟧." if style == "structure" else "⟦; try `relief_style` structure⟧⟦, or a larger `detail_mm`⟧.")
        )
    return f"Most of the relief is shape a fingertip can follow: only {share:.0%} of its variation is finer than about 1 mm."


def _level_verdicts(f: dict) -> list[str]:
    """How many height levels, and whether fingers tell the steps apart."""
    out = []
    levels, step = f["levels_used"], f["smallest_step_mm"]
    if levels > MANY_LEVELS:
        out.append(f"The heights vary continuously ({levels} layer levels in use): read it as a landscape, not as distinct levels.")
    elif step is not None and step < STEP_MM - 1e-9:
        out.append(
            f"{levels} height levels; the smallest step between neighbouring regions is {step:.2g} mm, under the "
            f"{STEP_MM} mm fingers tell apart reliably; try fewer levels or a taller relief."
        )
    elif step is not None:
        out.append(f"{levels} distinct height levels, at least {step:.2g} mm apart: easy to tell apart by touch.")
    return out


def _narrow_verdicts(f: dict, nozzle_mm: float, style: str | None) -> list[str]:
    """Raised detail narrower than two nozzle widths, said as what it is for the style."""
    out = []
    if f["narrow_share"] > 0.05 and style == "content":  # a lattice's columns, small domes: drawn so on purpose
        out.append(f"{f['narrow_area_mm2']:.0f} mm² ({f['narrow_share']:.0%} of the picture) is raised detail narrower than two "
                   f"nozzle widths ({2 * nozzle_mm:g} mm): the drawn content's small domes and lines, kept on purpose; a wider "
                   f"print makes them wider.")
    elif f["narrow_share"] > 0.05 and style == "channels":
        out.append(f"{f['narrow_area_mm2']:.0f} mm² ({f['narrow_share']:.0%} of the picture) is raised detail narrower than two "
                   f"nozzle widths ({2 * nozzle_mm:g} mm): the edges of the channels' textures; a wider print makes them wider.")
    elif f["narrow_share"] > 0.05:
        out.append(Text(
            f"{f['narrow_area_mm2']:.0f} mm² ({f['narrow_share']:.0%} of the picture) is ridges or grooves narrower than two "
            f"nozzle widths ({2 * nozzle_mm:g} mm): they may not print and read as noise⟦; a larger `detail_mm` removes them⟧."
        ))
    return out


def _object_verdict(f: dict, style: str | None) -> str:
    """How high the objects stand above the ground around them (styles other than content)."""
    lift, low = f["object_lift_mm"], f["lowest_lift_mm"]
    n = f["object_count"]
    if lift < LIFT_MM:
        return Text(
            f"The {n} object{'s' * (n != 1)} stand{'s' * (n == 1)} only {lift:.2g} mm (median) above the ground around "
            f"{'it' if n == 1 else 'them'}; "
            f"a finger may not find {'it' if n == 1 else 'them'}"
            + ("⟦; try a taller `relief_mm`⟧." if style in ("objects", "content") else "⟦; try `relief_style` objects⟧.")
        )
    return (f"{n} object{'s' * (n != 1)} stand{'s' * (n == 1)} {lift:.2g} mm (median; lowest {low:.2g} mm) above the "
            f"ground around {'it' if n == 1 else 'them'}.")
