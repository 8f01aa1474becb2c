"""Readers for microscope vendors' own formats, dispatched from read.py by the file's signature.

Zeiss CZI, Leica LIF, Nikon ND2, OME-Zarr folders, FEI TIA, Velox/Berkeley EMD, HyperSpy,
MRC/CCP4, JEOL Analysis Station, Phenom ELID and Olympus OIB/OIF. Each reader opens its file
lazily (`Stack`); `plan.choose` prices the planes against the decoded-size guard, then decodes
only them. Libraries are imported inside the functions that need them.

`read_channels` is the typed entry point for multi-channel use: every channel of one plane, with
its name and wavelength.
"""

from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import InputError, MissingDependencyError, ParameterError, Text
from .errors import damaged, missing
from .model import Channel, Stack
from .plan import Chosen, Request, choose

log = logging.getLogger(__name__)

PACKAGES = {"czi": "czifile", "lif": "liffile", "nd2": "nd2", "omezarr": "zarr", "mrc": "mrcfile", "oif": "oiffile",
            "tia": "rosettasciio", "emd": "rosettasciio h5py", "hspy": "rosettasciio h5py", "hdf5": "h5py",
            "jeol": "rosettasciio", "elid": "rosettasciio"}
DEFAULT_TARGET_PX = 2048  # pyramid level: the smallest at least this wide (a print needs ≤ 1024 grid points)


def detect(path: Path) -> str | None:
    """The vendor kind of `path` (a file or an OME-Zarr folder), or None when read.py reads it."""
    from .signatures import HEAD_BYTES, hdf5_kind, kind_of_folder, kind_of_head

    if path.is_dir():
        return kind_of_folder(path)
    with path.open("rb") as fh:
        head = fh.read(HEAD_BYTES)
    kind = kind_of_head(head, path)
    return hdf5_kind(path) if kind == "hdf5" else kind


def open_stack(path: Path, kind: str, scene: int | None, *, limits, target_px: int = DEFAULT_TARGET_PX) -> Stack:
    from .xmlbound import check_metadata_xml

    check_metadata_xml(path, kind)  # before a reader parses it whole (and liffile walks it recursively)
    if kind == "czi":
        from .czi import open_czi

        return open_czi(path, scene, limits)
    if kind == "lif":
        from .lif import open_lif

        return open_lif(path, scene)
    if kind == "nd2":
        from .nd2 import open_nd2

        return open_nd2(path, scene)
    if kind == "omezarr":
        from .omezarr import open_omezarr

        return open_omezarr(path, scene, target_px, limits=limits)
    if kind == "mrc":
        from .mrc import open_mrc

        return open_mrc(path, scene, limits)
    if kind == "oif":
        from .oif import open_oif

        return open_oif(path, scene, limits)
    if kind == "hdf5":
        raise ValueError("the HDF5 superblock cannot be read")
    from .rsci import open_rsciio

    return open_rsciio(path, kind, scene, limits=limits)


@dataclass
class VendorPlanes:
    """What a vendor reader read: the planes, the stack's facts and the notes to tell the user."""

    stack: Stack
    chosen: Chosen
    notes: list[str] = field(default_factory=list)

    def facts(self) -> dict:
        """The metadata block read.py stores as metadata['vendor'] (plain types, for JSON and scale.py)."""
        s, c = self.stack, self.chosen
        channels = s.channel_list()
        return {
            "format": s.format, "reader": s.reader,
            "pixel_size_m": list(s.pixel_size_m) if s.pixel_size_m else None, "pixel_size_key": s.pixel_size_key,
            "z_step_m": s.z_step_m, "z_key": s.z_key, "time_step_s": s.time_step_s,
            "axes": _axes(s), "scene": s.scene, "scene_name": s.scene_name, "time": c.time, "z": c.z,
            "channels": [{"name": ch.name, "excitation_nm": ch.excitation_nm, "emission_nm": ch.emission_nm} for ch in channels],
            "channels_used": c.channels, **{k: v for k, v in s.metadata.items() if v not in ("", None)},
            **({"scene_names": list(s.scene_names)} if s.scene_names else {}),
            **({"wavelength_axes": dict(s.bands), "wavelength_key": s.band_key} if s.bands else {}),
        }


def _axes(s: Stack) -> dict[str, int]:
    """Scenes, T, C, Z and any wavelength axis (λ, Λ) with more than one step; C counts detectors."""
    axes = {"scenes": s.scenes} if s.scenes > 1 else {}
    axes.update({a: s.size(a) for a in "TCZ" if s.size(a) > 1})
    if s.bands:
        axes.pop("C", None)
        axes.update({"C": s.detectors} if s.detectors > 1 else {})
        axes.update({a: n for a, n in s.bands.items() if n > 1})
    return axes


def read_planes(path: Path, kind: str, request: Request, *, limits, all_channels: bool = False, pick=None,
                target_px: int = DEFAULT_TARGET_PX) -> VendorPlanes:
    """Open, price and read the planes `request` asks for (with `all_channels`, every channel's, or
    those `pick` picks: plan.choose); every failure is one clear InputError."""
    stack = None
    try:
        with warnings.catch_warnings(record=True) as caught:  # library warnings become log lines, not failures
            warnings.simplefilter("always")
            stack = open_stack(path, kind, request.scene, limits=limits, target_px=target_px)
            chosen = choose(path, stack, request, limits=limits, all_channels=all_channels, pick=pick)
        for w in caught:
            log.debug("%s: %s", path, w.message)
    except (InputError, ParameterError, MissingDependencyError):
        raise
    except ImportError as exc:
        raise missing(path, kind, PACKAGES.get(kind, str(exc.name))) from None
    except MemoryError:
        raise InputError(f"{path}: not enough memory to read this {kind.upper()} file; lower `max_decoded_gb` or choose one scene.") from None
    except NotImplementedError as exc:
        from .errors import unsupported

        raise unsupported(path, kind, str(exc) or "a layout it does not read") from None
    except LookupError as exc:
        from .errors import unsupported

        raise unsupported(path, kind, str(exc)) from None
    except Exception as exc:
        log.debug("reading %s failed", path, exc_info=True)
        raise damaged(path, kind, exc) from None
    finally:
        if stack is not None:
            try:
                stack.close()
            except Exception:  # closing a damaged file must not hide the first error
                pass
    notes = list(stack.notes) + list(chosen.notes)
    if stack.pixel_size_m and abs(stack.pixel_size_m[1] / stack.pixel_size_m[0] - 1) > 0.01:
        from ...units import format_length

        x, y = stack.pixel_size_m
        notes.append(Text(f"pixels are not square ({format_length(x)} across × {format_length(y)} down); the print shows them "
                          f"square, so it is {y / x:.3g}× as deep, relative to its width, as the sample (give `depth_mm` to correct it)."))
    notes += _blank_notes(stack, chosen)
    return VendorPlanes(stack, chosen, notes)


def _blank_notes(stack: Stack, chosen: Chosen) -> list[str]:
    notes = []
    for array, c in zip(chosen.arrays, chosen.channels):
        finite = array[np.isfinite(array)] if array.dtype.kind == "f" else array
        if finite.size and finite.min() == finite.max():
            where = f" ({stack.scene_name})" if stack.scene_name else ""
            others = f"; the file holds {stack.scenes} images: choose another with `scene`" if stack.scenes > 1 else ""
            notes.append(Text(f"the image{where} is blank: every pixel is {finite.flat[0]:g}, so there is nothing to feel{others}."))
    return notes


__all__ = ["Channel", "Request", "Stack", "detect", "read_planes"]
