"""Every output file is written here: to a temporary name beside the target, then renamed into
place, so a crash never leaves half a file that looks whole."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import BinaryIO, Callable

import numpy as np

from .errors import ExportError


def write_atomic(path: Path, write: Callable[[BinaryIO], None]) -> Path:
    """Write through `write(file)` to a temporary file beside `path`, then rename it into place."""
    path = Path(path)
    if path.is_dir():
        raise ExportError(f"{path}: is a folder; give a file name for the output (for example {path / 'print.stl'}).")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise ExportError(f"{folder}: the output folder does not exist; create it or choose another with -o.")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=folder)
    except OSError as exc:
        raise ExportError(f"{folder}: cannot write here ({exc.strerror}); choose another output folder with -o.") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise ExportError(f"{path}: writing failed ({exc.strerror or exc}); nothing was written.") from None
        raise
    return path


def write_text(path, text: str) -> Path:
    """Write UTF-8 text atomically."""
    return write_atomic(Path(path), lambda fh: fh.write(text.encode("utf-8")))


def write_png(path, image) -> Path:
    """Write a PIL image, or a uint8 array, as PNG atomically."""
    from PIL import Image

    picture = image if isinstance(image, Image.Image) else Image.fromarray(image)
    return write_atomic(Path(path), lambda fh: picture.save(fh, format="PNG"))


def to_uint8(values: np.ndarray, lo: float | None = None, hi: float | None = None) -> np.ndarray:
    """`values` mapped from lo..hi (default: their own range) to 0..255 as uint8, for a PNG."""
    values = np.asarray(values, dtype=np.float64)
    lo = float(values.min()) if lo is None else lo
    hi = float(values.max()) if hi is None else hi
    return ((values - lo) / ((hi - lo) or 1) * 255).astype(np.uint8)
