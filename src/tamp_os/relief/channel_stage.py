"""The channel path of the pipeline: read every channel, put each on the print grid, encode it as
a texture (relief/channels.py) and add a braille key along the bottom margin (relief/key3d.py).

Taken when `channels` is given ("auto" or NAME=ENCODING assignments) and the picture has several
channels or is a stained brightfield RGB.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError, Text
from .channels import (
    STAIN_LABEL,
    ChannelImage,
    ChannelRelief,
    KeyEntry,
    channel_relief,
    is_fluorescence_composite,
    is_stained_brightfield,
    parse_assignments,
    stain_channels,
    stain_relief,
)
from .preprocess import prepare


@dataclass
class ChannelStage:
    relief: ChannelRelief
    key: tuple[KeyEntry, ...]
    kind: str  # "fluorescence" or "stain"


def _raw_channels(source, params) -> list:
    """[(name, values, excitation_nm, emission_nm)] of the source, or an RGB array to deconvolve."""
    if isinstance(source, (str, Path)):
        from ..vendor_read import read_channels

        planes = read_channels(source, scene=params.scene, time=params.time, z_slice=params.z_slice,
                               max_megapixels=params.max_megapixels, max_decoded_gb=params.max_decoded_gb)
        return [(p.name, p.values, p.excitation_nm, p.emission_nm) for p in planes]
    arr = np.asarray(source)
    if arr.ndim == 3 and arr.shape[2] in (3, 4):
        return [(n, arr[..., i].astype(np.float32), None, None) for i, n in enumerate(("red", "green", "blue"))]
    if arr.ndim == 3:  # (C, H, W) stack
        return [(f"channel {i}", arr[i].astype(np.float32), None, None) for i in range(arr.shape[0])]
    return [("luminance", arr.astype(np.float32), None, None)]


def _on_grid(values: np.ndarray, layout, params) -> np.ndarray:
    return prepare(values, None, rows=layout.rows, cols=layout.cols, target_aspect=layout.target_aspect, fit=layout.fit,
                   low_pct=params.stretch_low_pct, high_pct=params.stretch_high_pct, sigma_px=layout.blur_px,
                   invert=False, flip_x=params.flip_x).image


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


_ROLE = {"domes": "nuclei", "ridges": "filaments", "dots": "spots", "plateau": "cytoplasm"}


def run(source, layout, params) -> ChannelStage | None:
    """The channel relief, or None when the picture has a single plain channel (the usual path then)."""
    raw = _raw_channels(source, params)
    names = [r[0] for r in raw]
    rgb = names[:3] == ["red", "green", "blue"]
    assigned = parse_assignments(params.channels)
    labels = _labels(params.key_labels)
    mm = layout.mm_per_px
    if rgb:
        stack = np.stack([r[1] for r in raw[:3]], axis=-1)
        if is_stained_brightfield(stack) and not assigned:
            on_grid = [ChannelImage(c.name, _on_grid(c.image, layout, params)) for c in stain_channels(stack)]
            # stain densities are already 0..1; prepare() stretched them again, which keeps white at 0
            rel = stain_relief(on_grid, mm_per_px=mm, base_mm=params.base_mm, relief_mm=params.relief_mm)
            key = tuple(KeyEntry(labels.get(ch.name.lower(), STAIN_LABEL[ch.name]), ch.encoding) for ch in rel.choices)
            return ChannelStage(rel, key, "stain")
        if not is_fluorescence_composite(stack) and not assigned:
            return None  # an ordinary colour picture
    elif len(raw) < 2:
        if assigned:
            raise ParameterError(Text("`channels`: this picture has a single channel; there is nothing to assign. "
                                      "Leave `channels` unset."))
        return None
    chans = [ChannelImage(n, _on_grid(v, layout, params), ex, em) for n, v, ex, em in raw]
    chans = [c for c in chans if float(c.image.max() - c.image.min()) > 1e-6] or chans  # empty (e.g. unused blue) left out
    rel = channel_relief(chans, mm_per_px=mm, base_mm=params.base_mm, relief_mm=params.relief_mm, assigned=assigned)
    key = tuple(KeyEntry(labels.get(ch.name.lower(), f"{_ROLE[ch.encoding]} ({ch.name})"), ch.encoding) for ch in rel.choices)
    return ChannelStage(rel, key, "fluorescence")


def describe_key(key) -> str:
    """"domes: nuclei (DAPI); ridges: filaments (GFP)" for the description and the report."""
    return "; ".join(f"{e.encoding}: {e.label}" for e in key)


def channel_path(source, relief, layout, params):
    """(relief, layout, key) of the channel print, or the ones given when the picture is not one."""
    import dataclasses

    from .key3d import key_strip
    from .styles import ReliefResult

    stage = run(source, layout, params)
    if stage is None:
        note = Text("`channels`: this picture has one plain channel (not a multi-channel or stained picture); "
                    "it is printed as usual.")
        return dataclasses.replace(relief, notes=tuple(relief.notes) + (note,)), layout, ()
    rel = stage.relief
    strip = key_strip(stage.key, width_mm=layout.width_mm, mm_per_px=layout.mm_per_px, relief_mm=params.relief_mm,
                      table=params.braille_table)
    cols = rel.heights_mm.shape[1]
    key_h = strip.heights_mm[:, :cols]
    heights = np.vstack([rel.heights_mm, params.base_mm + key_h[1:]])
    grown = dataclasses.replace(layout, rows=heights.shape[0], depth_mm=layout.depth_mm + (key_h.shape[0] - 1) * layout.mm_per_px)
    what = "stains" if stage.kind == "stain" else "channels"
    reason = (f"{len(rel.choices)} {what} as textures: {describe_key(strip.entries)} "
              f"(encodings from {', '.join(sorted({c.why for c in rel.choices}))}).")
    notes = tuple(rel.notes) + (Text(f"The plate grew by {grown.depth_mm - layout.depth_mm:.1f} mm along its depth to hold the "
                                     f"braille key below the picture."),)
    out = ReliefResult(heights, "channels", reason, None, (), notes)
    return out, grown, strip.entries
