"""The writer contributions: File > Save Selected Layers as .stl or .3mf makes the print of those
layers through the whole pipeline (the same convert() as every front end, default settings),
with its description and recipe beside it."""

from __future__ import annotations

from pathlib import Path

from .layers import LayerPicture, print_source


def write_stl(path: str, layer_data: list[tuple]) -> list[str]:
    return write_print(path, layer_data, fmt="stl")


def write_3mf(path: str, layer_data: list[tuple]) -> list[str]:
    return write_print(path, layer_data, fmt="3mf")


def write_print(path, layer_data: list[tuple], *, fmt: str) -> list[str]:
    """Print the layers (one picture, or one picture's channels) to `path`; the paths written."""
    from ..errors import TampError
    from ..lithograph.products import convert
    from .controls import params_for, widget_words

    target = Path(path)
    stem = target.name[: -len(target.suffix)] if target.suffix.lower() == f".{fmt}" else target.name
    pictures = [_picture(data, meta, kind) for data, meta, kind in layer_data]
    try:
        src = print_source(pictures, target.parent)
        params = params_for(printer="standard", preset="medium", caption="", relief_style="auto", formats=(fmt,),
                            pixel_size_m=src.pixel_size_m, channel=src.channel)
        done = convert(src.source, params, target.parent, stem=stem)
    except TampError as exc:  # napari shows a writer's error as its message: say it in plain words
        raise ValueError(widget_words(exc)) from None
    return [str(p) for p in done.all_written]


def _picture(data, meta: dict, kind: str) -> LayerPicture:
    """A layer as napari hands it to a writer: its data and its state (name, scale, units, metadata)."""
    import numpy as np

    data = np.asarray(data)
    units = tuple(str(u) for u in (meta.get("units") or ("pixel",) * data.ndim))
    mark = (meta.get("metadata") or {}).get("tamp_os")
    return LayerPicture(str(meta.get("name") or "layer"), kind, data, tuple(float(s) for s in meta.get("scale", (1.0,) * data.ndim)),
                        units, None, dict(mark) if isinstance(mark, dict) else None, bool(meta.get("rgb", False)))
