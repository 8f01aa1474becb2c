"""The liblouis braille tables installed here, by name and by language, for choosing one and for
saying which real tables are closest to a name that is not one.

liblouis tables carry their own metadata in comment lines (`#+language:fr`, `#+grade:2`,
`#-display-name: French contracted braille`); only tables that have a display name are meant to be
chosen (the others are pieces included by them), so those are the ones offered.
"""

from __future__ import annotations

import difflib
import functools
import os
from dataclasses import dataclass
from pathlib import Path

TABLE_DIRS = ("/usr/share/liblouis/tables", "/usr/local/share/liblouis/tables")
TABLE_SUFFIXES = (".ctb", ".utb", ".tbl")


@dataclass(frozen=True)
class BrailleTable:
    name: str  # the file name liblouis takes: 'fr-bfu-g2.ctb'
    language: str  # its '#+language' tag: 'fr', 'en-US', ... ('' when it has none)
    display_name: str  # 'French contracted braille'
    grade: str = ""  # '1', '2' or '' when the table does not say

    def line(self) -> str:
        return f"{self.name} ({self.display_name})"


def table_dirs() -> list[Path]:
    """liblouis's table folders: LOUIS_TABLEPATH's (comma-separated, as liblouis reads it), then the install folders."""
    env = [Path(p) for p in os.environ.get("LOUIS_TABLEPATH", "").split(",") if p]
    return [d for d in (*env, *(Path(p) for p in TABLE_DIRS)) if d.is_dir()]


@functools.lru_cache(maxsize=4)
def _tables_in(folders: tuple[Path, ...]) -> tuple[BrailleTable, ...]:
    found: dict[str, BrailleTable] = {}
    for folder in folders:
        for path in sorted(folder.iterdir()):
            if path.suffix not in TABLE_SUFFIXES or path.name in found:
                continue
            meta = _metadata(path)
            if meta.get("display-name"):
                found[path.name] = BrailleTable(path.name, meta.get("language", ""), meta["display-name"], meta.get("grade", ""))
    return tuple(sorted(found.values(), key=lambda t: t.name.lower()))


def _metadata(path: Path) -> dict[str, str]:
    """The '#+key:value' and '#-key:value' lines at the head of a table (they come before any rule)."""
    meta: dict[str, str] = {}
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            for _, line in zip(range(200), fh):
                if line.startswith(("#+", "#-")) and ":" in line:
                    key, _, value = line[2:].partition(":")
                    meta.setdefault(key.strip().lower(), value.strip())
    except OSError:
        pass
    return meta


def installed_tables() -> tuple[BrailleTable, ...]:
    """Every table meant to be chosen, in every table folder (first folder wins a name)."""
    return _tables_in(tuple(table_dirs()))


def tables_for_language(language: str) -> list[BrailleTable]:
    """Tables whose language is `language` ('fr' also finds 'fr-FR'), uncontracted (grade 1) first."""
    lang = language.strip().lower()
    return sorted(
        (t for t in installed_tables() if t.language.lower() == lang or t.language.lower().startswith(lang + "-")), key=lambda t: (t.grade != "1", t.name)
    )


def table_exists(name: str) -> bool | None:
    """Whether liblouis can find table `name` (each part of a comma-separated list); None when no table
    folder is known here (then only liblouis can tell)."""
    folders = table_dirs()
    if not folders:
        return None
    return all(Path(part).is_file() or any((d / part).is_file() for d in folders) for part in name.split(",") if part)


def closest_tables(name: str, n: int = 4) -> list[BrailleTable]:
    """Real tables closest to `name`: those of the language it names, then names that start with it,
    then names that read alike."""
    key = name.strip().lower()
    tables = installed_tables()
    by_name = {t.name.lower(): t for t in tables}
    picks = tables_for_language(key.split(".")[0]) if key else []
    picks += [t for t in tables if t.name.lower().startswith(key) and t not in picks]
    stems = {t.name.lower().rsplit(".", 1)[0]: t for t in tables}
    picks += [stems[s] for s in difflib.get_close_matches(key.rsplit(".", 1)[0], list(stems), n=n, cutoff=0.5) if stems[s] not in picks]
    picks += [by_name[s] for s in difflib.get_close_matches(key, list(by_name), n=n, cutoff=0.5) if by_name[s] not in picks]
    return picks[:n]
