"""Every channel of one plane of a picture, with names and wavelengths: a vendor file's channels
(read/vendor/), an OME or ImageJ TIFF's, or the colours of an RGB image (read/image.py)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .model import LUMA_601, Limits, imagej_info_channels
from .vendor import Channel, Request, detect, read_planes


@dataclass(frozen=True)
class ChannelPlane:
    """One channel of the chosen plane.

    name : the channel's name in the file ("DAPI", "ChA-T1", "HyD 1 Leica/FITC"), or "channel N".
    wavelength_nm : emission wavelength where recorded, else excitation, else None.
    values : (H, W) float32 at the file's own scale (not stretched).
    """

    name: str
    wavelength_nm: float | None
    values: np.ndarray
    excitation_nm: float | None = None
    emission_nm: float | None = None


def read_channels(path, *, scene: int | str | None = None, time: int | None = None, z_slice: int | None = None,
                  max_megapixels: float = 400.0, max_decoded_gb: float = 2.0, pick=None) -> list[ChannelPlane]:
    """Every channel of one plane of a microscope file, with names and wavelengths.

    The plane is the first scene and time point and the maximum-intensity projection over Z,
    unless `scene`, `time` or `z_slice` choose another. All channels together are priced against
    `max_decoded_gb` before any pixel is decoded. Files that read.py reads itself (TIFF, DM,
    PNG…) give one ChannelPlane per OME/ImageJ channel, or per colour (red, green, blue) of an
    RGB image, or a single "luminance" plane.

    pick : a function of the file's channels (a list of vendor.model.Channel: name, wavelengths)
    that returns the indices to read; only those are priced and read (a file of 100 channels need
    not be read whole to print three). None reads every channel. Colours are always all read.

    Returns a list of ChannelPlane in the file's channel order. Raises InputError or
    ParameterError in plain words, as read_image does.
    """
    from .image import read_image  # looked up when called, as every reader of a plane is

    path = Path(path)
    limits = Limits(max_megapixels, max_decoded_gb)
    kind = detect(path) if path.exists() else None
    if kind:
        planes = read_planes(path, kind, Request(scene, time, z_slice), limits=limits, all_channels=True, pick=pick)
        channels = planes.stack.channel_list()
        return [ChannelPlane(channels[c].name, channels[c].wavelength_nm, _grey(a), channels[c].excitation_nm, channels[c].emission_nm)
                for a, c in zip(planes.chosen.arrays, planes.chosen.channels)]
    first = read_image(path, page=scene, z_slice=z_slice, max_megapixels=max_megapixels, max_decoded_gb=max_decoded_gb)
    count = first.file.channel_count
    if count > 1 and "C" in first.file.axes:
        names = first.file.channel_names or [f"channel {i}" for i in range(count)]
        info = imagej_info_channels(first.file.metadata.get("imagej_metadata") or {})
        waves = [(ex, em) for n, ex, em in info] if [n for n, _, _ in info] == names[:len(info)] else []

        def plane(i, values):
            ex, em = waves[i] if i < len(waves) else (None, None)
            return ChannelPlane(names[i] if i < len(names) else f"channel {i}", em or ex, values, ex, em)

        wanted = range(count)
        if pick is not None:
            listed = [plane(i, None) for i in range(count)]
            wanted = sorted({int(i) for i in pick([Channel(p.name, p.excitation_nm, p.emission_nm) for p in listed]) if 0 <= int(i) < count})
        out = [plane(0, first.values)] if 0 in wanted else []
        for i in (i for i in wanted if i > 0):
            p = read_image(path, page=scene, z_slice=z_slice, channel=str(i), max_megapixels=max_megapixels, max_decoded_gb=max_decoded_gb)
            out.append(plane(i, p.values))
        return out
    if first.file.channels in (3, 4):
        return [ChannelPlane(colour, None, read_image(path, page=scene, channel=colour, max_megapixels=max_megapixels,
                                                      max_decoded_gb=max_decoded_gb).values) for colour in ("red", "green", "blue")]
    return [ChannelPlane("luminance", None, first.values)]


def _grey(array: np.ndarray) -> np.ndarray:
    array = np.asarray(array)
    if array.ndim == 3:  # a colour plane of a vendor file: luminance
        array = array[..., :3].astype(np.float32) @ LUMA_601
    return array.astype(np.float32)
