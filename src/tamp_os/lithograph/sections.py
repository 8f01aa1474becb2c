"""A z-stack as a section series (issue 36: `sections` K): K evenly spaced slices, each its
own relief plate, labelled in braille with its place in the series ("2 of 5, z = 12 µm").

Each plate is an ordinary print of one slice (`z_slice`), so every rule of a relief holds for it
(scale bar, cut corner, description, recipe); the slices are the middles of K equal parts of the
stack, so the series covers it evenly and never starts or ends on a half-empty edge slice. Each
plate is stretched on its own: the caption says where it lies, the relief what is in it.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError, ParameterError
from ..params import LithoParams


@dataclass(frozen=True)
class Section:
    number: int  # 1..K
    z_index: int  # the slice of the stack
    z_m: float | None  # its depth from the first slice, when the z step is known
    where: str  # "z = 12 µm", or "slice 3 of 11" when the z step is not known
    conversion: object  # the slice's Conversion (lithograph/convert.py)


def section_slices(planes: int, count: int) -> list[int]:
    """The K slices of a stack of `planes`: the middles of K equal parts (all of them when K ≥ planes)."""
    if count >= planes:
        return list(range(planes))
    return [min(planes - 1, int((k + 0.5) * planes / count)) for k in range(count)]


def _where(z_index: int, z_m: float | None, planes: int) -> str:
    from ..units import format_length

    return f"z = {format_length(z_m)}" if z_m is not None else f"slice {z_index + 1} of {planes}"


def convert_sections(source, params: LithoParams, out_dir, *, stem: str | None = None, printer_profile=None) -> list[Section]:
    """Write the section series of the z-stack `source` into `out_dir` as STEM.section-k.*."""
    from ..read.image import read_image
    from .convert import convert

    count = params.sections
    if not count:
        raise ParameterError("`sections`: give the number of slices to print (2 or more).", parameter="sections")
    path = Path(source)
    picture = read_image(path, **params.read_options(z_slice=None, channel="luminance"))
    planes = int(picture.file.axes.get("Z", 1))
    if planes < 2:
        raise InputError(f"{path}: the image has one plane, so there is no series of sections to print; leave `sections` "
                         f"out to print it as a relief.")
    step_m = params.z_step_m if params.z_step_m is not None else picture.file.z_step_m
    stem = stem or path.stem
    out = []
    for number, z in enumerate(section_slices(planes, count), 1):
        z_m = z * step_m if step_m else None
        where = _where(z, z_m, planes)
        label = f"{number} of {min(count, planes)}, {where}"
        caption = f"{params.caption}, {label}" if params.caption else label
        one = params.replace(sections=None, z_slice=z, caption=caption)
        done = convert(path, one, out_dir, stem=f"{stem}.section-{number}", printer_profile=printer_profile)
        out.append(Section(number, z, z_m, where, done))
    return out


def sections_note(sections: list[Section]) -> str:
    """One sentence for the whole series."""
    return (f"a series of {len(sections)} sections ({', '.join(s.where for s in sections)}), each its own plate labelled in "
            f"braille with its place; each plate is stretched on its own, so heights compare within a plate, not across plates.")
