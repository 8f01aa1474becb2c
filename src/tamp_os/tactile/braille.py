"""Text -> braille cells (through liblouis) -> dot centres in millimetres.

liblouis is the standard open braille translator; it is a system library (Debian
liblouis-bin, liblouis-data, python3-louis), not on PyPI. We use its Python binding when it
can be imported (also from Debian's dist-packages, which a virtual environment does not see),
else its `lou_translate` command, whose Braille ASCII we map to Unicode cells. Text that is
already Unicode braille (U+2800-U+28FF) is used as it is.
"""

from __future__ import annotations

import functools
import importlib.util
import re
import shutil
import subprocess
import unicodedata
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..standards import DEFAULT_TABLE, BrailleSpec  # noqa: F401  (re-exported: the braille stage's numbers)
from ..errors import MissingDependencyError, ParameterError

BLANK = "\u2800"
# North American Braille ASCII: the character for each cell 0x00-0x3F (dots 1-6 as bits 0-5).
BRAILLE_ASCII = " A1B'K2L@CIF/MSP\"E3H9O6R^DJG>NTQ,*5<-U8V.%[$+X!&;:4\\0Z7(_?W]#Y)="
INSTALL_HINT = (
    "braille needs liblouis: on Debian or Ubuntu run 'sudo apt-get install liblouis-bin liblouis-data "
    "python3-louis' (make setup does this), or give the caption directly as Unicode braille (⠠⠋⠑⠠⠏⠞)."
)


def _load_binding():
    """The liblouis Python module, also from Debian's dist-packages; None when it is not usable."""
    try:
        import louis

        return louis
    except ImportError:
        pass
    for base in ("/usr/lib/python3/dist-packages", "/usr/local/lib/python3/dist-packages"):
        init = Path(base) / "louis" / "__init__.py"
        if init.is_file():
            spec = importlib.util.spec_from_file_location("louis", init)
            module = importlib.util.module_from_spec(spec)
            try:
                spec.loader.exec_module(module)
                return module
            except OSError:  # the binding is there but liblouis.so is not
                return None
    return None


@dataclass(frozen=True)
class Liblouis:
    """A liblouis translator: its Python binding when given, else its `lou_translate` command.

    `Liblouis.system()` finds both once per process (cached); tests build one with
    `binding=None` to use the command only.
    """

    binding: Any = None  # the `louis` module, or None
    command: str | None = None  # path of lou_translate, or None

    @staticmethod
    @functools.lru_cache(maxsize=1)
    def system() -> "Liblouis":
        return Liblouis(binding=_load_binding(), command=shutil.which("lou_translate"))

    @property
    def available(self) -> bool:
        return self.binding is not None or self.command is not None

    def translate(self, text: str, table: str) -> str:
        """Unicode braille cells for `text` (spaces kept as spaces)."""
        if self.binding is not None:
            louis = self.binding
            try:
                return louis.translateString([table], text, mode=louis.dotsIO | louis.ucBrl)
            except RuntimeError as exc:
                raise ParameterError(f"braille table {table!r}: liblouis cannot use it ({exc}); see 'lou_checktable'.") from None
        if self.command is None:
            raise MissingDependencyError(INSTALL_HINT)
        done = subprocess.run([self.command, "--forward", table], input=text, capture_output=True, text=True, encoding="utf-8", errors="replace", timeout=30)
        if done.returncode != 0:
            raise ParameterError(f"braille table {table!r}: lou_translate failed ({done.stderr.strip()}).")
        out = done.stdout.rstrip("\n")
        if re.search(r"\\[xy][0-9a-f]", out.lower()):  # '\x4e2d/', '\y1f600/': a character the table lacks
            # mark it as dots mode does (a dot-7 cell), so to_braille refuses it
            return "\u2873"
        return "".join(chr(0x2800 + BRAILLE_ASCII.index(ch)) for ch in map(_fold, out) if ch in BRAILLE_ASCII)


def liblouis_available() -> bool:
    return Liblouis.system().available


def is_unicode_braille(text: str) -> bool:
    return bool(text) and all("\u2800" <= ch <= "\u28ff" or ch in " \n" for ch in text)


def unwritable_characters(text: str) -> list[str]:
    """Control and other non-printing characters in `text` (any braille table would garble them)."""
    return sorted({ch for ch in text if ch != "\n" and unicodedata.category(ch) in ("Cc", "Cf", "Cs", "Co", "Cn")})


def _has_escape(cells: str) -> bool:
    """liblouis writes a character its table lacks as an escape ('\\x1f600/' in Braille ASCII,
    cells with dot 7 in dots mode); six-dot tables never raise dots 7 or 8 otherwise."""
    return any(ord(ch) - 0x2800 >= 0x40 for ch in cells) or "\u2804\u2873\u282d" in cells


def _name(ch: str) -> str:
    return f"U+{ord(ch):04X} {unicodedata.name(ch, 'unnamed')}" + (f" ({ch})" if ch.isprintable() else "")


