"""The one product entry point (issue 52.1): every front end (the CLI, batch, the web app, napari) asks
`convert()` for a print, whatever the product, and gets one result shape, `Made`.

The product follows from the settings: a relief of a picture (a multi-panel figure gives a print per
panel and an overview), a z-stack's 3-D model (`volume`), or its series of section plates
(`sections`). A format the product cannot write is refused here, before any work: a 3-D model took
a minute to build before failing on a format it has no writer for.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path

from ..errors import ParameterError
from ..formats import MESH_FORMATS, NAMES
from ..params import LithoParams
from .convert import Conversion


class Product(enum.Enum):
    RELIEF = "relief"  # a picture's plate, or a figure's plates and overview
    VOLUME = "volume"  # a z-stack as one 3-D model
    SECTIONS = "sections"  # a z-stack as a series of relief plates

    @property
    def formats(self) -> tuple[str, ...]:
        """The formats this product can write."""
        return MESH_FORMATS if self is Product.VOLUME else NAMES


def product_of(params: LithoParams) -> Product:
    if params.volume:
        return Product.VOLUME
    if params.sections:
        return Product.SECTIONS
    return Product.RELIEF


@dataclass(frozen=True)
class Made:
    """What any product gives a front end: its relief conversions (one for a picture or figure, one
    per plate of a section series, none for a 3-D model), the model (a VolumeConversion) when it is
    one, and what the product as a whole adds (a series' note)."""

    product: Product
    conversions: tuple[Conversion, ...] = ()
    model: object = None  # lithograph.volume.VolumeConversion for Product.VOLUME, else None
    notes: tuple[str, ...] = ()

    @property
    def all_written(self) -> tuple[Path, ...]:
        """Every file written, in the order it was written (each print's recipe after its files)."""
        if self.model is not None:
            return tuple(self.model.written)
        return tuple(p for conversion in self.conversions for p in conversion.all_written)

    @property
    def warnings(self) -> list:
        """Every warning once, in order: the model's, or each print's and then what a figure's
        layout left out."""
        if self.model is not None:
            return list(self.model.model.warnings)
        said = [w for c in self.conversions for each in c.prints for w in each.report.warnings]
        said += [n for c in self.conversions for n in c.layout_notes]
        return list(dict.fromkeys(said))

    def touch(self) -> list[str]:
        """What a finger will find on each relief print (nothing is judged for a 3-D model yet)."""
        return [line for conversion in self.conversions for line in conversion.touch()]


def check_formats(product: Product, formats) -> None:
    """Refuse, before any work, a format the product cannot write, naming those it can."""
    unfit = [f for f in formats if f not in product.formats]
    if unfit:
        raise ParameterError(f"`formats`: a {product.value} print is written as {', '.join(product.formats)}, not as "
                             f"{', '.join(unfit)}. Leave {', '.join(unfit)} out, or choose another product.",
                             parameter="formats", value=unfit)


def convert(source, params: LithoParams | None, out_dir, *, stem: str | None = None, printer_profile=None,
            formats=None, on_price=None) -> Made:
    """Make the product the settings ask for from `source` and write its files into `out_dir`.

    `source` is an image or stack file, an array or a Picture (a 3-D model and a section series need
    a file); `printer_profile` replaces the printer `params.printer` names; `formats` replaces
    `params.formats`; `on_price(price)` hears a 3-D model's price before its work begins.
    """
    params = params or LithoParams()
    product = product_of(params)
    check_formats(product, list(formats or params.formats))
    if product is Product.VOLUME:
        from .volume import convert_volume

        done = convert_volume(source, params, out_dir, stem=stem, printer_profile=printer_profile, formats=formats,
                              on_price=on_price)
        return Made(product, model=done)
    if product is Product.SECTIONS:
        from .sections import convert_sections, sections_note

        sections = convert_sections(source, params, out_dir, stem=stem, printer_profile=printer_profile)
        return Made(product, tuple(s.conversion for s in sections), notes=(sections_note(sections),))
    from .convert import convert as convert_relief

    return Made(product, (convert_relief(source, params, out_dir, stem=stem, printer_profile=printer_profile, formats=formats),))
