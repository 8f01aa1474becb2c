"""Every output file is written here: to a temporary name beside the target, then renamed into
place, so a crash never leaves half a file that looks whole."""

from __future__ import annotations

import hashlib
import os
import stat
import tempfile
import threading
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


class _Hashing:
    """A file that also feeds everything written to it into a SHA-256 (hashlib releases the GIL
    for blocks, so each writer thread hashes its own file beside the others)."""

    def __init__(self, fh: BinaryIO):
        self.fh, self.digest = fh, hashlib.sha256()

    def write(self, data) -> int:
        self.digest.update(data)
        return self.fh.write(data)


# The SHA-256 of files this process wrote with remember_sha256, by absolute path, with the
# file's identity then (device, inode, size, modification and change times): a file replaced
# or written since no longer matches and is read again (see written_sha256).
_WRITTEN: dict[str, tuple[tuple, str]] = {}
_WRITTEN_LOCK = threading.Lock()  # the formats of a print are written side by side
WRITTEN_REMEMBERED = 256


def _identity(path: Path) -> tuple | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns) if stat.S_ISREG(st.st_mode) else None


def written_sha256(path) -> str | None:
    """The SHA-256 (hex) of `path` as this process wrote it (write_atomic's remember_sha256), or
    None when it did not, or the file has been replaced or changed since."""
    key = os.path.abspath(path)
    with _WRITTEN_LOCK:
        known = _WRITTEN.get(key)
    if known is None or _identity(Path(key)) != known[0]:
        return None
    return known[1]


def write_atomic(path: Path, write: Callable[[BinaryIO], None], *, remember_sha256: bool = False,
                 before_replace: Callable[[], None] | None = None) -> Path:
    """Write through `write(file)` to a temporary file beside `path`, then rename it into place.
    `remember_sha256`: hash the bytes as they are written, for written_sha256 (the file object
    then offers only write()). `before_replace`: called once the temporary file is complete and
    before it takes the name; if it raises, the temporary file goes and nothing is written."""
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
            hashing = _Hashing(fh) if remember_sha256 else None
            write(hashing or fh)
        if before_replace is not None:
            before_replace()
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
        if hashing is not None:
            _remember(path, hashing.digest.hexdigest())
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise ExportError(f"{path}: writing failed ({exc.strerror or exc}); nothing was written.") from None
        raise
    return path


def _remember(path: Path, digest: str) -> None:
    identity = _identity(path)
    if identity is None:
        return
    key = os.path.abspath(path)
    with _WRITTEN_LOCK:
        _WRITTEN.pop(key, None)
        _WRITTEN[key] = (identity, digest)
        while len(_WRITTEN) > WRITTEN_REMEMBERED:  # the oldest first (dicts keep their order)
            _WRITTEN.pop(next(iter(_WRITTEN)))


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
