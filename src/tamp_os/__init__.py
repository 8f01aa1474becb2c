"""TAMP-OS: turn (microscopy) images into 3D-printable tactile lithographs at a known scale."""

from .version import __version__  # noqa: E402
from .errors import ExportError, InputError, MissingDependencyError, ParameterError, TampError  # noqa: E402
from .params import LithoParams  # noqa: E402
from .printing.printers import BUILTIN_PRINTERS, PrinterProfile, get_printer  # noqa: E402


def make_lithograph(source, params=None, **changes):
    """Make a lithograph from an image path or array; see tamp_os.lithograph.pipeline.make_lithograph."""
    from .lithograph.pipeline import make_lithograph as _make

    return _make(source, params, **changes)


__all__ = [
    "make_lithograph",
    "LithoParams",
    "PrinterProfile",
    "BUILTIN_PRINTERS",
    "get_printer",
    "TampError",
    "InputError",
    "ParameterError",
    "MissingDependencyError",
    "ExportError",
    "__version__",
]
