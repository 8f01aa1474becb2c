"""The reader contribution: microscope files napari does not read itself (CZI, LIF, ND2, MRC,
EMD, TIA, DM3/DM4, JEOL, ELID, Olympus, HyperSpy) opened through our readers, one layer per
channel, at the scale the file records, each layer marked with where it came from so that the
widget prints the file itself (with its metadata) when it is printed as read."""

from __future__ import annotations

from pathlib import Path

from ..read.image import DM_MAGIC
from .layers import READER_MARK

# Fluorescence colours by emission wavelength (nm): what the layer list shows, not what is printed.
COLOURS = ((500.0, "blue"), (570.0, "green"), (620.0, "yellow"), (1e9, "red"))


def napari_get_reader(path):
    """npe2's reader hook: our reader for a file our readers take and napari's do not, else None."""
    if isinstance(path, (list, tuple)):
        return None if len(path) != 1 else napari_get_reader(path[0])
    return read_layers if is_ours(Path(path)) else None


def is_ours(path: Path) -> bool:
    """A vendor file (read/vendor/) or a DigitalMicrograph file (read/image.py reads those)."""
    from ..read.vendor import detect

    try:
        if path.is_file():
            with path.open("rb") as fh:
                if fh.read(4) in DM_MAGIC:
                    return True
        return bool((path.is_file() or path.is_dir()) and detect(path))
    except OSError:
        return False


def read_layers(path) -> list[tuple]:
    """[(data, layer keywords, "image")], one per channel of the file's first scene and time point
    (the maximum over z, as `tamp-os convert` prints it)."""
    from ..clean.scale import read_pixel_size
    from ..read.channels import read_channels
    from ..read.image import read_image

    path = Path(path)
    picture = read_image(path)
    f = picture.file
    metres = read_pixel_size(f.metadata, f.tiff_tags, f.path, width_px=f.width).metres
    planes = read_channels(path) if f.channel_count > 1 else None
    if not planes:
        return [(picture.values, _keywords(path, path.stem, metres, None, 1, None), "image")]
    return [(p.values, _keywords(path, f"{path.stem} {p.name}", metres, i, len(planes), p.wavelength_nm), "image")
            for i, p in enumerate(planes)]


def _keywords(path: Path, name: str, metres: float | None, channel: int | None, channels: int, wavelength_nm) -> dict:
    keywords = {"name": name, "metadata": {READER_MARK: {"path": str(path), "channel": channel, "channels": channels,
                                                        "pixel_size_m": metres}}}
    if metres:
        keywords.update(scale=(metres * 1e6, metres * 1e6), units=("micrometer", "micrometer"))
    if channels > 1:
        colour = next((c for limit, c in COLOURS if wavelength_nm and wavelength_nm < limit), None)
        keywords.update(blending="additive", colormap=colour or "gray")
    return keywords
