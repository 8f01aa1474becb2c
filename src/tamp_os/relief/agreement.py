"""Does the print agree with the picture? Two checks a style's own check cannot make, because they
compare the finished heights with the picture as it is displayed (issue 32, "know when the print
is wrong"):

- polarity (issue 53): what is raised should be what the picture shows as specimen. The picture's
  brightness under the raised parts is compared with its brightness under the ground, against the
  side the picture says is matter: the modality first (SE, BSE and HAADF STEM: bright; bright
  field: dark), then the members' shape (the side whose pieces are compact and convex, not the
  concave shards between them: content.side_shapes), then an empty bright ground (glass, paper:
  dark is matter), else bright (the default: bright = high). Raised parts on the other side are
  said in one line, "raised parts darker than their ground (possibly inverted)", with the option
  that turns it over. Without a modality, a print whose raised parts are the picture's smooth side
  while its structured side stays at the base has raised the gaps too.
- flat structure: structure the picture shows at fingertip scale (0.5–3 mm on the print, well
  above the picture's noise) over an area a hand finds, where the print is flat.

Both measure on the relief grid in print millimetres, so the same picture at 50 or 200 mm is
judged at what a fingertip meets. Each finding says what may be wrong and the one option that
changes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..clean.instrument import SIGNALS, matter_is_bright
from ..errors import Text
from .scales import gaussian_mm

RAISED_SHARE = 0.5  # a point in the top half of the relief's span is raised
GROUND_SHARE = 0.15  # one within the lowest 15 % stays at the base
MIN_PHASE_AREA = 0.02  # both sides must cover this share of the picture to be compared (four beads: 2 %)
SIDE_QUANTILE = 0.1  # else the highest and lowest tenth of the points are the sides (particles cover 5-50 %)
SIDE_APART = 0.25  # when they stand this share of the relief apart (a finger tells 0.5 mm of 3 mm)
DARKER_BY = 0.15  # the raised side's median brightness this far (0..1) under the ground's: it is the dark side
EMPTY_GROUND = 0.6  # a ground this bright (median, 0..1) and of one grey is empty: glass, paper, vacuum
EMPTY_TOLERANCE = 0.06  # of one grey: within this of its median (as content.py's empty ground)
EMPTY_SHARE = 0.8  # for this share of it, 1 mm in from the raised parts
INVERTED_WORDS = "possibly inverted"  # what every polarity finding says, so a reader (and a test) can find it
STRUCTURE_RATIO = 2.0  # the base side carries this many times the raised side's structure: it is the specimen
FINGER_BAND_MM = (0.5, 3.0)  # structure a fingertip follows: finer than 3 mm, coarser than the nozzle's texture
FINGERTIP_MM = 2.0  # what a fingertip covers at once: relief this near a point is found there
FLAT_MM = 0.15  # local relief (standard deviation) under this is flat to a finger
VISIBLE_NOISE = 5.0  # structure this many times the band's noise is visible in the picture
VISIBLE_MIN = 0.04  # and at least this much of the 0..1 range
FLAT_AREA_SHARE = 0.15  # structure flattened over this share of the picture is worth saying
MAX_POINTS = 1_000_000  # the check's grid at most (block means of the relief grid beyond)


@dataclass(frozen=True)
class Agreement:
    """What the comparison measured (shares of the relief's area; brightness 0..1 as displayed)."""

    raised_brightness: float | None = None
    ground_brightness: float | None = None
    raised_structure: float | None = None
    ground_structure: float | None = None
    flat_structure_share: float = 0.0
    sentences: tuple[Text, ...] = ()
    possibly_inverted: bool = False  # the raised parts are the side the picture does not show as matter


@dataclass(frozen=True)
class Expected:
    """Which side of the picture is matter, and why in words ("in a backscattered-electron image
    bright is matter")."""

    bright: bool
    why: str
    firm: bool = False  # said by the modality or the members' shape, not by the ground's look or the default


def agreement(picture01: np.ndarray, heights_mm: np.ndarray, *, mm_per_px: float, base_mm: float,
              inverted: bool, signal: str | None, polarity: bool = True, style: str = "content", fine=None) -> Agreement:
    """Compare the heights with the picture on the same grid.

    Parameters
    ----------
    picture01 : (rows, cols) the picture as the relief saw it, 0..1 (inverted when `inverted`).
    heights_mm : (rows, cols) heights in mm, base included, on the same grid.
    mm_per_px : the grid's pitch on the print.
    base_mm : the base's thickness.
    inverted : the picture was inverted before the relief (its displayed brightness is 1 - picture01).
    signal : the signal ("SE", "BSE", "STEM", "BF") when the file or its data band names it, else None.
    polarity : False where the relief decides its own polarity on purpose (raised lines, which may
        be the picture's dark or bright strokes; lattices of columns).
    style : the relief style that made the heights; it decides which option the advice names.
    fine : a function of a column count giving the picture without the print grid's blur
        (`preprocess.Prepared.finer`, inverted as picture01 is), where the members' shape is
        measured when neither the modality says which side is matter; or None.
    """
    shown = 1.0 - picture01 if inverted else picture01
    # Fingertip-scale measures need no finer grid than about a megapixel: a large plate is judged
    # on block means, which bounds the check's memory and time (a 1000 mm plate at High is 4.7 Mpx).
    factor = max(1, math.ceil(math.sqrt(shown.size / MAX_POINTS)))
    shown = _block_mean(shown.astype(np.float32, copy=False), factor)
    h = _block_mean(heights_mm.astype(np.float32, copy=False), factor) - base_mm
    mm_per_px *= factor
    span = float(h.max()) if h.size else 0.0
    if span < 0.5 or min(h.shape) < 8:
        return Agreement()
    structure = _structure(shown, mm_per_px)
    noise = _band_noise(shown, mm_per_px)
    out: list[Text] = []
    facts = {}
    if polarity:
        shown_fine = None if fine is None else (lambda cols: _as_shown(fine(cols), inverted))
        facts, said = _polarity(shown, h / span, structure, noise, mm_per_px, _Seen(inverted, signal, style, shown_fine))
        out += said
    share, said = _flat_structure(h, structure, noise, mm_per_px, style)
    out += said
    return Agreement(**facts, flat_structure_share=share, sentences=tuple(out))


def _as_shown(picture: np.ndarray | None, inverted: bool) -> np.ndarray | None:
    return None if picture is None else (1.0 - picture if inverted else picture)


@dataclass(frozen=True)
class _Seen:
    """What the polarity check knows of how the print was made: the picture inverted, the signal,
    the style, and the picture as displayed before the print grid's blur (a function of a column
    count, or None)."""

    inverted: bool
    signal: str | None
    style: str
    fine: object = None


def _block_mean(a: np.ndarray, factor: int) -> np.ndarray:
    if factor == 1:
        return a
    rows, cols = (a.shape[0] // factor) * factor, (a.shape[1] // factor) * factor
    return a[:rows, :cols].reshape(rows // factor, factor, cols // factor, factor).mean(axis=(1, 3), dtype=np.float32)


def _structure(values: np.ndarray, pitch_mm: float) -> np.ndarray:
    """Local strength of fingertip-scale structure (of the picture, or of the heights in mm): the
    band between FINGER_BAND_MM, its root mean square over a fingertip's area."""
    lo, hi = FINGER_BAND_MM
    band = gaussian_mm(values, lo / 2, pitch_mm) - gaussian_mm(values, hi / 2, pitch_mm)
    return np.sqrt(gaussian_mm(band * band, hi / 2, pitch_mm))


def _band_noise(shown: np.ndarray, pitch_mm: float) -> float:
    """The picture's noise as it survives the band: white noise of sigma s, low-passed by a
    Gaussian of sigma g pixels, keeps s / (2 sqrt(pi) g) (the higher cut removes little more)."""
    from .touch import noise_sigma

    g = max(FINGER_BAND_MM[0] / 2 / pitch_mm, 0.5)
    return noise_sigma(shown) / (2 * math.sqrt(math.pi) * g)


def _polarity(shown, rel, structure, noise, pitch_mm, seen: _Seen) -> tuple[dict, list[Text]]:
    raised, ground = _sides(rel)
    if raised is None:
        return {}, []
    # inside each side, away from the edge where the two meet (an edge is structure of both)
    edge = max(1, round(1.0 / pitch_mm))
    inner_r, inner_g = ndimage.binary_erosion(raised, iterations=edge), ndimage.binary_erosion(ground, iterations=edge)
    if inner_r.sum() < 20 or inner_g.sum() < 20:
        inner_r, inner_g = raised, ground
    b_r, b_g = float(np.median(shown[raised])), float(np.median(shown[ground]))
    s_r, s_g = float(np.median(structure[inner_r])), float(np.median(structure[inner_g]))
    facts = dict(raised_brightness=round(b_r, 3), ground_brightness=round(b_g, 3), raised_structure=round(s_r, 4),
                 ground_structure=round(s_g, 4))
    if abs(b_r - b_g) <= DARKER_BY:
        return facts, []
    # The base side carries the specimen's structure (shading and edges) while the raised side is smooth.
    structured_base = s_g > STRUCTURE_RATIO * max(s_r, noise) and s_g > VISIBLE_NOISE * noise
    # The members' shape (a watershed of each side, ~0.1-0.4 s) is asked only where the print may be wrong.
    expected = expected_side(shown, pitch_mm, seen.signal, ground_brightness=b_g, ground_empty=_empty(shown, ground, inner_g, b_g),
                             fine=seen.fine, shapes=b_r < b_g or structured_base)
    if (b_r > b_g) != expected.bright:
        return {**facts, "possibly_inverted": True}, [_inverted_sentence(b_r, b_g, expected, seen)]
    if structured_base and not expected.firm:
        side = "dark" if b_r < b_g else "bright"
        option = "`invert` off" if seen.inverted else "`invert`"
        return facts, [Text(f"What is raised is the picture's smooth {side} side, and what stays at the base carries its "
                            f"structure (shading and edges {s_g / max(s_r, 1e-6):.1f}× stronger): the print may raise the "
                            f"gaps, not the specimen⟦; {option} raises the other side⟧.")]
    return facts, []


def _sides(rel: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(raised, ground) masks of a relief (0..1 of its span): the top half and the lowest
    GROUND_SHARE; where either covers under MIN_PHASE_AREA (a landscape whose lowest points are a
    few bright particles printed inverted), the highest and lowest SIDE_QUANTILE of the points,
    when they stand at least SIDE_APART of the span apart. (None, None) when the sides cannot be told."""
    raised, ground = rel >= RAISED_SHARE, rel <= GROUND_SHARE
    if raised.mean() >= MIN_PHASE_AREA and ground.mean() >= MIN_PHASE_AREA:
        return raised, ground
    low, high = np.quantile(rel, [SIDE_QUANTILE, 1.0 - SIDE_QUANTILE])
    if high - low < SIDE_APART:
        return None, None
    return rel >= high, rel <= low


def _empty(shown: np.ndarray, ground: np.ndarray, inner: np.ndarray, brightness: float) -> bool:
    """Whether the print's ground is an empty field: of one grey (EMPTY_SHARE of it, 1 mm in from
    the raised parts, within EMPTY_TOLERANCE of its median) and one piece around the raised parts
    (EMPTY_SHARE of it connected), as glass or paper is; flat members printed inverted are many pieces."""
    if float(np.mean(np.abs(shown[inner] - brightness) < EMPTY_TOLERANCE)) < EMPTY_SHARE:
        return False
    pieces, count = ndimage.label(ground)
    return count > 0 and float(np.bincount(pieces.ravel())[1:].max()) >= EMPTY_SHARE * float(ground.sum())


def expected_side(shown: np.ndarray, pitch_mm: float, signal: str | None, *, ground_brightness: float, ground_empty: bool,
                  fine=None, shapes: bool = True) -> Expected:
    """Which side of the picture (as displayed) is matter: the signal's (SE, BSE, STEM bright;
    bright field dark); else the side of compact members (content.side_shapes, on the picture
    before the print grid's blur when `fine` gives it; only with `shapes`); else, when the print's
    ground is bright and empty (`ground_empty`: glass, paper), dark; else bright, the default."""
    matter = matter_is_bright(signal)
    if matter is not None:
        return Expected(matter, f"in a {SIGNALS[signal]} image {'bright' if matter else 'dark'} is matter", firm=True)
    if shapes:
        from .content import measured_shapes

        found = measured_shapes(shown, pitch_mm, width_mm=(shown.shape[1] - 1) * pitch_mm, fine=fine)
        members = found.members_bright if found is not None else None
        if members is not None:
            return Expected(members, found.words(), firm=True)
    if ground_brightness >= EMPTY_GROUND and ground_empty:
        return Expected(False, "the ground is bright and empty (glass, paper, vacuum), where dark is matter")
    return Expected(True, "with no modality recorded, bright is taken as matter")


def _inverted_sentence(b_r: float, b_g: float, expected: Expected, seen: _Seen) -> Text:
    """One plain line: the raised parts on the side the picture does not show as matter, the
    brightness measured, why the other side is matter, and the option that turns the print over."""
    what = "darker" if b_r < b_g else "brighter"
    side = "bright" if expected.bright else "dark"
    if seen.inverted:
        option = "`invert` off"
    elif seen.style in ("content", "auto") and expected.bright:
        option = "`relief_style` structure (which follows brightness)"  # the content style reads its polarity from the picture
    else:
        option = "`invert`"
    return Text(f"Raised parts {what} than their ground ({INVERTED_WORDS}): the picture's median brightness is {b_r:.0%} under "
                f"the raised parts against {b_g:.0%} under the ground, but {expected.why}⟦; {option} raises the {side} side⟧.")


def _flat_structure(h, structure, noise, pitch_mm, style: str) -> tuple[float, list[Text]]:
    relief = _structure(h, pitch_mm)
    # A line's or an edge's structure spreads over its blur in the picture while the print draws it
    # sharp: what the print carries within a fingertip's reach of a point counts for that point.
    reach = 2 * max(1, round(FINGERTIP_MM / 2 / pitch_mm)) + 1
    relief = ndimage.maximum_filter(relief, size=reach)
    visible = structure > max(VISIBLE_MIN, VISIBLE_NOISE * noise)
    flat = relief < FLAT_MM
    lost = visible & flat
    share = float(lost.mean())
    if share < FLAT_AREA_SHARE:
        return round(share, 3), []
    where = _where(lost)
    # The structure style already follows the picture everywhere: there the detail it kept as low
    # texture is what is missing (the moth's scales come out at `detail_mm` 0.5).
    advice = ("a smaller `detail_mm` (0.5 mm) draws it as shape" if style == "structure"
              else "`relief_style` structure raises the picture's shape everywhere")
    return round(share, 3), [Text(f"{share:.0%} of the picture ({where}) shows structure at fingertip scale that the print "
                                  f"leaves flat (under {FLAT_MM:g} mm of relief within a fingertip's reach): a finger will "
                                  f"not find it⟦; {advice}⟧.")]


def _where(mask: np.ndarray) -> str:
    """Where a region lies, in the words a reader uses for a plate (far edge = top of the picture)."""
    rows, cols = mask.shape
    ys, xs = np.nonzero(mask)
    if mask.mean() > 0.6:
        return "most of it"
    y, x = ys.mean() / rows, xs.mean() / cols
    vertical = "top" if y < 0.38 else "bottom" if y > 0.62 else ""
    horizontal = "left" if x < 0.38 else "right" if x > 0.62 else ""
    if vertical and horizontal:
        return f"mostly its {vertical} {horizontal}"
    if vertical or horizontal:
        return f"mostly its {vertical or horizontal} side"
    return "mostly its middle"
