"""TEM and SEM formats that RosettaSciIO reads: FEI/Thermo Fisher TIA (.emi/.ser), Velox and
Berkeley EMD, JEOL Analysis Station (.img/.map), Phenom ELID and HyperSpy .hspy.

Why RosettaSciIO: it is the field's reference reader for these formats (HyperSpy's I/O), already
installed for DM3/DM4 (the `dm` extra), and opens all of them lazily except Phenom ELID (a small
bzip2 project file whose decompressed size is counted before it is decoded). Only images are used:
items whose two axes are x and y; spectra, line scans and maps with an energy axis are skipped.
A further axis (frames of a series) is offered as time points.
"""

from __future__ import annotations

import bz2
import logging

import numpy as np

from ..errors import Text
from ..units import unit_factor_m
from .model import Channel, Stack

log = logging.getLogger(__name__)


def _reader(kind: str):
    import rsciio  # noqa: F401  (configures its logger first)

    logging.getLogger("rsciio").setLevel(logging.ERROR)  # its "numba is not installed" notice is not the user's concern
    if kind == "tia":
        from rsciio.tia import file_reader
    elif kind == "emd":
        from rsciio.emd import file_reader
    elif kind == "jeol":
        from rsciio.jeol import file_reader
    elif kind == "elid":
        from rsciio.phenom import file_reader
    else:
        from rsciio.hspy import file_reader
    return file_reader


def elid_decoded_bytes(path, cap_bytes: float) -> int:
    """Bytes the ELID's bzip2 stream holds once decompressed, counted in small pieces, stopping past `cap_bytes`."""
    total, decomp = 0, bz2.BZ2Decompressor()
    with open(path, "rb") as fh:
        while not decomp.eof and total <= cap_bytes:
            chunk = fh.read(1 << 16)
            if not chunk:
                raise EOFError("the compressed stream ends early")
            total += len(decomp.decompress(chunk))
    return total


def _image_axes(item) -> tuple[int, int] | None:
    """Indices of the (y, x) axes of an image item, or None for spectra, line scans and maps."""
    axes = item.get("axes", [])
    names = [str(a.get("name", "")).lower() for a in axes]
    others = [a for i, a in enumerate(axes) if names[i] not in ("x", "y")]
    if any("ev" in str(a.get("units", "")).lower() or "energy" in str(a.get("name", "")).lower() for a in others):
        return None  # a spectrum image (EDS/EELS map), not a picture
    if "x" in names and "y" in names:
        return names.index("y"), names.index("x")
    return None


def open_rsciio(path, kind: str, scene: int | None, limits) -> Stack:
    from .plan import check_index

    if kind == "elid":
        from ..read import _check_bytes

        size = elid_decoded_bytes(path, limits.max_decoded_gb * 1e9)
        _check_bytes(path, (size,), np.uint8, limits, "Phenom ELID project (decompressed)")
        items = _reader(kind)(str(path))
    else:
        items = _reader(kind)(str(path), lazy=True)
    images = [(item, ax) for item in items for ax in [_image_axes(item)] if ax is not None and len(item["axes"]) <= 3]
    if not images:
        raise LookupError("no image in it (only spectra or maps)")
    s = check_index(path, "scene", scene, len(images), "image")
    item, (yi, xi) = images[s]
    data = item["data"]
    rgba = data.dtype.names is not None
    frames = [i for i in range(len(item["axes"])) if i not in (yi, xi)]
    ax_x, ax_y = item["axes"][xi], item["axes"][yi]
    fx, fy = unit_factor_m(str(ax_x.get("units", ""))), unit_factor_m(str(ax_y.get("units", "")))
    px = float(ax_x.get("scale", 0)) * fx if fx else None
    py = float(ax_y.get("scale", 0)) * fy if fy else None
    title = str((item.get("metadata", {}).get("General", {}) or {}).get("title") or f"image {s}")
    titles = [str((it.get("metadata", {}).get("General", {}) or {}).get("title") or f"image {i}") for i, (it, _) in enumerate(images)]
    nt = int(data.shape[frames[0]]) if frames else 1
    dtype = np.dtype(np.uint8) if rgba else np.dtype(data.dtype)

    def plane(t: int, c: int, z: int) -> np.ndarray:
        index = [slice(None)] * data.ndim
        if frames:
            index[frames[0]] = t
        out = np.asarray(data[tuple(index)])
        if yi > xi:
            out = out.T
        if rgba:
            out = np.stack([out[name] for name in data.dtype.names], axis=-1)
        return out

    notes = []
    if len(images) > 1:
        notes.append(Text(f"{len(images)} images in the file ({'; '.join(f'{i}: {t}' for i, t in enumerate(titles))}); read {s} ({title}). Choose another with `scene`."))
    return Stack(
        format=FORMAT_NAMES[kind], reader=f"rosettasciio {_version()}", sizes={"T": nt}, dtype=dtype,
        height=int(data.shape[yi]), width=int(data.shape[xi]), plane=plane, scenes=len(images), scene=s,
        scene_name=title, channels=[Channel(title)], pixel_size_m=(px, py or px) if px and px > 0 else None,
        pixel_size_key=f"axes['{ax_x.get('name')}'].scale ({ax_x.get('units')})" if px else "",
        samples=len(data.dtype.names) if rgba else 1, metadata={"rsciio_title": title}, notes=notes,
    )


FORMAT_NAMES = {"tia": "FEI TIA (.emi/.ser)", "emd": "EMD (Velox/Berkeley)", "jeol": "JEOL Analysis Station",
                "elid": "Phenom ELID", "hspy": "HyperSpy .hspy"}


def _version() -> str:
    from importlib.metadata import version

    return version("rosettasciio")
