"""Several channels (or a stained brightfield RGB) -> one relief where each channel is a texture.

A nuclear stain becomes smooth domes, filaments parallel ridges, small spots dots, diffuse
cytoplasm a low plateau with a raised outline. The encoding comes from the channel's name or
wavelengths where the file records them, else from the measured shape (a ridge filter's response
against a blob detector's). H&E / IHC brightfield slides are split by colour deconvolution
(Ruifrok & Johnston, skimage.color.rgb2hed) into haematoxylin, eosin and DAB.
"""

from __future__ import annotations

import dataclasses
import logging
import re
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage as ndi
from skimage import color, filters, morphology

from ..errors import Decision, ParameterError, Text
from .textures3d import MAX_TEXTURES, pattern, ridge_angle_unlike, spec_for

log = logging.getLogger(__name__)

ENCODINGS = ("domes", "ridges", "dots", "plateau")
TEXTURE_OF = {"domes": "smooth", "ridges": "ridges", "dots": "dots", "plateau": "smooth"}
DEFAULT_MAX_CHANNELS = 3
# Heights of each encoding's top above the base, as a share of relief_mm (domes highest, so
# nuclei stay the first thing found; textures at least 0.5 mm so a finger tells them from base).
TOP_SHARE = {"domes": 1.0, "ridges": 0.6, "dots": 0.7, "plateau": 0.3}
OUTLINE_SHARE = 0.6
MIN_FEATURE_MM = 0.5

# The one table of signal names (issue 31): a dye, marker or stain's name -> its encoding and the
# role the key says in words ("nuclei (DAPI)"). The first match wins, so specific names come before
# the general ones. Channel roles follow the dye first (DESIGN.md "Translating content"): nuclear
# stains domes; tubulin, actin, collagen ridges; mitochondrial markers network lines (ridges, raised
# along their own skeleton when tubular); lysosome and vesicle markers dots; diffuse markers a
# plateau. Fluorescent proteins (GFP, mCherry...) and plain filter names (FITC, TRITC) say nothing of
# what is labelled: they are not here, so the shape decides.
SIGNALS: tuple[tuple[str, str, str], ...] = (
    (r"dapi|hoechst|h33342|draq5|sytox|propidium|\bpi\b|\bdna\b|nucle|\bnuc\b|haemat|hemat|\bh2b\b", "domes", "nuclei"),
    (r"tubulin|microtub|\bmts?\b|\beb[13]\b", "ridges", "microtubules"),
    (r"phalloid|lifeact|actin", "ridges", "actin"),
    (r"collagen|\bshg\b", "ridges", "collagen"),
    (r"vimentin|keratin|filament|fibr", "ridges", "filaments"),
    (r"mitotracker|tom ?20|tmrm|tmre|\bmito|mitochond", "ridges", "mitochondria"),
    (r"lyso|lamp ?[12]\b", "dots", "lysosomes"),
    (r"vesic|endosom|peroxi|\brab\d", "dots", "vesicles"),
    (r"foci|focus|spot|puncta|gamma ?h2ax|53bp1|fish", "dots", "spots"),
    (r"eosin", "ridges", "stroma"),
    (r"\bdab\b", "plateau", "DAB positive"),
    (r"membrane|\bwga\b|cellmask", "plateau", "membranes"),
    (r"cytopl|cfse|calcein", "plateau", "cytoplasm"),
)
_SIGNALS = tuple((re.compile(rx, re.IGNORECASE), enc, role) for rx, enc, role in SIGNALS)


def signal_role(name: str) -> tuple[str, str] | None:
    """(encoding, role in words) of a channel or stain named `name`, from SIGNALS; None when the
    name says nothing of what is labelled (a fluorescent protein, a filter, "channel 1")."""
    for rx, enc, role in _SIGNALS:
        if rx.search(name):
            return enc, role
    return None

@dataclass(frozen=True)
class ChannelImage:
    """One channel on the print grid: name, 0..1 values (rows, cols), wavelengths where known."""

    name: str
    image: np.ndarray
    excitation_nm: float | None = None
    emission_nm: float | None = None


@dataclass(frozen=True)
class KeyEntry:
    """One line of the print's key: what a texture means, and how it is written in braille."""

    label: str
    encoding: str
    braille: str = ""
    # what the braille writes when the label is too long for a key line ("spots (FITC)" for
    # "spots (FITC BP)"); "" until the key is laid out (relief/key3d.py)
    braille_label: str = ""
    # the forms the key may write, fullest first, the last the dye alone (relief/key_labels.py); () = the label
    key_forms: tuple[str, ...] = ()
    key_role: str = ""  # the role words the forms begin with ("nuclei"): on two lines, the first line


@dataclass(frozen=True)
class ChannelChoice:
    name: str
    encoding: str
    why: str  # "name", "wavelength", "colour", "shape", "distinct", "asked" or "stain"
    role: str = ""  # what it shows, in words, when its name, wavelength or colour says ("nuclei"); "" by shape


@dataclass
class ChannelRelief:
    """What the channel path made: heights, the encodings chosen, the masks raised, and notes."""

    heights_mm: np.ndarray
    choices: list[ChannelChoice]
    masks: dict[str, np.ndarray]
    notes: list[str] = field(default_factory=list)


def parse_assignments(text: str | None) -> dict[str, str]:
    """`"DAPI=domes,GFP=ridges"` -> {"dapi": "domes", "gfp": "ridges"} (names case-free)."""
    if not text or text.strip().lower() in ("auto", "off", "none", "luminance", "no"):
        return {}
    out = {}
    for part in text.split(","):
        if not part.strip():
            continue
        name, sep, enc = part.partition("=")
        enc = enc.strip().lower()
        if not sep or not name.strip() or enc not in ENCODINGS:
            raise ParameterError(Text(
                f"`channels`: {part.strip()!r} is not NAME=ENCODING; write e.g. \"DAPI=domes,GFP=ridges\" "
                f"with an encoding among {', '.join(ENCODINGS)}; or auto, or off (brightness as before)."))
        out[name.strip().lower()] = enc
    if len(set(out.values())) > MAX_TEXTURES:
        raise ParameterError(Text(f"`channels`: at most {MAX_TEXTURES} encodings on one print; a finger does not tell more apart."))
    return out


def _by_name(name: str) -> str | None:
    found = signal_role(name)
    return found[0] if found else None


# Fluorescent proteins name no structure, but a name that pairs one with a marker ("mCherryEB3",
# "GFP-Mito") says which channel shows the marker: the one excited where the protein is (peak
# excitation: GFP 488, YFP 514, mCherry 587, tdTomato 554, CFP 433, BFP 402 nm; bands with room for
# the laser lines used on them: 488, 514, 561, 405).
FLUORESCENT_PROTEINS = (
    (r"e?gfp|mneongreen|emerald|venus|e?yfp|citrine|mclover", 465.0, 520.0),
    (r"mcherry|mscarlet|tdtomato|dsred|t?rfp|mkate2?|mruby\d?|mapple", 535.0, 600.0),
    (r"e?cfp|cerulean|mturquoise2?", 420.0, 460.0),
    (r"e?bfp2?|tagbfp", 370.0, 415.0),
)
_FP = re.compile("|".join(f"(?:{rx})" for rx, _, _ in FLUORESCENT_PROTEINS))


def _protein_band(word: str) -> tuple[float, float] | None:
    for rx, lo, hi in FLUORESCENT_PROTEINS:
        if re.fullmatch(rx, word):
            return lo, hi
    return None


def proteins_with_markers(title: str) -> list[tuple[tuple[float, float], tuple[str, str]]]:
    """[(excitation band nm, (encoding, role))] for each protein–marker pair the title names:
    "mCherryEB3", "EB3-mCherry", "GFP_Mito" (one word, or two words side by side)."""
    words = [w for w in re.split(r"[^a-z0-9]+", title.lower()) if w]
    out = []
    for k, w in enumerate(words):
        for m in _FP.finditer(w):
            band = _protein_band(m.group(0))
            if band is None:
                continue
            rest = w[m.end():] or w[: m.start()]
            # the protein a word of its own: a neighbour is the marker ("GFP_Mito", "H2B-GFP")
            near = [rest] if rest else [words[j] for j in (k + 1, k - 1) if 0 <= j < len(words)]
            role = next((signal_role(n) for n in near if signal_role(n)), None)
            if role is not None:
                out.append((band, role))
            break
    return out


def marker_in_title(title: str, channels: list[ChannelImage]) -> dict[str, tuple[str, str]]:
    """{channel name: (encoding, role)} for the channels whose own name, wavelength and colour say
    nothing, when the file's title (its name, "dapi_tubulin") names as many markers as there are
    such channels, none of them a marker a channel's name already says: "fluo_dapi_tubulin" with
    channels DAPI and EGFP makes EGFP microtubules; "cell_dna_mt_actin" with three unnamed
    channels gives them nuclei, microtubules and actin, in the file's channel order (the order a
    name lists its channels in, as ImageJ and Fiji users name their exports). Anything less
    certain (more markers than channels, or fewer) gives {}."""
    named = {signal_role(c.name)[1] for c in channels if signal_role(c.name)}
    if any(_by_wavelength(*_wavelengths(c)) for c in channels if not signal_role(c.name)):
        named.add("nuclei")  # a DAPI-like wavelength already says which channel the nuclei are
    unknown = [c for c in channels if signal_role(c.name) is None and _by_wavelength(*_wavelengths(c)) is None
               and c.name not in ("red", "green", "blue")]
    paired = {}
    for (lo, hi), role in proteins_with_markers(title):
        excited = [c for c in unknown if (_wavelengths(c)[0] or 0) and lo <= _wavelengths(c)[0] <= hi]
        if len(excited) == 1 and role[1] not in named:
            paired[excited[0].name] = role
    if paired:
        return paired
    found = _markers_named(title, skip=named)
    return {c.name: role for c, role in zip(unknown, found)} if unknown and len(found) == len(unknown) else {}


def _markers_named(title: str, skip: set[str]) -> list[tuple[str, str]]:
    """(encoding, role) of each marker the title's words name, in their order, once each, leaving out the roles in `skip`."""
    found: list[tuple[str, str]] = []
    for token in re.split(r"[^a-z0-9]+", title.lower()):
        role = signal_role(token) if token else None
        if role and role[1] not in skip and role not in found:
            found.append(role)
    return found


def markers_by_shape(title: str, channels: list[ChannelImage], shapes: dict) -> dict[str, tuple[str, str]]:
    """{channel: (encoding, role)} for an RGB fluorescence composite whose name lists its markers
    ("cells_lyso_mito_nuclei.png"): blue keeps the nuclei (the usual colours); the other markers go
    to the red and green channels by how well each channel's measured shape fits the marker's
    texture (shape_ranking), when the name lists exactly as many as there are such channels and one
    assignment fits strictly best. Anything less certain gives {}."""
    from itertools import permutations

    free = [c for c in channels if c.name in ("red", "green")]
    found = _markers_named(title, skip={"nuclei"})
    if not free or len(found) != len(free):
        return {}

    def misfit(order) -> int:
        return sum(shape_ranking(shapes[c.name]).index(enc) for c, (enc, _) in zip(free, order))

    ranked = sorted(permutations(found), key=misfit)
    if len(ranked) > 1 and misfit(ranked[0]) == misfit(ranked[1]):
        return {}
    return {c.name: role for c, role in zip(free, ranked[0])}


_LIGHT_IN_NAME = re.compile(r"\b(?:led|laser|ex|exc)[\s_-]*(\d{3})(?:\s*nm)?\b|\b(\d{3})\s*nm\b", re.IGNORECASE)


def _wavelengths(c: ChannelImage) -> tuple[float | None, float | None]:
    """(excitation, emission) nm of a channel: the file's, else an excitation its name gives
    ("LED385", "Laser 405", "405 nm": the light source, not a dye)."""
    if c.excitation_nm is not None or c.emission_nm is not None:
        return c.excitation_nm, c.emission_nm
    m = _LIGHT_IN_NAME.search(c.name)
    return (float(m.group(1) or m.group(2)), None) if m else (None, None)


def _by_wavelength(ex: float | None, em: float | None) -> str | None:
    # DAPI / Hoechst: excited near 350-405 nm, emitting 440-470 nm. The emission decides when the
    # file gives it: a 405 nm excitation is also what some files record for every channel (the
    # Nikon PBMC ND2 gives it for FITC and TRITC too), and a green or red emission is no DAPI.
    if em is not None:
        return "domes" if 430 <= em <= 470 else None
    return "domes" if ex is not None and ex <= 410 else None


@dataclass(frozen=True)
class Shape:
    """Measured shape of a channel: how line-like, how blob-like, typical blob size, how much structure."""

    line_score: float  # share of the foreground whose ridge-filter response dominates
    blob_diam_mm: float  # median equivalent diameter of foreground components
    roundness: float  # median area / convex area of the components (NaN: not measured, it decided nothing)
    foreground: float  # share of the picture in the foreground
    structure: float  # contrast of the channel: the spread of its values
    elongation: float = 1.0  # median major / minor axis of the components
    # Along its skeleton: (length ÷ width) and width (mm) of the median component by area. A
    # branched tube (mitochondria, a filament network) has a low ellipse ratio but a long skeleton.
    tube_elongation: float = 1.0
    tube_width_mm: float = 0.0


TUBE_ELONGATION = 5.0  # a component five times longer, along its skeleton, than it is wide is a tube
TUBE_WIDTH_MM = 3.0  # ... and narrower than about a ridge pitch: felt as a line, not as an area


def tube_shape(mask: np.ndarray, mm_per_px: float) -> tuple[float, float]:
    """(length ÷ width, width in mm) of the area-weighted median component of `mask`, along its skeleton."""
    labels, n = ndi.label(mask)
    if n == 0:
        return 1.0, 0.0
    skel = morphology.skeletonize(mask)
    dist = ndi.distance_transform_edt(mask)
    length = np.bincount(labels[skel], minlength=n + 1)[1:].astype(float)
    along = np.bincount(labels[skel], dist[skel], minlength=n + 1)[1:]
    area = np.bincount(labels.ravel(), minlength=n + 1)[1:].astype(float)
    width = np.maximum(2 * along / np.maximum(length, 1) - 1, 1)  # the distance to the edge, on both sides
    keep = area >= 4
    if not keep.any():
        return 1.0, 0.0
    elong, width, area = ((length + width) / width)[keep], width[keep], area[keep]

    def median_by_area(x):
        order = np.argsort(x)
        cum = np.cumsum(area[order])
        return float(x[order][np.searchsorted(cum, cum[-1] / 2)])

    return median_by_area(elong), median_by_area(width) * mm_per_px


_EIGHT = np.ones((3, 3), bool)  # components as skimage.measure.label finds them in 2-D (8-connected)


