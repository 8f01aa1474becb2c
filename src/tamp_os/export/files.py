"""Every output file is written here: to a temporary name beside the target, then renamed into
place, so a crash never leaves half a file that looks whole."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import BinaryIO, Callable

import numpy as np

from ..errors import ExportError


NAME_MAX_BYTES = 255  # one file or folder name (Linux, macOS, Windows NTFS)
PATH_MAX_BYTES = 4096  # a whole path (Linux)
PART_EXTRA_BYTES = 15  # a temporary name is '.' + name + '.' + 8 random characters + '.part'


def short_path(path) -> str:
    """A path short enough to quote in a message: its start and its end."""
    text = str(path)
    return text if len(text) <= 120 else f"{text[:60]}…{text[-40:]} ({len(os.fsencode(text)):,} bytes)"


def check_path_length(path, extra_bytes: int = 0) -> None:
    """Refuse, before anything is written, a path the operating system cannot hold: a name over
    NAME_MAX_BYTES (with `extra_bytes` for names made from it) or a whole path over PATH_MAX_BYTES."""
    path = Path(path)
    whole = len(os.fsencode(os.path.abspath(path))) + extra_bytes
    longest = max((len(os.fsencode(part)) for part in path.parts), default=0)
    if longest + extra_bytes > NAME_MAX_BYTES or whole > PATH_MAX_BYTES:
        raise ExportError(
            f"{short_path(path)}: this output name is too long for the file system (a name may have at most "
            f"{NAME_MAX_BYTES - extra_bytes} bytes here, a whole path {PATH_MAX_BYTES}); choose a shorter output name or folder with -o."
        )


def write_atomic(path: Path, write: Callable[[BinaryIO], None]) -> Path:
    """Write through `write(file)` to a temporary file beside `path`, then rename it into place."""
    path = Path(path)
    check_path_length(path, PART_EXTRA_BYTES)
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
    """Write UTF-8 text atomically.

    A file name that is not valid UTF-8 reaches Python as lone surrogates ('\udcff'); they are
    written as that escape, which JSON reads back as the same name (so a recipe still finds its
    input) and a reader sees as a visible code instead of a crash.
    """
    return write_atomic(Path(path), lambda fh: fh.write(text.encode("utf-8", "backslashreplace")))


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
