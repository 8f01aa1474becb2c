"""One writer per output folder: the lock that convert and batch take, and the sweep of the
temporary files that a killed run left behind.

Two runs writing one set of names into one folder at once produce a mixed set (one run's STL,
the other's recipe) that both report as done. The lock is an exclusive `flock` on a file in the
folder, opened without following symbolic links (a planted link cannot send our writes
elsewhere), and removed when the run ends. Because a run removes the file as it finishes, a
run that opened the old file just before that re-checks, once it holds the lock, that the name
still points at the file it locked; otherwise it starts again on the new file.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import stat
from pathlib import Path

from ..errors import ExportError, InputError

log = logging.getLogger(__name__)

LOCK_NAME = ".tamp-batch.lock"  # the name batch has always used: an older batch and a newer convert exclude each other
PART_GLOB = ".*.part"  # files.write_atomic's temporary names
ATTEMPTS = 5


def _open_lock_file(path: Path) -> int:
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags, 0o644)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError(
                f"{path}: is a symbolic link, not this folder's lock file; TAMP-OS does not follow it. "
                f"Remove the link (someone may have planted it) and run again."
            ) from None
        raise ExportError(
            f"{path.parent}: cannot write into this output folder ({exc.strerror}); check its permissions or choose another with -o."
        ) from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise InputError(f"{path}: is not a regular file, so it cannot be this folder's lock; remove it and run again.")
    return fd


def prepare_folder(folder: Path) -> Path:
    """Create the output folder if needed; refuse a file or an uncreatable path in plain words."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ExportError(f"{folder}: is a file, not a folder; choose an output folder with -o (a new name is created).")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"{folder}: cannot create the output folder ({exc.strerror}); choose another with -o.") from None
    return folder


@contextlib.contextmanager
def folder_lock(folder: Path, who: str = "another TAMP-OS run"):
    """Hold the output folder's lock for the duration; refuse at once when another run holds it.

    The folder is created if needed. On leaving, the lock file is removed before it is released.
    """
    import fcntl

    folder = prepare_folder(folder)
    path = folder / LOCK_NAME
    for _ in range(ATTEMPTS):
        fd = _open_lock_file(path)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise InputError(
                f"{folder}: {who} is writing into this folder now; wait for it to finish or choose another output folder."
            ) from None
        try:
            same = os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)  # the holder removed the file as we opened it: lock the new one
    else:
        raise InputError(f"{folder}: the lock of this folder keeps changing hands; run again in a moment.")
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)  # closing releases the flock


def sweep_parts(folder: Path) -> list[str]:
    """Remove temporary `.part` files that a killed run left in `folder` (call it holding the lock)."""
    removed = []
    for stale in Path(folder).glob(PART_GLOB):
        try:
            if stale.is_file() and not stale.is_symlink():
                stale.unlink()
                removed.append(stale.name)
        except OSError as exc:
            log.warning("could not remove the stale temporary file %s: %s", stale, exc)
    return removed


@contextlib.contextmanager
def output_lock(target: Path, who: str = "another convert or batch"):
    """The lock of the folder that `target` (a folder, or a file name such as print.stl) writes
    into, with the stale temporary files of killed runs swept once it is held."""
    from ..export.files import check_path_length

    target = Path(target)
    check_path_length(target)  # a name the file system cannot hold fails in plain words, before any look at it
    folder = target.parent if target.suffix and not target.is_dir() else target
    with folder_lock(folder, who) as path:
        sweep_parts(folder)
        yield path
