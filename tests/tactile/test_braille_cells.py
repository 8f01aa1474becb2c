"""tactile/braille.py: cells, dot positions against the standard's numbers, the tables' refusals and the system translator."""

import math
import numpy as np
import pytest
from conftest import need


def test_dots_of_a_cell_and_their_places():
    from tamp_os.tactile.braille import DOT_POSITION, cell_dots

    assert cell_dots("⠀") == [] and cell_dots("⠁") == [1] and cell_dots("⠿") == [1, 2, 3, 4, 5, 6]
    assert cell_dots("⣿") == list(range(1, 9)) and cell_dots("⢀") == [8] and cell_dots("⡀") == [7]
    assert cell_dots("⠚") == [2, 4, 5]  # j
    # Braille's own numbering: 1-2-3 down the left column, 4-5-6 down the right, 7 and 8 below.
    assert DOT_POSITION == {1: (0, 0), 2: (0, 1), 3: (0, 2), 4: (1, 0), 5: (1, 1), 6: (1, 2), 7: (0, 3), 8: (1, 3)}


def test_dot_centres_follow_the_spacing_of_the_standard():
    from tamp_os.tactile.braille import BrailleSpec, dot_centres

    spec = BrailleSpec(dot_diameter_mm=1.4, dot_spacing_mm=2.4, cell_spacing_mm=6.2, line_spacing_mm=10.5)
    r = 0.7
    centres = dot_centres(["⣿⠁", "⠈"], spec, 3.0, top_mm=50.0)
    first = [(3.0 + r + col * 2.4, 50.0 - r - row * 2.4) for col, row in
             ((0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (0, 3), (1, 3))]
    expected = first + [(3.0 + r + 6.2, 50.0 - r)] + [(3.0 + r + 2.4, 50.0 - r - 10.5)]
    assert np.allclose(np.array(centres), np.array(expected), atol=1e-12, rtol=0)
    assert dot_centres([], spec, 0.0, top_mm=0.0) == [] and dot_centres(["⠀⠀"], spec, 0.0, top_mm=0.0) == []


def test_block_size_of_one_cell_and_of_lines():
    from tamp_os.tactile.braille import BrailleSpec, block_size_mm

    spec = BrailleSpec()  # 1.5 mm dots 2.5 mm apart, cells 6 mm, lines 10 mm
    assert block_size_mm(["⠿"], spec) == pytest.approx((2.5 + 1.5, spec.cell_height_mm))
    assert block_size_mm(["⠿⠿⠿", "⠿"], spec) == pytest.approx((2 * 6.0 + 2.5 + 1.5, 10.0 + spec.cell_height_mm))
    assert block_size_mm(["⠿", "⣿"], spec)[1] == pytest.approx(10.0 + spec.cell_height_mm + 2.5)  # dots 7, 8 below
    assert block_size_mm(["⣿", "⠿"], spec)[1] == pytest.approx(10.0 + spec.cell_height_mm)  # only the last line's count
    assert block_size_mm(["⡀"], spec)[1] == pytest.approx(spec.cell_height_mm + 2.5)
    assert block_size_mm(["⢀"], spec)[1] == pytest.approx(spec.cell_height_mm + 2.5)
    assert block_size_mm(["⠀⠿ "], spec)[0] == pytest.approx(2 * 6.0 + 4.0)


def test_what_counts_as_unicode_braille():
    from tamp_os.tactile.braille import is_unicode_braille

    assert is_unicode_braille("⠁⠃ ⠉\n⠙") and is_unicode_braille("⠀") and is_unicode_braille("⣿")
    assert not is_unicode_braille("") and not is_unicode_braille("⠁a") and not is_unicode_braille("⠁\t")
    assert not is_unicode_braille("\u27ff") and not is_unicode_braille("\u2900")


def test_characters_no_braille_table_can_write():
    from tamp_os.tactile.braille import unwritable_characters

    assert unwritable_characters("two\nlines") == []
    assert unwritable_characters("a\tb\x00c\u200b\ue000\U000e0080\ud800\t") == sorted(
        {"\t", "\x00", "\u200b", "\ue000", "\U000e0080", "\ud800"})


def test_control_characters_are_refused_by_name_and_parameter():
    from tamp_os.errors import ParameterError
    from tamp_os.tactile.braille import to_braille

    with pytest.raises(ParameterError) as caught:
        to_braille("a\tb\u200b", what="caption")
    assert str(caught.value) == ("caption: control characters cannot be written in braille: U+0009 unnamed, "
                                 "U+200B ZERO WIDTH SPACE; remove them.")


def test_unicode_braille_passes_through_with_blank_cells():
    from tamp_os.tactile.braille import BLANK, Liblouis, to_braille

    never = Liblouis(binding=None, command=None)  # a translator would fail: it is not asked
    assert to_braille("⠁⠃ ⠉", translator=never) == f"⠁⠃{BLANK}⠉"
    assert BLANK == "\u2800"


class _Table:
    """A stand-in liblouis binding: letters a-c to cells, anything else to an escape."""

    dotsIO, ucBrl = 4, 8
    cells = {"a": "⠁", "b": "⠃", "c": "⠉", "q": "⠟", " ": " "}

    @classmethod
    def translateString(cls, tables, text, mode=0):
        assert tables == ["t.ctb"] and mode == cls.dotsIO | cls.ucBrl
        if text == "qq":  # a pair the table cannot write, though each letter alone it can
            return "\u2804\u2873\u282d"
        return "".join(cls.cells.get(ch, "\u2804\u2873\u282d") for ch in text)


def test_a_character_the_table_lacks_is_refused_by_name(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille

    monkeypatch.setattr(braille, "check_table_name", lambda table: None)
    louis = braille.Liblouis(binding=_Table, command=None)
    assert braille.to_braille("ab c", "t.ctb", translator=louis) == "⠁⠃⠀⠉"
    with pytest.raises(ParameterError) as caught:
        braille.to_braille("a€b ☃", "t.ctb", translator=louis, what="caption")
    assert str(caught.value) == (
        "caption: the braille table t.ctb cannot write U+20AC EURO SIGN (€), U+2603 SNOWMAN (☃) (liblouis would "
        "emboss escape codes); remove them, choose another braille_table, or give the text as Unicode braille.")


def test_escape_cells_are_dots_seven_and_eight_or_the_escape_sequence():
    from tamp_os.tactile.braille import _has_escape

    assert not _has_escape("⠁⠿⠀") and not _has_escape("")
    assert _has_escape("⡀") and _has_escape("⢀") and _has_escape("⣿")
    assert _has_escape("⠁\u2804\u2873\u282d⠁") and not _has_escape("\u2804\u282d")


def test_an_unknown_table_is_refused_before_liblouis_is_asked(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille, braille_tables

    monkeypatch.setattr(braille_tables, "table_exists", lambda table: False)
    monkeypatch.setattr(braille_tables, "closest_tables", lambda table: [])
    with pytest.raises(ParameterError) as caught:
        braille.check_table_name("nope.ctb")
    assert str(caught.value) == ("braille_table: liblouis has no table called 'nope.ctb'. "
                                 "Give a table's file name, such as en-ueb-g2.ctb.")
    monkeypatch.setattr(braille_tables, "table_exists", lambda table: None)  # cannot tell: liblouis decides
    braille.check_table_name("nope.ctb")


def test_an_unknown_table_names_the_closest(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille, braille_tables

    class Close:
        def __init__(self, name):
            self.name = name

        def line(self):
            return self.name

    monkeypatch.setattr(braille_tables, "table_exists", lambda table: False)
    monkeypatch.setattr(braille_tables, "closest_tables",
                        lambda table: [Close("en-ueb-g1.ctb"), Close("en-ueb-g2.ctb")] if table == "en-ueb.ctb" else [])
    with pytest.raises(ParameterError, match=r"The closest are: en-ueb-g1\.ctb; en-ueb-g2\.ctb\. Give"):
        braille.check_table_name("en-ueb.ctb")


def test_the_system_translator_is_found_once():
    from tamp_os.tactile.braille import Liblouis, liblouis_available

    assert Liblouis.system() is Liblouis.system()
    assert liblouis_available() == Liblouis.system().available
    assert Liblouis(binding=_Table).available and Liblouis(command="/bin/true").available


def test_the_command_output_is_read_as_braille_ascii(tmp_path):
    from tamp_os.tactile.braille import Liblouis

    def fake(output: str):
        script = tmp_path / "lou"
        script.write_text(f"#!/bin/sh\ncat > /dev/null\nprintf '{output}'\n")
        script.chmod(0o755)
        return Liblouis(binding=None, command=str(script))

    assert fake("ABC\\n\\n").translate("x", "t") == "⠁⠃⠉"
    assert fake("a b").translate("x", "t") == "⠁\u2800⠃"  # Braille ASCII is case-free; its space is the blank cell
    assert fake("#A").translate("x", "t") == "⠼⠁"
    assert fake("A\\\\X4E2D/").translate("x", "t") == "\u2873"
    assert fake("A\\\\y1f600/").translate("x", "t") == "\u2873"
    assert fake("A\\\\Z").translate("x", "t") == "⠁⠳⠵"


def test_a_combination_the_table_cannot_write_is_refused_without_a_name(monkeypatch):
    from tamp_os.errors import ParameterError
    from tamp_os.tactile import braille

    monkeypatch.setattr(braille, "check_table_name", lambda table: None)
    with pytest.raises(ParameterError, match="the braille table t.ctb cannot write some characters \\(liblouis"):
        braille.to_braille("qq", "t.ctb", translator=braille.Liblouis(binding=_Table), what="caption")


def test_refusals_name_text_by_default_and_the_install_hint():
    from tamp_os.errors import MissingDependencyError, ParameterError
    from tamp_os.tactile.braille import INSTALL_HINT, Liblouis, is_unicode_braille, to_braille

    with pytest.raises(ParameterError, match="^text: control characters"):
        to_braille("a\tb")
    with pytest.raises(MissingDependencyError) as caught:
        Liblouis(binding=None, command=None).translate("a", "t.ctb")
    assert INSTALL_HINT in str(caught.value) and "liblouis-bin" in INSTALL_HINT
    assert not is_unicode_braille("⠁X") and not is_unicode_braille("X")


def test_the_command_output_keeps_trailing_blanks_and_survives_bad_bytes(tmp_path):
    from tamp_os.tactile.braille import Liblouis

    script = tmp_path / "lou"
    script.write_text("#!/bin/sh\ncat > /dev/null\nprintf 'A  \\n'\n")
    script.chmod(0o755)
    assert Liblouis(command=str(script)).translate("a  ", "t") == "⠁\u2800\u2800"  # the spaces are cells
    script.write_text("#!/bin/sh\ncat > /dev/null\nprintf 'A\\377B\\177\\n'\n")  # not UTF-8, and a DEL
    assert Liblouis(command=str(script)).translate("ab", "t") == "⠁⠃⠸"  # bad bytes dropped; DEL folds onto '_'


def test_the_binding_is_found_in_debians_dist_packages(monkeypatch):
    import sys
    from pathlib import Path

    from tamp_os.tactile.braille import _load_binding

    need(Path("/usr/lib/python3/dist-packages/louis/__init__.py").is_file() or
         Path("/usr/local/lib/python3/dist-packages/louis/__init__.py").is_file(), "python3-louis (apt-get install python3-louis)")
    monkeypatch.setitem(sys.modules, "louis", None)  # `import louis` fails, as in a virtual environment
    louis = _load_binding()
    assert louis is not None and "dist-packages" in louis.__file__
    assert louis.translateString(["en-ueb-g1.ctb"], "abc", mode=louis.dotsIO | louis.ucBrl) == "⠁⠃⠉"
