"""A vendor file's chosen plane as read.py's Picture (the glue between vendor_read and read.py)."""

from __future__ import annotations

from pathlib import Path

from ...errors import ParameterError


def read_vendor(path: Path, kind, page, *, channel, limits, z_slice, time, scene, target_px):
    """A vendor file (CZI, LIF, ND2, OME-Zarr, TIA, EMD, MRC, JEOL, ELID, HyperSpy, OIB): one plane."""
    from ..model import CHANNEL_NAMES, DEFAULT_TARGET_PX, Decoded, sha256_of, to_picture
    from . import read_planes
    from .plan import Request

    notes = []
    if page is not None and scene is None:
        scene = page
        notes.append(f"page {page} chooses scene {page} in this {kind.upper()} file.")
    picked = channel if channel not in CHANNEL_NAMES else "luminance"
    planes = read_planes(path, kind, Request(scene, time, z_slice, picked), limits=limits, target_px=target_px or DEFAULT_TARGET_PX)
    stack, chosen = planes.stack, planes.chosen
    facts = planes.facts()
    channels = stack.channel_list()
    named = any(not c.name.startswith("channel ") for c in channels)
    decoded = Decoded(stack.format, chosen.arrays[0], {"vendor": facts}, max(stack.scenes, 1), notes=notes + planes.notes,
                       channel_chosen=picked != "luminance" or stack.size("C") > 1 or stack.samples == 1)
    decoded.facts = {
        # a λ scan is one detector's channel at many wavelengths: not several channels to print apart
        "axes": facts["axes"], "channel_count": (stack.detectors if stack.bands else max(stack.size("C"), 1)) if stack.samples == 1 else stack.samples,
        "channel_names": [c.name for c in channels] if named else None, "wavelengths_nm": [c.wavelength_nm for c in channels],
        "z_step_m": stack.z_step_m, "reader": stack.reader,
    }
    if channel in CHANNEL_NAMES and stack.samples > 1:
        decoded.channel_chosen = False  # red/green/blue of a colour plane: grayscale picks it
    elif channel in CHANNEL_NAMES:
        raise ParameterError(f"{path}: channel {channel!r} names a colour, but this file's planes are grey; give a channel number or name.")
    return to_picture(decoded, "luminance" if decoded.channel_chosen else channel, name=path.name, sha=sha256_of(path), path=str(path))
