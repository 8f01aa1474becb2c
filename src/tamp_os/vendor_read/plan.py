"""Which planes of a Stack are read, priced against the decoded-size guard before any is decoded.

Defaults, each said in a note when the file has more: the first time point, the first channel
(all channels for `read_channels`), and a maximum-intensity projection over Z computed one plane
at a time (so a large stack never sits in memory whole), or one slice with `z_slice`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError, Text
from .model import Channel, Stack


@dataclass(frozen=True)
class Request:
    """What to read from a file: scene, time point, z slice (None: projection) and channel."""

    scene: int | None = None
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


def check_index(path, name: str, value: int | None, count: int, what: str) -> int:
    if value is None:
        return 0
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
    if channel == "luminance":
        return None
    if channel.isdigit():
        index = int(channel)
    else:
        folded = [name.casefold() for name in names]
        if channel.casefold() not in folded:
            raise ParameterError(
                f"{path}: channel {channel!r} is not one of 0–{n - 1} or {', '.join(repr(x) for x in names)}."
            )
        index = folded.index(channel.casefold())
    if not 0 <= index < n:
        raise ParameterError(f"{path}: `channel` must be 0–{n - 1} ({', '.join(names)}); got {index}.")
    return index


def choose(path, stack: Stack, request: Request, limits, *, all_channels: bool = False) -> Chosen:
    """Read the planes `request` asks for, after pricing them with the decoded-size guard."""
    from ..read import _check_bytes, _check_size

    notes: list[str] = []
    nt, nc, nz = stack.size("T"), stack.size("C"), stack.size("Z")
    t = check_index(path, "time", request.time, nt, "time point")
    if nt > 1 and request.time is None:
        step = f", {stack.time_step_s:g} s apart" if stack.time_step_s else ""
        notes.append(Text(f"time series of {nt} time points{step}: using the first (choose another with `time`)."))
    if all_channels:
        channels = list(range(nc))
    else:
        index = channel_index(path, stack, request.channel)
        if index is None and nc > 1:
            names = ", ".join(c.describe() for c in stack.channel_list())
            notes.append(Text(f"{nc} channels ({names}); using channel 0. Choose another with `channel` (a number or a name)."))
        channels = [index or 0]
    if nz > 1 and request.z_slice is None:
        zs, z_words = list(range(nz)), f"projection of {nz}"
        notes.append(Text(f"z-stack of {nz} slices: maximum-intensity projection (choose one slice with `z_slice`)."))
    else:
        z = check_index(path, "z_slice", request.z_slice, nz, "slice")
        zs, z_words = [z], (f"slice {z}" if nz > 1 else "")
    _check_size(path, (stack.height, stack.width), limits)
    shape = (len(zs) * len(channels), stack.height, stack.width) + ((stack.samples,) if stack.samples > 1 else ())
    _check_bytes(path, shape, stack.dtype, limits, f"{stack.format} plane{'s' if shape[0] > 1 else ''}")
    arrays = [_project(stack, t, c, zs) for c in channels]
    return Chosen(arrays, channels, t, z_words, notes)


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
