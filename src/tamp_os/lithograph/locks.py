"""One writer per output folder: the lock that convert and batch take, and the sweep of the
temporary files that a killed run left behind.

Two runs writing one set of names into one folder at once produce a mixed set (one run's STL,
the other's recipe) that both report as done. The lock is an exclusive `flock` on a file in the
folder, opened without following symbolic links (a planted link cannot send our writes
elsewhere), and removed when the run ends. Because a run removes the file as it finishes, a
run that opened the old file just before that re-checks, once it holds the lock, that the name
still points at the file it locked; otherwise it starts again on the new file.

A run killed with SIGKILL cannot remove the file, but the kernel releases its flock with the
process (and batch's workers die with it: batch.exit_with_parent), so the next run takes the lock
of the file that is left and goes on. The holder writes its process ID into the file: a refusal
names the process that writes, and a run that takes over a lock left by a process that is gone
says so in the log.
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
        except OSError as exc:
            holder = _holder(fd)
            os.close(fd)
            if exc.errno not in (errno.EWOULDBLOCK, errno.EAGAIN):  # a file system without locks, not a holder
                raise ExportError(f"{folder}: cannot lock this output folder ({exc.strerror}); choose a folder on a "
                                  f"local disk with -o.") from None
            raise InputError(
                f"{folder}: {who}{f' (process {holder})' if holder else ''} is writing into this folder now; wait for it "
                f"to finish or choose another output folder."
            ) from None
        try:
            same = os.stat(path, follow_symlinks=False).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            _take_over(fd, path)
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


def _holder(fd: int) -> int | None:
    """The process ID a lock file names (None: none, or not a number)."""
    try:
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def _take_over(fd: int, path: Path) -> None:
    """Write this process's ID into the lock it now holds; log a lock a process that is gone left."""
    left_by = _holder(fd)
    if left_by is not None and left_by != os.getpid():
        log.info("%s: the lock left by process %d (stopped without removing it) is taken over", path, left_by)
    with contextlib.suppress(OSError):  # the ID is for people; the flock is the lock
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)


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
