"""Clear words for vendor files that are recognised by their signature but cannot be read."""

from __future__ import annotations

from ...errors import InputError

# kind -> (what it is, what to do instead)
KINDS = {
    "czi": ("a Zeiss CZI file", "open it in ZEN (or Fiji with Bio-Formats) and export it again, or export OME-TIFF"),
    "lif": ("a Leica LIF file", "open it in LAS X (or Fiji with Bio-Formats) and export it again, or export OME-TIFF"),
    "nd2": ("a Nikon ND2 file", "open it in NIS-Elements (or Fiji with Bio-Formats) and export it again, or export OME-TIFF"),
    "omezarr": ("an OME-Zarr folder", "write it again (for example with ome-zarr-py or Fiji's OME-Zarr export), or export OME-TIFF"),
    "tia": ("a FEI/Thermo Fisher TIA file (.emi/.ser)", "keep the .emi and its .ser files together with the same name, or export TIFF from TIA or Velox"),
    "emd": ("an EMD file (Velox or Berkeley)", "export it again from Velox, or export TIFF"),
    "hspy": ("a HyperSpy .hspy file", "save it again from HyperSpy, or export TIFF"),
    "hdf5": ("an HDF5 file (an EMD or HyperSpy file by its signature)", "export it again from Velox or HyperSpy, or export TIFF"),
    "mrc": ("an MRC/CCP4 map", "write it again (for example with mrcfile, IMOD or ChimeraX), or export TIFF"),
    "jeol": ("a JEOL Analysis Station file (.img/.map)", "export it again from Analysis Station, or export TIFF"),
    "elid": ("a Phenom ELID project (.elid)", "export the image as TIFF from Phenom ProSuite / Element"),
    "oif": ("an Olympus OIB/OIF file", "open it in FluoView (or Fiji with Bio-Formats) and export OME-TIFF"),
}


def damaged(path, kind: str, exc: BaseException | None = None) -> InputError:
    """'x.czi: a Zeiss CZI file whose image data is damaged or truncated (...); open it in ZEN ...'."""
    what, todo = KINDS[kind]
    detail = f" ({_short(exc)})" if exc is not None and _short(exc) else ""
    return InputError(f"{path}: {what} whose image data is damaged or truncated{detail}; {todo}.")


def unsupported(path, kind: str, why: str) -> InputError:
    what, todo = KINDS[kind]
    return InputError(f"{path}: {what} of a kind this reader cannot use ({why}); {todo}.")


def missing(path, kind: str, package: str):
    from ...errors import MissingDependencyError, install_hint

    what, _ = KINDS[kind]
    return MissingDependencyError(
        f"{path}: is {what}; reading it needs the Python package {package}, which comes with the 'vendor' extra: "
        f"{install_hint('vendor')}."
    )


def _short(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:160] + ("…" if len(text) > 160 else "")
