"""Which planes of a Stack are read, priced against the decoded-size guard before any is decoded.

Defaults, each said in a note when the file has more: the first time point, the first channel
(all channels for `read_channels`), and a maximum-intensity projection over Z computed one plane
at a time (so a large stack never sits in memory whole), or one slice with `z_slice`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...errors import Decision, ParameterError, Text
from .model import Channel, Stack


@dataclass(frozen=True)
class Request:
    """What to read from a file: scene (a number, or a name), time point, z slice (None: projection) and channel
    (a number, a name, or for a wavelength sweep 'peak')."""

    scene: int | str | None = None
    time: int | None = None
    z_slice: int | None = None
    channel: str = "luminance"


@dataclass
class Chosen:
    """The planes read: one 2-D array per channel index in `channels`, and what was chosen."""

    arrays: list[np.ndarray]
    channels: list[int]
    time: int
    z: str  # "projection of N", "slice K", or "" without Z
    notes: list[str] = field(default_factory=list)


def check_index(path, name: str, value: int | str | None, *, count: int, what: str, names: list[str] | None = None) -> int:
    """`value` as an index 0…count−1: a number, or (a scene) one of `names` in any case; else one clear error."""
    if value is None:
        return 0
    if isinstance(value, str):
        text = value.strip()
        if text.lstrip("-").isdigit():
            value = int(text)
        else:
            folded = [n.casefold() for n in names or []]
            if text.casefold() in folded:
                return folded.index(text.casefold())
            if names:
                listed = ", ".join(f"{i} {n!r}" for i, n in enumerate(names))
                raise ParameterError(f"{path}: `{name}` {text!r} names no {what} of this file; its {what}s are {listed} "
                                     f"(give a name or a number).", parameter=name, value=value, allowed=listed)
            if count == 1:
                raise ParameterError(f"{path}: {name} {text!r} asked for, but the file has a single {what}; leave {name} out.",
                                     parameter=name, value=value)
            raise ParameterError(f"{path}: `{name}` {text!r} is a name, but this file's {what}s have none; give a number "
                                 f"0–{count - 1}.", parameter=name, value=value, allowed=f"0–{count - 1}")
    if not 0 <= value < count:
        if count == 1:
            raise ParameterError(f"{path}: {name} {value} asked for, but the file has a single {what}; leave {name} out.")
        raise ParameterError(f"{path}: `{name}` must be 0–{count - 1} ({what}s in this file); got {value}.", parameter=name, value=value,
                             allowed=f"0–{count - 1}")
    return value


def channel_index(path, stack: Stack, channel: str) -> int | None:
    """The channel index `channel` names (a number or a name, any case); None for luminance."""
    n = stack.size("C")
    names = [c.name for c in stack.channel_list()]
    if channel == "luminance" or (stack.bands and channel.strip().casefold() in PEAK_WORDS):
        return None
    if channel.isdigit():
        index = int(channel)
    else:
        key = _folded(channel)
        found = [i for i, name in enumerate(names) if key == _folded(name)]
        if not found and stack.bands:  # '520 nm' for 'λ 520 nm'
            found = [i for i, name in enumerate(names) if key == _folded(name).replace("λ", "")]
        if len(found) != 1:
            peak = " or 'peak' (the emission peak)" if stack.bands else ""
            raise ParameterError(
                f"{path}: channel {channel!r} is not one of 0–{n - 1} or {', '.join(repr(x) for x in names)}{peak}."
            )
        index = found[0]
    if not 0 <= index < n:
        raise ParameterError(f"{path}: `channel` must be 0–{n - 1} ({', '.join(names)}); got {index}.")
    return index


PEAK_WORDS = ("peak", "emission peak", "luminance")


def _folded(name: str) -> str:
    """A channel name as matched: any case, without spaces; 'lambda' for 'λ' ('lambda520nm' = 'λ 520 nm').
    (Casefolding makes the excitation 'Λ' an 'λ' too: one image's names list each axis in one order, so
    they stay apart.)"""
    return "".join(name.casefold().replace("lambda", "λ").split())


def choose(path, stack: Stack, request: Request, *, limits, all_channels: bool = False, pick=None) -> Chosen:
    """Read the planes `request` asks for, after pricing them with the decoded-size guard.

    all_channels : every channel's plane, or with `pick` (a function of the stack's channel list
    that returns channel indices) the channels it picks: only those are priced and read."""
    from ..model import check_bytes, check_size

    notes: list[str] = []
    nt, nc, nz = stack.size("T"), stack.size("C"), stack.size("Z")
    t = check_index(path, "time", request.time, count=nt, what="time point")
    if nt > 1 and request.time is None:
        step = f", {stack.time_step_s:g} s apart" if stack.time_step_s else ""
        notes.append(Decision(f"time series of {nt} time points{step}: using the first⟦ (choose another with `time`)⟧."))
    peak = False
    if all_channels:
        channels = list(range(nc)) if pick is None else sorted({int(i) for i in pick(stack.channel_list()) if 0 <= int(i) < nc})
    else:
        index = channel_index(path, stack, request.channel)
        # A wavelength sweep prints its emission peak by default: a finger reads one picture, not a
        # spectrum. Each λ plane of a sample shows the same structures at another brightness, so the
        # channel path's textures would repeat one structure; the plane where the sample emits most has
        # the most signal over the same noise, so its structures stand out best. A maximum over all the
        # planes would lift the background instead (the maximum of N noisy values) and flatten contrast.
        peak = index is None and bool(stack.bands)
        if index is None and nc > 1 and not peak:
            names = ", ".join(c.describe() for c in stack.channel_list())
            notes.append(Text(f"{nc} channels ({names}); using channel 0. Choose another with `channel` (a number or a name)."))
        channels = [index or 0]
    if nz > 1 and request.z_slice is None:
        zs, z_words = list(range(nz)), f"projection of {nz}"
        notes.append(Decision(f"z-stack of {nz} slices: maximum-intensity projection⟦ (choose one slice with `z_slice`)⟧."))
    else:
        z = check_index(path, "z_slice", request.z_slice, count=nz, what="slice")
        zs, z_words = [z], (f"slice {z}" if nz > 1 else "")
    check_size(path, (stack.height, stack.width), limits)
    read = len(zs) * (nc if peak else len(channels))  # the peak is found by reading every wavelength's plane
    shape = (read, stack.height, stack.width) + ((stack.samples,) if stack.samples > 1 else ())
    check_bytes(path, shape, stack.dtype, limits=limits, what=f"{stack.format} plane{'s' if shape[0] > 1 else ''}")
    if peak:
        array, c = _emission_peak(stack, t, zs)
        names = stack.channel_list()
        notes.append(Text(f"{nc} wavelengths ({names[0].name} … {names[-1].name}): using the emission peak, {names[c].name} "
                          f"(the brightest plane); choose another with `channel`: a number 0–{nc - 1} or a name such as "
                          f"'{names[c].name}'."))
        return Chosen([array], [c], t, z_words, notes)
    arrays = [_project(stack, t, c, zs) for c in channels]
    return Chosen(arrays, channels, t, z_words, notes)


def _emission_peak(stack: Stack, t: int, zs: list[int]) -> tuple[np.ndarray, int]:
    """The channel (wavelength) whose plane is brightest on average, and that plane: two planes in memory at most."""
    best, best_c, best_mean = None, 0, -np.inf
    for c in range(stack.size("C")):
        plane = _project(stack, t, c, zs)
        mean = float(np.nanmean(plane, dtype=np.float64)) if plane.size else 0.0
        if mean > best_mean:
            best, best_c, best_mean = plane, c, mean
    return best, best_c


def _project(stack: Stack, t: int, c: int, zs: list[int]) -> np.ndarray:
    """One plane, or the running maximum over `zs`: two planes in memory at most.

    Always a copy: a reader may hand back a view of its memory-mapped file, which closes after reading.
    """
    out = np.array(stack.plane(t, c, zs[0]), copy=True)
    if len(zs) > 1:
        for z in zs[1:]:
            np.maximum(out, np.asarray(stack.plane(t, c, z)), out=out)
    return out


def channel_of(stack: Stack, index: int) -> Channel:
    return stack.channel_list()[index]
