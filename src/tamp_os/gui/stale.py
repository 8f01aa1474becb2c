"""The web app's own leftovers: job folders of a server that was killed (SIGKILL, a power cut)
before it could remove them. Uploads are people's images; they must not stay in the temporary
folder forever.

Each server writes an owner file (its process id and start time) into its folder; at start, a
server removes the `tamp-gui-*` folders in the temporary folder whose owner is no longer
running, and only folders that belong to this user and are real folders (never a link).
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import stat
import tempfile
import time
from pathlib import Path

log = logging.getLogger(__name__)

PREFIX = "tamp-gui-"
OWNER_FILE = ".tamp-gui-owner"
JOB_FOLDER = re.compile(r"^[0-9a-f]{32}$")
UNOWNED_AGE_S = 24 * 3600  # folders from servers that wrote no owner file: removed after a day


def _start_time(pid: int) -> str:
    """The process's start time in clock ticks since boot (tells a reused pid apart), or ''."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return fields[19]  # field 22 of stat; the first two (pid, comm) were split off
    except (OSError, IndexError):
        return ""


def _running(pid: int, started: str) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's process with that pid: not ours to judge, keep the folder
    return not started or not _start_time(pid) or _start_time(pid) == started


def claim(root: Path) -> None:
    """Mark `root` as this server's."""
    pid = os.getpid()
    (Path(root) / OWNER_FILE).write_text(f"{pid} {_start_time(pid)}\n")


def _owner_alive(folder: Path) -> bool | None:
    """True/False from the owner file; None when there is none (or it is unreadable)."""
    try:
        words = (folder / OWNER_FILE).read_text().split()
        return _running(int(words[0]), words[1] if len(words) > 1 else "")
    except (OSError, ValueError, IndexError):
        return None


def _ours(path: Path) -> bool:
    try:
        info = os.lstat(path)
    except OSError:
        return False
    return stat.S_ISDIR(info.st_mode) and info.st_uid == os.getuid()


def sweep_stale(tmp_dir: Path | None = None, now: float | None = None) -> list[Path]:
    """Remove the job folders of servers that are no longer running; the folders removed."""
    tmp_dir = Path(tmp_dir or tempfile.gettempdir())
    now = time.time() if now is None else now
    removed = []
    try:
        candidates = [p for p in tmp_dir.iterdir() if p.name.startswith(PREFIX)]
    except OSError:
        return removed
    for folder in candidates:
        if not _ours(folder):
            continue
        alive = _owner_alive(folder)
        if alive is None:
            try:
                alive = now - folder.stat().st_mtime < UNOWNED_AGE_S
            except OSError:
                continue
        if not alive:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    if removed:
        log.info("removed %d job folder(s) left by stopped TAMP-OS servers", len(removed))
    return removed


def sweep_root(root: Path) -> list[Path]:
    """In a job root given by the user: the job folders left by a previous server there, if it has stopped."""
    root = Path(root)
    if _owner_alive(root) is not False:
        return []
    removed = []
    for folder in root.iterdir():
        if JOB_FOLDER.match(folder.name) and _ours(folder):
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed
