"""The channel path of the pipeline: read every channel, put each on the print grid, encode it as
a texture (relief/channels.py) and add a braille key along the bottom margin (relief/key3d.py).

Taken by default when the picture has several channels, or is a fluorescence composite or a
stained brightfield slide in RGB (relief/channel_auto.py decides); `channels` NAME=ENCODING forces it,
`channels` off or a single `channel` keeps the luminance path.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Decision, ParameterError, Text
from .channels import (
    STAIN_LABEL,
    ChannelImage,
    ChannelRelief,
    KeyEntry,
    channel_relief,
    glass_weight,
    nuclear_weight,
    NUCLEAR_OD,
    density_weight,
    faint_haematoxylin,
    is_fluorescence_composite,
    is_stained_brightfield,
    parse_assignments,
    signal_role,
    some_names,
    stain_channels,
    stain_relief,
)
from .channel_auto import OFF, unused_key_labels
from .key_labels import label_forms
from .preprocess import prepare


@dataclass
class ChannelStage:
    relief: ChannelRelief
    key: tuple[KeyEntry, ...]
    kind: str  # "fluorescence" or "stain"


MAX_CHANNEL_NAME = 40  # characters of a file's channel name kept for the key, the messages and the recipe


def channel_name(name, index: int) -> str:
    """A file's channel name as the key and the messages can say it: control and format characters
    (NUL, escape sequences, right-to-left overrides, zero-width marks) dropped, white space made
    single spaces, at most MAX_CHANNEL_NAME characters ('…' marks a cut); 'channel N' when
    nothing is left. Letters of any script and emoji are kept: the braille translator says
    what it cannot write."""
    import unicodedata

    text = "".join(ch if unicodedata.category(ch) not in ("Cc", "Cf", "Zl", "Zp") else " " for ch in str(name or "")[:10 * MAX_CHANNEL_NAME])
    text = " ".join(text.split())
    if len(text) > MAX_CHANNEL_NAME:
        text = text[:MAX_CHANNEL_NAME - 1].rstrip() + "…"
    return text or f"channel {index}"


# The channel print keeps DEFAULT_MAX_CHANNELS (3) textures, chosen by measuring each channel on the
# print grid (its read, its annotations, its trip to the grid and its shape measures: 0.2-0.6 s a
# channel at the default grid, 4x that at High), so a file of 100 channels took 45 s. At most this
# many are read and measured (twice the 2-4 channels of a usual fluorescence file); a note says which.
MAX_CHANNELS_MEASURED = 8


@dataclass
class ChannelPick:
    """Which of a file's channels the channel print reads (read_channels' `pick`): every one up to
    MAX_CHANNELS_MEASURED; past that, those `channels` assigns, else those whose name says what
    they label (a dye: relief/channels.py signal_role) or whose file records a wavelength, then
    the first in the file's order. Remembers how many the file has."""

    assigned: dict
    total: int = 0

    def __call__(self, channels) -> list[int]:
        self.total = len(channels)
        if self.total <= MAX_CHANNELS_MEASURED:
            return list(range(self.total))
        names = [channel_name(c.name, i) for i, c in enumerate(channels)]
        if self.assigned:
            unknown = sorted(set(self.assigned) - {n.lower() for n in names})
            if unknown:
                raise ParameterError(Text(f"`channels`: no channel named {some_names(unknown)} in this picture; its channels "
                                          f"are {some_names(names)}."))
            return [i for i, n in enumerate(names) if n.lower() in self.assigned]
        known = [i for i, c in enumerate(channels) if signal_role(names[i]) or c.wavelength_nm is not None]
        rest = [i for i in range(self.total) if i not in set(known)]
        return sorted((known + rest)[:MAX_CHANNELS_MEASURED])


