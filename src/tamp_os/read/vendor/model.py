"""What every vendor reader hands back: a lazily opened stack and its facts, in plain types.

A reader opens the file, chooses the scene (series, image, position), and returns a `Stack`
whose `plane(t, c, z)` decodes one 2-D plane on demand. Nothing is decoded before the caller
has priced the planes it will read against the decoded-size guard (`plan.py`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass(frozen=True)
class Channel:
    """One channel: its name and, where the file records them, its wavelengths in nm."""

    name: str
    excitation_nm: float | None = None
    emission_nm: float | None = None

    @property
    def wavelength_nm(self) -> float | None:
        """The wavelength that names the channel: emission where known, else excitation."""
        return self.emission_nm if self.emission_nm is not None else self.excitation_nm

    def describe(self) -> str:
        parts = [f"ex {self.excitation_nm:g} nm" for _ in [0] if self.excitation_nm is not None]
        parts += [f"em {self.emission_nm:g} nm" for _ in [0] if self.emission_nm is not None]
        return self.name + (f" ({', '.join(parts)})" if parts else "")


@dataclass
class Stack:
    """One scene of a vendor file, opened lazily.

    format : what the file is, in words ("Zeiss CZI").
    reader : the library that read it, with its version ("czifile 2019.7.2.3").
    sizes : the axes present and their lengths: any of T, C, Z (besides Y and X); 1 when absent.
    scenes : how many scenes (series, images, positions) the file holds; `scene` the one opened.
    plane : (t, c, z) -> a 2-D (Y, X) or (Y, X, S) array, decoded on demand.
    pixel_size_m : (x, y) in metres, or None when the file does not record it.
    pixel_size_key : where in the file the pixel size was read (provenance).
    z_step_m, z_key : the z step and where it was read, when the file has a Z axis.
    samples : colour samples per pixel (3 for RGB), 1 for grey.
    scene_names : the scenes' names where the file gives them (a LIF's series), in order.
    bands : wavelength axes folded into C ({'λ': 32} for a λ scan): the channels then run over
        detector × wavelength, and `band_key` says where the wavelengths were read.
    """

    format: str
    reader: str
    sizes: dict[str, int]
    dtype: np.dtype
    height: int
    width: int
    plane: Callable[[int, int, int], np.ndarray]
    scenes: int = 1
    scene: int = 0
    scene_name: str = ""
    channels: list[Channel] = field(default_factory=list)
    pixel_size_m: tuple[float, float] | None = None
    pixel_size_key: str = ""
    z_step_m: float | None = None
    z_key: str = ""
    time_step_s: float | None = None
    samples: int = 1
    metadata: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    close: Callable[[], None] = lambda: None
    scene_names: list[str] = field(default_factory=list)
    bands: dict[str, int] = field(default_factory=dict)
    band_key: str = ""

    def size(self, axis: str) -> int:
        return int(self.sizes.get(axis, 1))

    @property
    def detectors(self) -> int:
        """Channels of the file's own C axis (a λ scan of one detector: 1, whatever its wavelengths)."""
        per = 1
        for n in self.bands.values():
            per *= int(n)
        return max(self.size("C") // per, 1)

    def channel_list(self) -> list[Channel]:
        """A Channel for every index of C, named by its number where the file gives no name."""
        n = self.size("C")
        named = list(self.channels)[:n]
        return named + [Channel(f"channel {i}") for i in range(len(named), n)]