def to_braille(text: str, table: str = DEFAULT_TABLE, translator: Liblouis | None = None, *, what: str = "text") -> str:
    """Unicode braille for `text` (e.g. '5 µm' -> '⠼⠑⠀⠨⠍⠍' with UEB); blanks as U+2800.

    `translator` defaults to the system's liblouis (`Liblouis.system()`). Characters the table
    cannot write (control characters, and emoji or scripts it lacks, which liblouis would turn
    into escape codes) raise ParameterError naming them and `what` (the parameter, e.g. caption).
    """
    bad = unwritable_characters(text)
    if bad:
        raise ParameterError(f"{what}: control characters cannot be written in braille: {', '.join(map(_name, bad))}; remove them.")
    if is_unicode_braille(text):
        return text.replace(" ", BLANK)
    translator = translator or Liblouis.system()
    check_table_name(table)
    cells = translator.translate(text, table)
    if _has_escape(cells):
        bad = [ch for ch in sorted(set(text)) if not ch.isspace() and _has_escape(translator.translate(ch, table))]
        raise ParameterError(
            f"{what}: the braille table {table} cannot write {', '.join(map(_name, bad)) or 'some characters'} "
            f"(liblouis would emboss escape codes); remove them, choose another `braille_table`, or give the text as Unicode braille."
        )
    return cells.replace(" ", BLANK)


def check_table_name(table: str) -> None:
    """ParameterError naming the closest real tables when liblouis has no table called `table`
    (checked on the table folders before liblouis is asked, which would only print its internals)."""
    from .braille_tables import closest_tables, table_exists

    if table_exists(table) is False:
        close = closest_tables(table)
        hint = f" The closest are: {'; '.join(t.line() for t in close)}." if close else ""
        raise ParameterError(f"`braille_table`: liblouis has no table called {table!r}.{hint} Give a table's file name, such as {DEFAULT_TABLE}.")


def _fold(ch: str) -> str:
    """Braille ASCII is case-free: 0x60-0x7F ('a'-'z', '`{|}~') mean the same cells as 0x40-0x5F."""
    return chr(ord(ch) - 0x20) if 0x60 <= ord(ch) <= 0x7F else ch


def cell_dots(cell: str) -> list[int]:
    """Dot numbers (1-8) raised in one Unicode braille cell."""
    bits = ord(cell) - 0x2800
    return [d + 1 for d in range(8) if bits >> d & 1]


# (column, row) of each dot number inside a cell; row 0 is the top.
DOT_POSITION = {1: (0, 0), 2: (0, 1), 3: (0, 2), 4: (1, 0), 5: (1, 1), 6: (1, 2), 7: (0, 3), 8: (1, 3)}


def wrap_cells(braille: str, max_cells: int) -> list[str]:
    """Lines of at most max_cells, broken at blank cells where possible."""
    if max_cells < 1:
        raise ParameterError("braille: the plate is too narrow for even one braille cell; make the print wider.")
    lines, current = [], ""
    for word in braille.split(BLANK):
        while len(word) > max_cells:  # a word longer than a line is split
            if current:
                lines.append(current)
                current = ""
            lines.append(word[:max_cells])
            word = word[max_cells:]
        candidate = f"{current}{BLANK}{word}" if current else word
        if len(candidate) <= max_cells:
            current = candidate
        else:
            lines.append(current)
            current = word
    if current:
        lines.append(current)
    return lines


def dot_centres(lines: list[str], spec: BrailleSpec, left_mm: float, *, top_mm: float) -> list[tuple[float, float]]:
    """Dot centres (x, y) in mm; the first line's top dots at y = top_mm - dot radius, lines going down."""
    centres = []
    r = spec.dot_diameter_mm / 2
    for i, line in enumerate(lines):
        y_top = top_mm - r - i * spec.line_spacing_mm
        for j, cell in enumerate(line):
            for dot in cell_dots(cell):
                col, row = DOT_POSITION[dot]
                centres.append((left_mm + r + j * spec.cell_spacing_mm + col * spec.dot_spacing_mm, y_top - row * spec.dot_spacing_mm))
    return centres


def block_size_mm(lines: list[str], spec: BrailleSpec) -> tuple[float, float]:
    """Width and height of a block of braille lines, from the outer edges of its dots."""
    if not lines:
        return 0.0, 0.0
    cells = max(len(line) for line in lines)
    width = (cells - 1) * spec.cell_spacing_mm + spec.dot_spacing_mm + spec.dot_diameter_mm
    height = (len(lines) - 1) * spec.line_spacing_mm + spec.cell_height_mm
    if any(0x2800 <= ord(cell) <= 0x28FF and (ord(cell) - 0x2800) & 0xC0 for cell in lines[-1]):
        height += spec.dot_spacing_mm  # 8-dot cells (dots 7 and 8) in the last line reach a fourth row
    return width, height