def raw_channels(source, params, *, pick: ChannelPick | None = None) -> list:
    """[(name, values, excitation_nm, emission_nm)] of the source, or an RGB array to deconvolve;
    of a file, the channels `pick` picks (all without one)."""
    if isinstance(source, (str, Path)):
        from ..read.channels import read_channels

        planes = read_channels(source, scene=params.scene, time=params.time, z_slice=params.z_slice,
                               max_megapixels=params.max_megapixels, max_decoded_gb=params.max_decoded_gb, pick=pick)
        return [(channel_name(p.name, i), p.values, p.excitation_nm, p.emission_nm) for i, p in enumerate(planes)]
    arr = np.asarray(source)
    if arr.ndim == 3 and arr.shape[2] in (3, 4):
        return [(n, arr[..., i].astype(np.float32), None, None) for i, n in enumerate(("red", "green", "blue"))]
    if arr.ndim == 3:  # (C, H, W) stack
        return [(f"channel {i}", arr[i].astype(np.float32), None, None) for i in range(arr.shape[0])]
    return [("luminance", arr.astype(np.float32), None, None)]


def _near_grid(rgb: np.ndarray, layout) -> np.ndarray:
    """A slide averaged down to about twice the grid (colour deconvolution of millions of pixels
    the grid will average anyway costs seconds); blocks of whole pixels, so no colour is invented."""
    f = int(min(rgb.shape[0] / max(layout.rows, 1), rgb.shape[1] / max(layout.cols, 1)) // 2)
    if f < 2:
        return rgb
    h, w = rgb.shape[0] // f * f, rgb.shape[1] // f * f  # under half a grid pitch cut at the far edges
    return rgb[:h, :w, :3].reshape(h // f, f, w // f, f, 3).mean(axis=(1, 3), dtype=np.float32)


def _on_grid(values: np.ndarray, layout, params) -> np.ndarray:
    return prepare(values, None, rows=layout.rows, cols=layout.cols, target_aspect=layout.target_aspect, fit=layout.fit,
                   low_pct=params.stretch_low_pct, high_pct=params.stretch_high_pct, sigma_px=layout.blur_px,
                   invert=False, flip_x=params.flip_x).image


DENSE_LABEL = "dense tissue"  # the key's word for what a faint section raises in place of nuclei


def _weight_on_grid(w: np.ndarray, layout, params) -> np.ndarray:
    """Where a 0..1 weight (relief/channels.py glass_weight, nuclear_weight) is at least 0.5, on the print grid."""
    if float(w.max()) < 0.5:
        return np.zeros((layout.rows, layout.cols), bool)
    if float(w.min()) > 0.5:
        return np.ones((layout.rows, layout.cols), bool)
    grid = prepare(w.astype(np.float32), None, rows=layout.rows, cols=layout.cols, target_aspect=layout.target_aspect,
                   fit=layout.fit, low_pct=0.0, high_pct=100.0, sigma_px=0.0, invert=False, flip_x=params.flip_x).image
    return grid >= 0.5


def _labels(text: str | None) -> dict[str, str]:
    """`key_labels` "DAPI=nuclei,GFP=actin" -> {"dapi": "nuclei", ...}."""
    out = {}
    for part in (text or "").split(","):
        if part.strip():
            name, sep, label = part.partition("=")
            if not sep or not label.strip():
                raise ParameterError(Text(f"`key_labels`: {part.strip()!r} is not NAME=LABEL; write e.g. \"DAPI=nuclei,GFP=actin\"."))
            out[name.strip().lower()] = label.strip()
    return out


def _check_labels(labels: dict[str, str], names) -> tuple[Text, ...]:
    """Refuse `key_labels` of which no name is one of the picture's channels (`names`): they were
    left out without a word (issue 51.6); a note for those of them that name no channel."""
    from .channels import some_names

    known = {str(n).lower() for n in names}
    unknown = [name for name in labels if name not in known]
    if not unknown:
        return ()
    said = f"no channel named {some_names(unknown)} in this picture; its channels are {some_names(list(names))}"
    if len(unknown) == len(labels):
        raise ParameterError(Text(f"`key_labels`: {said}. Name the channels as the key does (NAME=LABEL), or leave "
                                  f"`key_labels` out."), parameter="key_labels", allowed=f"names among {some_names(list(names))}")
    return (Text(f"`key_labels`: {said}; those labels are not used."),)


_ROLE = {"domes": "nuclei", "ridges": "filaments", "dots": "spots", "plateau": "cytoplasm"}
# An encoding chosen by measured shape says what the shape is, not what biology it might be (the
# tubes of mitochondria are not "filaments", a dense field of EB3 comets is not "cytoplasm").
_SHAPE_WORD = {"domes": "round blobs", "ridges": "lines", "dots": "spots", "plateau": "diffuse"}


def _entry(choice, labels: dict[str, str]) -> KeyEntry:
    given = labels.get(choice.name.lower())
    if given is not None:  # the user's own words, written as given
        return KeyEntry(given, choice.encoding)
    # the role from the one table of signal names (relief/channels.py SIGNALS), the wavelength or the
    # colour convention; a shape says only what the shape is
    role = choice.role or (_SHAPE_WORD if choice.why in ("shape", "distinct") else _ROLE)[choice.encoding]
    return KeyEntry(f"{role} ({choice.name})", choice.encoding, key_forms=label_forms(role, choice.name, bool(choice.role)),
                    key_role=role)


def _as_cleaned(raw: list, cleaned) -> tuple[list, list]:
    """Each channel cropped like the grey picture (its data band) and blank where annotations were
    removed: those found on the grey picture (channel 0, or an RGB picture's luminance) from every
    channel, and those found on each channel alone (a label burnt into one channel) from that
    channel; with a note for each of the latter. Annotations kept (`keep_annotations`): cropped only."""
    from ..clean.annotations import detect_annotations

    if cleaned is None:
        return raw, []
    top, bottom = cleaned.band.top_rows, cleaned.band.bottom_rows
    out, notes = [], []
    for name, values, ex, em in raw:
        if values.shape[0] == top + cleaned.values.shape[0] + bottom and values.shape[1] == cleaned.values.shape[1]:
            values = values[top: values.shape[0] - bottom]
            if cleaned.mask is not None and cleaned.mask.shape == values.shape:
                own, found = detect_annotations(values)
                new = own & ~cleaned.mask
                if found and new.any():
                    notes.append(Text(f"Removed from the channel {name!r} alone (a mark burnt into it): "
                                      f"{'; '.join(a.describe() for a in found)}."))
                mask = cleaned.mask | own
                if mask.any():
                    values = np.where(mask, np.float32(np.median(values)), values)  # a scale bar is no channel's structure
        out.append((name, values, ex, em))
    return out, notes


def run(source, layout, params, *, route=None, cleaned=None, title: str = "") -> ChannelStage | None:
    """The channel relief, or None when the picture has a single plain channel (the usual path then)."""
    assigned = parse_assignments(params.channels) if route is None or route.kind == "assigned" else {}
    pick = ChannelPick(assigned)
    raw, cleaning_notes = _as_cleaned(raw_channels(source, params, pick=pick), cleaned)
    if pick.total > len(raw) and not assigned:
        cleaning_notes.insert(0, Decision(
            f"The picture has {pick.total} channels; {len(raw)} were read and measured ({some_names([r[0] for r in raw])}: those "
            f"whose name or wavelength says what they show, then the first in the file's order), the other "
            f"{pick.total - len(raw)} not (measuring each takes its time)."))
    names = [r[0] for r in raw]
    rgb = names[:3] == ["red", "green", "blue"]
    labels = _labels(params.key_labels)
    mm = layout.mm_per_px
    if rgb:
        stack = np.stack([r[1] for r in raw[:3]], axis=-1)
        stain = route.kind == "stain" if route is not None and route.kind != "assigned" else is_stained_brightfield(stack)
        if stain and not assigned:
            label_notes = _check_labels(labels, STAIN_LABEL)
            stack = _near_grid(stack, layout)
            on_grid = [ChannelImage(c.name, _on_grid(c.image, layout, params)) for c in stain_channels(stack)]
            # stain densities are already 0..1; prepare() stretched them again; glass and lumens are
            # found on the colours themselves (an off-white glass tile's stretched densities are not 0)
            faint = faint_haematoxylin(stack)
            rel = stain_relief(on_grid, mm_per_px=mm, base_mm=params.base_mm, relief_mm=params.relief_mm,
                               glass=_weight_on_grid(glass_weight(stack), layout, params),
                               stained=_weight_on_grid(nuclear_weight(stack), layout, params),
                               dense=None if faint is None else _weight_on_grid(
                                   density_weight(stack, sigma_px=stack.shape[1] / layout.cols), layout, params))
            rel.notes[:0] = cleaning_notes
            names = dict(STAIN_LABEL)
            if faint is not None:
                names["haematoxylin"] = DENSE_LABEL
                rel.notes.append(Decision(f"The section's haematoxylin is faint (its tissue's 99th percentile {faint:.3f} optical "
                                          f"density, a nucleus reaches {NUCLEAR_OD:g}): no nuclei stand out, so the denser "
                                          f"tissue (cell-rich nests, by its total optical density) is raised as domes and the "
                                          f"paler stroma is a low texture."))
            rel.notes.extend(label_notes)
            key = tuple(KeyEntry(labels.get(ch.name.lower(), names[ch.name]), ch.encoding) for ch in rel.choices)
            return ChannelStage(rel, key, "stain")
        fluorescence = route.kind == "fluorescence" if route is not None and route.kind != "assigned" else is_fluorescence_composite(stack)
        if not fluorescence and not assigned:
            return None  # an ordinary colour picture
    elif len(raw) < 2:
        if assigned:
            raise ParameterError(Text("`channels`: this picture has a single channel; there is nothing to assign. "
                                      "Leave `channels` unset."))
        return None
    label_notes = _check_labels(labels, names)  # before the work: a mistake costs nothing
    chans = [ChannelImage(n, _on_grid(v, layout, params), ex, em) for n, v, ex, em in raw]
    chans = [c for c in chans if float(c.image.max() - c.image.min()) > 1e-6] or chans  # empty (e.g. unused blue) left out
    if len(chans) < 2 and not assigned:
        return None  # one channel with signal: nothing for a key to tell apart
    rel = channel_relief(chans, mm_per_px=mm, base_mm=params.base_mm, relief_mm=params.relief_mm, assigned=assigned,
                         channels_in_file=max(pick.total, len(chans)),
                         section=route.section if route is not None else "",
                         title=" ".join(t for t in (Path(source).stem if isinstance(source, (str, Path)) else "", title) if t))
    rel.notes[:0] = cleaning_notes
    rel.notes.extend(label_notes)
    key = tuple(_entry(ch, labels) for ch in rel.choices)
    return ChannelStage(rel, key, "fluorescence")


def describe_key(key) -> str:
    """"domes: nuclei (DAPI); ridges: filaments (GFP)" for the description and the report."""
    return "; ".join(f"{e.encoding}: {e.label}" for e in key)


def channel_path(source, relief, layout, *, params, route=None, cleaned=None, title: str = ""):
    """(relief, layout, key, key overlay) of the channel print, or the plain relief when the picture is not one.

    The key overlay is a heightmap (mm above the base, like the relief's) of what a two-colour
    print makes in its second colour: the key's braille and swatch outlines; None without a key.

    `relief` is the luminance relief, or a function that makes it (only called when needed).
    `route` (relief/channel_auto.py) says why the picture is printed channel by channel; None with
    `channels` given explicitly keeps the old opt-in behaviour. `title`: the file's own name for
    its picture (a CZI's document name), whose marker words may name channels (marker_in_title).
    """
    import dataclasses

    from .key3d import key_strip
    from .styles import ReliefResult

    plain = relief if not callable(relief) else None

    def luminance():
        return plain if plain is not None else relief()

    asked = bool(params.channels) and str(params.channels).strip().lower() not in OFF
    stage = run(source, layout, params, route=route, cleaned=cleaned, title=title) if route is not None or asked else None
    if stage is None:
        out = luminance()
        if asked:  # asked for, not possible
            note = Text("`channels`: this picture has one plain channel (not a multi-channel or stained picture); "
                        "it is printed as usual.")
            out = dataclasses.replace(out, notes=tuple(out.notes) + (note,))
        out = dataclasses.replace(out, notes=tuple(out.notes) + unused_key_labels(params.key_labels))
        return out, layout, (), None
    rel = stage.relief
    strip = key_strip(stage.key, width_mm=layout.width_mm, mm_per_px=layout.mm_per_px, relief_mm=params.relief_mm,
                      table=params.braille_table)
    cols = rel.heights_mm.shape[1]
    key_h = strip.heights_mm[:, :cols]
    heights = np.vstack([rel.heights_mm, params.base_mm + key_h[1:]])
    grown = dataclasses.replace(layout, rows=heights.shape[0], depth_mm=layout.depth_mm + (key_h.shape[0] - 1) * layout.mm_per_px)
    what = "stains" if stage.kind == "stain" else "channels"
    why = f"auto chose channels ({route.why}): " if route is not None and route.kind != "assigned" else ""
    reason = (f"{why}{len(rel.choices)} {what} as textures: {describe_key(strip.entries)} "
              f"(encodings from {', '.join(sorted({c.why for c in rel.choices}))}).")
    notes = tuple(rel.notes) + _key_notes(stage, route if why else None, strip, params.braille_table,
                                          grown.depth_mm - layout.depth_mm)
    out = ReliefResult(heights, "channels", reason, None, (), notes)
    overlay = np.vstack([np.zeros_like(rel.heights_mm), strip.overlay_mm[1:, :cols]])
    return out, grown, strip.entries, ChannelExtras(overlay, region_map(rel))


def _key_notes(stage, route, strip, braille_table: str, grown_mm: float) -> tuple[Text, ...]:
    """What the channel print says of itself beside its reason: why auto printed it channel by
    channel (`route`, None when it was asked for), the key's shortened or cut braille labels, and
    how far the plate grew to hold the key."""
    from ..tactile.braille import to_braille

    notes: tuple[Text, ...] = ()
    if route is not None:
        how = ("The stains were separated by colour deconvolution" if stage.kind == "stain"
               else "The picture was printed channel by channel")
        # (⟦…⟧: advice a front end without those controls leaves out, errors.render)
        notes += (Decision(f"{how}, each a texture named in the key, because {route.why}⟦; `channel` prints a single "
                           f"channel⟧⟦, and `channels` off prints the brightness as before⟧."),)
    short = [e for e in strip.entries if e.braille_label and e.braille_label != e.label]
    if short:
        notes += (Decision("The key writes shorter labels in braille, to fit its lines: "
                           + "; ".join(f"{e.braille_label!r} for {e.label!r}" for e in short) + "."),)
    cut = [e.label for e in strip.entries if e.braille != to_braille(e.braille_label, braille_table, what="key_labels")]
    if cut:
        notes += (Text(f"The key's braille for {', '.join(map(repr, cut))} is cut to two lines⟦; give a shorter label "
                       f"with `key_labels`⟧."),)
    notes += (Decision(f"The plate grew by {grown_mm:.1f} mm along its depth to hold the braille key below the picture."),)
    return notes


@dataclass(frozen=True)
class ChannelExtras:
    """What a channel print hands on beside its heights: the key overlay (two-colour prints) and the
    picture's region map (the 2-D graphic: 0 background, i = the i-th key entry's region)."""

    overlay_mm: np.ndarray  # (rows, cols) of the whole print, key included
    regions: np.ndarray  # (picture rows, cols) int32


_LAYER_ORDER = ("plateau", "ridges", "dots", "domes")  # as channel_relief stacks them: domes on top


def region_map(rel: ChannelRelief) -> np.ndarray:
    out = np.zeros(rel.heights_mm.shape, np.int32)
    for i in sorted(range(len(rel.choices)), key=lambda i: _LAYER_ORDER.index(rel.choices[i].encoding)):
        mask = rel.masks.get(rel.choices[i].name)
        if mask is not None:
            out[mask] = i + 1
    return out


PAPER_TEXTURE = {"ridges": "lines", "dots": "dots", "domes": "outline", "plateau": "outline"}


def paper_textures(key) -> dict[int, str]:
    """Region value -> swell-paper texture (outline, dots, lines), each used once: a finger tells three apart."""
    out, used = {}, set()
    for i, e in enumerate(key):
        want = PAPER_TEXTURE.get(e.encoding, "outline")
        if want in used:
            want = next((t for t in ("outline", "dots", "lines") if t not in used), want)
        out[i + 1] = want
        used.add(want)
    return out


def without_channel_note(picture):
    """The picture without the reader's "using channel 0" note: a print of several channels did not."""
    import dataclasses

    notes = [n for n in picture.file.notes if "using channel 0" not in str(n)]
    if len(notes) == len(picture.file.notes):
        return picture
    return dataclasses.replace(picture, file=dataclasses.replace(picture.file, notes=notes))