def component_stats(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(labels, area px, major ÷ minor axis, extent along rows ÷ along columns) of each 8-connected
    component of `mask`, index i = label i + 1.

    One labelled pass: areas and second moments by np.bincount over the component's pixels (the
    axes of the ellipse with the same second moments, as skimage's regionprops defines them; the
    minor axis counted at least one pixel long).
    """
    labels, n = ndi.label(mask, structure=_EIGHT)
    rr, cc = np.nonzero(labels)
    lab = labels[rr, cc] - 1
    area = np.bincount(lab, minlength=n).astype(float)
    dr = rr - np.bincount(lab, rr, minlength=n)[lab] / area[lab]
    dc = cc - np.bincount(lab, cc, minlength=n)[lab] / area[lab]
    a = np.bincount(lab, dr * dr, minlength=n) / area
    b = np.bincount(lab, dr * dc, minlength=n) / area
    c = np.bincount(lab, dc * dc, minlength=n) / area
    half, root = (a + c) / 2, np.sqrt(((a - c) / 2) ** 2 + b ** 2)
    major, minor = 4 * np.sqrt(np.maximum(half + root, 0)), 4 * np.sqrt(np.maximum(half - root, 0))
    pixel = 1 / 12  # the variance of one pixel's extent: a one-pixel line is not infinitely thin
    return labels, area, major / np.maximum(minor, 1.0), np.sqrt((a + pixel) / (c + pixel))


def _solidity(labels: np.ndarray, which: np.ndarray) -> np.ndarray:
    """Area ÷ convex-hull area of the components numbered in `which` (labels 1..n)."""
    from skimage.morphology import convex_hull_image

    boxes = ndi.find_objects(labels)
    out = []
    for i in which:
        box = labels[boxes[i - 1]] == i
        out.append(box.sum() / convex_hull_image(box).sum())
    return np.array(out, float)


def measure_shape(image: np.ndarray, mm_per_px: float, mask: np.ndarray | None = None) -> Shape:
    """The channel's measured shape; `mask` is its foreground() when already found.

    Roundness (median solidity, a convex hull per component) is measured only when it decides the
    encoding (shape_ranking); otherwise it is NaN: not measured.
    """
    img = image.astype(np.float64)
    mask = foreground(img) if mask is None else mask
    fg = float(mask.mean())
    if not mask.any():
        return Shape(0.0, 0.0, 0.0, 0.0, 0.0)
    sigma_px = max(1.0, 0.6 / mm_per_px)
    ridge = filters.sato(img, sigmas=[sigma_px], black_ridges=False)
    line_score = float((ridge[mask] > 0.5 * np.percentile(ridge[mask], 95)).mean()) if ridge[mask].max() > 0 else 0.0
    labels, area, ratio, _ = component_stats(mask)
    big = area >= 4
    diam = float(np.median(np.sqrt(4 * area[big] / np.pi))) * mm_per_px if big.any() else 0.0
    structure = float(np.percentile(img, 99) - np.percentile(img, 50))
    elong = float(np.median(ratio[big])) if big.any() else 1.0
    shape = Shape(line_score, diam, 0.0, fg, structure, elong, *tube_shape(mask, mm_per_px))
    if not big.any():
        return shape
    if shape_ranking(shape)[0] == shape_ranking(dataclasses.replace(shape, roundness=1.0))[0]:
        return dataclasses.replace(shape, roundness=float("nan"))  # it decides nothing here
    return dataclasses.replace(shape, roundness=float(np.median(_solidity(labels, np.flatnonzero(big) + 1))))


AXIAL_STRETCH_MAX = 4.0  # a confocal's axial PSF is 2-4x longer than its lateral one (more is a real structure)
AXIAL_STRETCH_MIN = 1.2  # less is no stretch worth correcting


def axial_stretch(masks: list[np.ndarray]) -> float:
    """In an axial section (rows along Z), how much longer along the rows than across them its
    structures are: the median, over the components of every channel (area ≥ 4 px), of their
    extent along rows ÷ along columns, from 1 (no stretch) to AXIAL_STRETCH_MAX. Points imaged
    side-on are stretched along Z by the optical PSF (and by a coarser Z step); every structure
    of the section shares that stretch."""
    ratios = []
    for mask in masks:
        _, area, _, along = component_stats(mask)
        ratios.append(along[area >= 4])
    ratios = np.concatenate(ratios) if ratios else np.zeros(0)
    if not len(ratios):
        return 1.0
    return float(np.clip(np.median(ratios), 1.0, AXIAL_STRETCH_MAX))


def squeeze_rows(image: np.ndarray, stretch: float) -> np.ndarray:
    """`image` with its rows shrunk by `stretch` (an axial section's Z stretch undone), for measuring shapes."""
    if stretch <= 1.0:
        return image
    from skimage.transform import resize

    rows = max(4, round(image.shape[0] / stretch))
    return resize(np.asarray(image, np.float64), (rows, image.shape[1]), order=1, anti_aliasing=True, preserve_range=True)


def shape_ranking(shape: Shape) -> list[str]:
    """Encodings from the most to the least fitting for this measured shape."""
    if shape.foreground > 0.45:
        first = "plateau"  # diffuse: covers much of the picture
    elif shape.tube_elongation >= TUBE_ELONGATION and shape.tube_width_mm <= TUBE_WIDTH_MM:
        first = "ridges"  # tubes, branched or not (mitochondria, microtubules): raised lines, never domes
    elif shape.elongation >= 2.5 or (shape.roundness < 0.6 and shape.line_score > 0.35):
        first = "ridges"  # elongated structure: filaments
    elif shape.blob_diam_mm < 2.0:
        first = "dots"  # blobs smaller than a dome a finger can feel as one
    elif shape.roundness >= 0.75:
        first = "domes"
    else:
        first = "plateau"
    rest = ["dots", "plateau", "ridges", "domes"] if shape.foreground < 0.2 else ["plateau", "ridges", "dots", "domes"]
    return [first] + [e for e in rest if e != first]


def by_shape(shape: Shape) -> str:
    return shape_ranking(shape)[0]


SHEET_EPS = 0.01  # the darkest signal the log scale tells apart (0..1 channel values)


def sheet_foreground(img: np.ndarray) -> np.ndarray:
    """Where a channel has signal over its dark ground, on a log scale (Otsu of log(value + 0.01),
    lightly smoothed): a fluorescent sheet's dim cells as well as its bright ones, not its gaps."""
    img = np.asarray(img, np.float64)
    if float(img.max() - img.min()) < 1e-6:
        return np.zeros(img.shape, bool)
    smooth = np.log(np.clip(filters.gaussian(img, 1.0), 0, None) + SHEET_EPS)
    mask = smooth > filters.threshold_otsu(smooth)
    return morphology.remove_small_objects(mask, max_size=8)


def foreground(img: np.ndarray) -> np.ndarray:
    """Where the channel has signal: Otsu threshold of the lightly smoothed channel, small specks dropped."""
    img = np.asarray(img, np.float64)  # one definition, whatever the channel's dtype
    if float(img.max() - img.min()) < 1e-6:
        return np.zeros(img.shape, bool)
    smooth = filters.gaussian(img, 1.0)
    t = filters.threshold_otsu(smooth)
    mask = smooth > t
    return morphology.remove_small_objects(mask, max_size=8)


def some_names(names: list[str], most: int = 5) -> str:
    """'a, b, c, d, e and 95 more': a message names a handful of channels, then counts the rest
    (100 channels named one by one made a warning of 97 names)."""
    names = list(names)
    if len(names) <= most + 1:
        return ", ".join(names)
    return f"{', '.join(names[:most])} and {len(names) - most:,} more"


def choose(channels: list[ChannelImage], assigned: dict[str, str], mm_per_px: float,
           *, max_channels: int = DEFAULT_MAX_CHANNELS,
           masks: dict[str, np.ndarray] | None = None, stretch: float = 1.0,
           title: str = "", channels_in_file: int = 0) -> tuple[list[ChannelChoice], list[str]]:
    """An encoding for each channel kept; a note when some are left out. `title`: the file's name,
    whose marker words may name the one channel nothing else names (marker_in_title). `masks`: each channel's
    foreground() by name, when already found. `stretch` > 1: an axial section, its shapes measured
    with the rows shrunk by it (squeeze_rows), so points the PSF drew long are not taken for lines."""
    notes = []
    if assigned:
        keep = [c for c in channels if c.name.lower() in assigned]
        unknown = sorted(set(assigned) - {c.name.lower() for c in channels})
        if unknown:
            raise ParameterError(Text(
                f"`channels`: no channel named {some_names(unknown)} in this picture; its channels are "
                f"{some_names([c.name for c in channels])}."))
        return [ChannelChoice(c.name, assigned[c.name.lower()], "asked") for c in keep], notes
    masks = masks or {}
    if stretch > 1.0:
        shapes = {c.name: measure_shape(squeeze_rows(c.image, stretch), mm_per_px) for c in channels}
    else:
        shapes = {c.name: measure_shape(c.image, mm_per_px, masks.get(c.name)) for c in channels}
    kept = channels
    if len(channels) > max_channels:
        kept = sorted(channels, key=lambda c: -shapes[c.name].structure)[:max_channels]
        dropped = [c.name for c in channels if c not in kept]
        kept = [c for c in channels if c in kept]
        had = (f"Of the {len(channels)} channels measured, the" if channels_in_file > len(channels)
               else f"The picture has {len(channels)} channels; the")
        notes.append(Decision(f"{had} {max_channels} with most structure are printed "
                          f"({', '.join(c.name for c in kept)}); left out: {some_names(dropped)}."
                          f"⟦ Choose others with `channels`.⟧"))
    out = _first_choices(channels, kept, shapes, title)
    # round blobs much smaller than another channel's are spots beside its nuclei
    dome_diams = [shapes[c.name].blob_diam_mm for c in out if c.encoding == "domes"]
    out = [ChannelChoice(c.name, "dots", "shape") if c.encoding == "domes" and c.why == "shape"
           and shapes[c.name].blob_diam_mm < 0.4 * max(dome_diams) else c for c in out]
    return _distinct(out, shapes), notes


def _first_choices(channels: list[ChannelImage], kept: list[ChannelImage], shapes: dict, title: str) -> list[ChannelChoice]:
    """Each kept channel's encoding by what first says it: its name, a marker in the file's name,
    its wavelength, the usual colours of an RGB composite, else its shape."""
    out = []
    rgb = sorted(c.name for c in channels) == ["blue", "green", "red"]
    titled = marker_in_title(title, channels) if title else {}
    if rgb and title and not titled:
        titled = markers_by_shape(title, kept, shapes)
    for c in kept:
        named = signal_role(c.name)
        if named is not None:
            out.append(ChannelChoice(c.name, named[0], "name", named[1]))
            continue
        if c.name in titled:
            enc, role = titled[c.name]
            out.append(ChannelChoice(c.name, enc, "file name", role))
            continue
        enc = _by_wavelength(*_wavelengths(c))
        if enc is not None:
            out.append(ChannelChoice(c.name, enc, "wavelength", "nuclei"))
        elif rgb and c.name == "blue":
            # an RGB fluorescence composite without names: by the usual colours, blue is the nuclear stain
            out.append(ChannelChoice(c.name, "domes", "colour", "nuclei"))
        else:
            out.append(ChannelChoice(c.name, by_shape(shapes[c.name]), "shape"))
    return out


def _distinct(out: list[ChannelChoice], shapes: dict) -> list[ChannelChoice]:
    """Two channels with the same encoding would feel alike: the ones chosen by shape give way to
    those chosen by name or wavelength, and take their next-best encoding (between two channels a
    name or wavelength placed, the one whose shape fits the encoding better keeps it)."""
    out = list(out)
    used = set()
    for i in sorted(range(len(out)), key=lambda i: (out[i].why == "shape", shape_ranking(shapes[out[i].name]).index(out[i].encoding))):
        ch = out[i]
        if ch.encoding in used:
            free = [e for e in shape_ranking(shapes[ch.name]) if e not in used]
            if free:
                out[i] = ChannelChoice(ch.name, free[0], "distinct", ch.role)  # what it shows stays in the key
        used.add(out[i].encoding)
    return out


def _domes(img: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Smooth domes over each blob: the square root of the normalized distance to its edge."""
    dist = ndi.distance_transform_edt(mask)
    labels, n = ndi.label(mask)
    if n == 0:
        return np.zeros(mask.shape)
    peak = ndi.maximum(dist, labels, index=np.arange(1, n + 1))
    peak_px = np.concatenate([[1.0], np.maximum(peak, 1.0)])[labels]
    return np.where(mask, np.sqrt(np.clip(dist / peak_px, 0, 1)), 0.0)


LINE_WIDTH_MM = 1.2  # a tube raised as a line: a standard tactile line is 1.0-1.5 mm wide


def _is_tubular(mask: np.ndarray, mm_per_px: float) -> bool:
    elong, width_mm = tube_shape(mask, mm_per_px)
    return elong >= TUBE_ELONGATION and width_mm <= TUBE_WIDTH_MM


def encode(img: np.ndarray, encoding: str, mm_per_px: float, *, relief_mm: float, angle_deg: float = 0.0,
           mask: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(relief above the base in mm, mask of the region raised) for one channel; `mask` is its
    foreground() when already found."""
    mask = foreground(img) if mask is None else mask
    top = TOP_SHARE[encoding] * relief_mm
    if encoding == "domes":
        h = _domes(img, mask)
        return MIN_FEATURE_MM * mask + (top - MIN_FEATURE_MM) * h, mask
    if encoding == "ridges" and _is_tubular(mask, mm_per_px):
        # tubes (mitochondria, a filament network) are lines already: each raised along its own
        # skeleton, LINE_WIDTH_MM wide, not a texture cut by their outline (reads as noise)
        lines = morphology.skeletonize(mask)
        lines = ndi.binary_dilation(lines, structure=morphology.disk(max(0, round((LINE_WIDTH_MM / mm_per_px - 1) / 2))))
        return np.where(lines, top, 0.0), lines
    if encoding == "plateau":
        edge = mask & ~ndi.binary_erosion(mask, iterations=max(1, round(0.5 / mm_per_px)))
        return np.where(edge, OUTLINE_SHARE * relief_mm, np.where(mask, top, 0.0)), mask
    if encoding == "ridges":
        # a fibrous area (a sheet of cells' cytoskeleton): its extent is where there is signal over
        # the dark ground, which spans decades; Otsu of the brightness keeps only the brightest cytoplasm
        mask = mask | sheet_foreground(img)
    spec = spec_for(TEXTURE_OF[encoding], angle_deg)
    tex = pattern(spec, img.shape, mm_per_px)
    # Structures narrower than the texture's pitch (a filament, a spot) are their own ridge or dot:
    # they stand at the texture's full height; wider regions carry the texture on a plinth, so the
    # region's extent is felt between its features.
    plinth = max(MIN_FEATURE_MM, 0.15 * relief_mm)
    wide = ndi.binary_opening(mask, structure=morphology.disk(max(1, round(spec.pitch_mm / 2 / mm_per_px))))
    return np.where(wide, plinth + (top - plinth) * tex, np.where(mask, top, 0.0)), mask


def channel_relief(channels: list[ChannelImage], *, mm_per_px: float, base_mm: float, relief_mm: float,
                   assigned: dict[str, str] | None = None, max_channels: int = DEFAULT_MAX_CHANNELS,
                   section: str = "", title: str = "", channels_in_file: int = 0) -> ChannelRelief:
    """Heights in mm (base included) where each chosen channel's region carries its texture.

    `section` "XZ" (or "YZ"): the picture is an axial section, its rows along Z; shapes are
    measured with the Z stretch its points share undone (axial_stretch), and a note says so.

    Where regions overlap the higher layer wins (domes over dots over ridges over plateau), so
    nuclei are never hidden by cytoplasm. `channels_in_file`: how many the file has, when only
    some of them are given (channel_stage.MAX_CHANNELS_MEASURED), for the notes.
    """
    if relief_mm * min(TOP_SHARE.values()) < MIN_FEATURE_MM and relief_mm < 1.7:
        raise ParameterError(Text(f"`relief_mm` {relief_mm:g} mm is too low for channel textures (each needs "
                                  f"≥{MIN_FEATURE_MM:g} mm); use at least 1.7 mm."))
    # found once: the shape measures and the encoders share it
    found = {c.name: foreground(c.image) for c in channels if not assigned or c.name.lower() in assigned}
    notes = []
    stretch = axial_stretch(list(found.values())) if section and not assigned else 1.0
    if section:
        said = f"The picture is an {section} section (a side view: its rows run along Z, the optical axis)."
        if stretch >= AXIAL_STRETCH_MIN:
            said += (f" Its structures are {stretch:.1f}× longer along Z than across, as the optical blur along the axis "
                     f"draws points; their shapes were measured with Z shrunk by that, so round objects (beads, nuclei) "
                     f"are not taken for lines.")
        elif not assigned:
            said += " Its structures are not stretched along Z; their shapes were measured as they are."
        # How it was measured, for the record: the reader's own note already warns that the print is a side view
        notes.append(Decision(said))
    if stretch < AXIAL_STRETCH_MIN:
        stretch = 1.0
    choices, chose_notes = choose(channels, assigned or {}, mm_per_px, max_channels=max_channels, masks=found, stretch=stretch, title=title,
                                  channels_in_file=channels_in_file)
    for ch in choices:
        if ch.why == "file name":
            chose_notes.append(Decision(f"The channel {ch.name!r} names no marker of its own; the file's name does "
                                    f"({ch.role}), so it is printed as {ch.role}: {ch.encoding}.⟦ Say otherwise with `channels`.⟧"))
    notes += chose_notes
    by_name = {c.name: c for c in channels}
    heights = np.zeros(channels[0].image.shape)
    masks = {}
    order = sorted(choices, key=lambda ch: ("plateau", "ridges", "dots", "domes").index(ch.encoding))
    line_picture = np.max([by_name[ch.name].image for ch in choices], axis=0) if choices else heights
    angle = ridge_angle_unlike(line_picture)
    for ch in order:
        h, mask = encode(by_name[ch.name].image, ch.encoding, mm_per_px, relief_mm=relief_mm, angle_deg=angle, mask=found[ch.name])
        heights = np.where(mask, h, heights) if ch.encoding == "domes" else np.maximum(heights, h)
        masks[ch.name] = mask
    return ChannelRelief(base_mm + heights, choices, masks, notes)


# ---- brightfield stains ---------------------------------------------------------------

def is_stained_brightfield(rgb: np.ndarray) -> bool:
    """A stained slide: mostly bright background, with purple/pink/brown (not grey) tissue."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    lum = x.mean(axis=2)
    sat = x.max(axis=2) - x.min(axis=2)
    tissue = lum < 0.85
    return bool(np.median(lum) > 0.6 and tissue.mean() > 0.02 and np.median(sat[tissue]) > 0.08) if tissue.any() else False


def is_fluorescence_composite(rgb: np.ndarray) -> bool:
    """A fluorescence composite: a dark background with coloured signal."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    return bool(np.median(x.mean(axis=2)) < 0.25)


DAB_OD = 0.15  # optical density of DAB that is a stain, not the cross-talk H&E leaves in the DAB channel
DAB_MIN_SHARE = 0.01  # share of the tissue that must be DAB-positive for an IHC slide


def stain_channels(rgb: np.ndarray) -> list[ChannelImage]:
    """Haematoxylin and eosin (0..1 each), and DAB when the slide has it, by colour deconvolution; white space at 0."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    hed = color.rgb2hed(np.clip(x, 0, 1))
    tissue = x.mean(axis=2) < 0.85
    out = []
    for i, name in enumerate(("haematoxylin", "eosin", "DAB")):
        v = np.clip(hed[..., i], 0, None)
        if name == "DAB" and (not tissue.any() or float((v[tissue] > DAB_OD).mean()) < DAB_MIN_SHARE):
            break
        hi = np.percentile(v, 99.5)
        out.append(ChannelImage(name, (v / hi).clip(0, 1) if hi > 0 else v))
    return out


STAIN_ENCODING = {n: signal_role(n)[0] for n in ("haematoxylin", "eosin", "DAB")}  # from the one table, SIGNALS
STAIN_LABEL = {n: signal_role(n)[1] for n in ("haematoxylin", "eosin", "DAB")}
STAIN_TISSUE = 0.15  # haematoxylin + eosin (each 0..1) of tissue; glass and lumens (white) are under it
STROMA_TOP_SHARE = 0.35  # the stroma's ridges: a low texture (1.05 mm at 3 mm), under the nuclei
DOME_RISE_MM = 1.0  # a nuclei region reaches its full height 1 mm in from its edge (crowded nuclei merge into one region)


def glass_weight(rgb: np.ndarray) -> np.ndarray:
    """0..1, how much each pixel of a brightfield slide is white glass or a lumen: bright (mean RGB
    ≥ 0.8) and colourless (max − min < 0.1), as relief/channel_auto.py counts white. Measured on the
    RGB, not on the stain densities: an off-white glass tile is white, although its densities,
    stretched, are not zero."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    lum = x.mean(axis=2)
    chroma = x.max(axis=2) - x.min(axis=2)
    return np.clip((lum - 0.75) / 0.1, 0, 1) * np.clip((0.14 - chroma) / 0.08, 0, 1)


NUCLEAR_OD = 0.035  # haematoxylin density (rgb2hed) a nucleus reaches: CMU-1's epidermis 0.11, the carcinoma
# tile's tissue median 0.049, the stroma tile's nuclei 0.07; a frozen section with almost no haematoxylin (TCGA-CR-7395,
# its tissue's 99th percentile 0.029) has none that stand out, whatever the stretch makes of its faint tint


def nuclear_weight(rgb: np.ndarray) -> np.ndarray:
    """0..1, how clearly each pixel's haematoxylin density reaches a nucleus's (NUCLEAR_OD ± 0.01)."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    h = color.rgb2hed(np.clip(x, 0, 1))[..., 0]
    return np.clip((h - (NUCLEAR_OD - 0.01)) / 0.02, 0, 1)


def faint_haematoxylin(rgb: np.ndarray) -> float | None:
    """The tissue's 99th percentile of haematoxylin density when it stays under a nucleus's
    (NUCLEAR_OD: a faint section, the frozen TCGA-CR-7395 0.026), else None."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    tissue = glass_weight(x) < 0.5
    if tissue.sum() < 16:
        return None
    top = float(np.percentile(color.rgb2hed(np.clip(x, 0, 1))[..., 0][tissue], 99))
    return top if top < NUCLEAR_OD else None


def density_weight(rgb: np.ndarray, *, sigma_px: float = 1.0) -> np.ndarray:
    """0..1, how clearly each pixel's total optical density (all three colours), blurred by
    `sigma_px` (the print grid's pitch: a region, not its nuclei one by one), stands over the
    tissue's own Otsu threshold of it. On a section whose haematoxylin is too
    faint to find nuclei by (faint_haematoxylin), the cell-rich parts (tumour nests, epithelium)
    still absorb more light than the stroma between them, whichever stain darkens them: measured on
    TCGA-CR-7395, 85 % of its dark nests and none of its pale strands lie over the threshold,
    where its haematoxylin's own threshold takes 64 % and 57 %."""
    x = rgb[..., :3].astype(np.float64)
    x = x / (255.0 if x.max() > 1.5 else 1.0)
    od = filters.gaussian(-np.log10(np.clip(x, 1e-3, 1)).sum(axis=2), max(sigma_px, 0.5))
    tissue = glass_weight(x) < 0.5
    if tissue.sum() < 16 or float(np.ptp(od[tissue])) <= 1e-6:
        return np.zeros(od.shape)
    t = filters.threshold_otsu(od[tissue])
    return np.clip((od - t) / max(0.1 * t, 1e-4) + 0.5, 0, 1) * tissue


def stain_relief(channels: list[ChannelImage], *, mm_per_px: float, base_mm: float, relief_mm: float,
                 glass: np.ndarray | None = None, stained: np.ndarray | None = None,
                 dense: np.ndarray | None = None) -> ChannelRelief:
    """H&E / IHC (issue 32): nuclei (haematoxylin) raised as domes, stroma (eosin) a low ridge
    texture, DAB-positive regions a plateau, glass and lumens (white) at the base, whatever the
    share of glass.

    Nuclei are where haematoxylin stands above the tissue's own Otsu threshold (haematoxylin tints
    all tissue; a tile crowded with nuclei has them over half its tissue, a stroma tile a few
    percent); each region rises to its full height within DOME_RISE_MM of its edge, so a field of
    crowded nuclei reads as a high field with grooves, not as one low hill. `glass`: where the
    slide is white (glass_weight ≥ 0.5, on the print grid); else tissue is where the densities are.
    `stained`: where haematoxylin reaches a nucleus's density (nuclear_weight ≥ 0.5, on the grid);
    the channels, stretched to 0..1, no longer say how much stain there is. `dense`: on a section
    whose haematoxylin is too faint for nuclei (faint_haematoxylin), the cell-dense tissue
    (density_weight ≥ 0.5) is raised in their place.
    """
    if relief_mm * STROMA_TOP_SHARE < MIN_FEATURE_MM and relief_mm < 1.7:
        raise ParameterError(Text(f"`relief_mm` {relief_mm:g} mm is too low for stain textures (each needs "
                                  f"≥{MIN_FEATURE_MM:g} mm); use at least 1.7 mm."))
    h, e = channels[:2]
    tissue = (e.image + h.image) > STAIN_TISSUE if glass is None else ~glass
    tissue = morphology.remove_small_objects(tissue, max_size=8)
    notes = []
    nuclei = np.zeros(tissue.shape, bool)
    if dense is not None:
        nuclei = morphology.remove_small_objects(tissue & dense, max_size=8)
    elif tissue.sum() > 16 and float(np.ptp(h.image[tissue])) > 1e-6:
        smooth = filters.gaussian(h.image, 1.0)
        nuclei = tissue & (smooth > filters.threshold_otsu(smooth[tissue]))
        if stained is not None:
            nuclei &= stained
        nuclei = morphology.remove_small_objects(nuclei, max_size=8)
    stroma = tissue & ~nuclei
    top = relief_mm
    heights = np.zeros(tissue.shape)
    # stroma: a low ridge texture on a 0.5 mm plinth (ridges felt as a texture, not as shape)
    stroma_top = max(STROMA_TOP_SHARE * relief_mm, MIN_FEATURE_MM + 0.3)
    spec = spec_for(TEXTURE_OF["ridges"], 0.0)
    tex = pattern(spec, tissue.shape, mm_per_px)
    heights = np.where(stroma, MIN_FEATURE_MM + (stroma_top - MIN_FEATURE_MM) * tex, heights)
    masks = {"haematoxylin": nuclei, "eosin": stroma}
    choices = [ChannelChoice("haematoxylin", "domes", "stain"), ChannelChoice("eosin", "ridges", "stain")]
    if len(channels) > 2:
        dab = foreground(channels[2].image) & tissue
        plateau = OUTLINE_SHARE * relief_mm
        heights = np.where(dab, plateau, heights)
        masks["DAB"] = dab
        choices.append(ChannelChoice("DAB", "plateau", "stain"))
    else:
        notes.append(Decision("No DAB stain found (an H&E slide): haematoxylin and eosin are printed."))
    # nuclei: domes over everything else, rising fully within DOME_RISE_MM of their edge
    dist = ndi.distance_transform_edt(nuclei)
    dome = np.sqrt(np.clip(dist / max(DOME_RISE_MM / mm_per_px, 1.0), 0, 1))
    heights = np.where(nuclei, MIN_FEATURE_MM + (top - MIN_FEATURE_MM) * dome, heights)
    if not nuclei.any():
        notes.append(Text("No nuclei stand out of the tissue's haematoxylin: the tissue is printed as stroma."))
    return ChannelRelief(base_mm + heights, choices, masks, notes)
