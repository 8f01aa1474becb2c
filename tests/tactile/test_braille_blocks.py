"""tactile/braille.py: the size of a braille block, wrapping lines, Braille ASCII and the liblouis translators."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tamp_os.mesh.solid import Mesh
from tamp_os.mesh.validate import check_as_written, check_solid, merge_float32
from conftest import examples


def _dots_box(lines, spec, left, top):
    from tamp_os.tactile.braille import dot_centres

    centres = np.array(dot_centres(lines, spec, left, top_mm=top))
    r = spec.dot_diameter_mm / 2
    return centres[:, 0].min() - r, centres[:, 1].min() - r, centres[:, 0].max() + r, centres[:, 1].max() + r


@settings(max_examples=examples(60), deadline=None)
@given(
    diameter=st.floats(1.2, 1.8), spacing=st.floats(2.2, 2.8), cell=st.floats(5.5, 7.6), line=st.floats(8.0, 15.0),
    cells=st.integers(1, 12), rows=st.integers(1, 4), eight_dot=st.booleans(),
    left=st.floats(-50, 50), top=st.floats(-50, 50),
)
def test_braille_block_size_is_the_bounding_box_of_full_cells(diameter, spacing, cell, line, cells, rows, eight_dot, left, top):
    from tamp_os.tactile.braille import BrailleSpec, block_size_mm

    spec = BrailleSpec(dot_diameter_mm=diameter, dot_spacing_mm=spacing, cell_spacing_mm=cell, line_spacing_mm=line)
    full = "⣿" if eight_dot else "⠿"
    lines = [full * cells] + [full * max(1, cells - i) for i in range(1, rows)]
    x0, y0, x1, y1 = _dots_box(lines, spec, left, top)
    width, height = block_size_mm(lines, spec)
    assert x0 == pytest.approx(left) and y1 == pytest.approx(top)
    assert width == pytest.approx(x1 - x0) and height == pytest.approx(y1 - y0)


def test_braille_block_of_sparse_cells_holds_every_dot():
    from tamp_os.tactile.braille import BrailleSpec, block_size_mm

    spec = BrailleSpec()
    lines = ["⠁⠂⠄", "⠈⠐", "⠠"]
    x0, y0, x1, y1 = _dots_box(lines, spec, 0.0, 0.0)
    width, height = block_size_mm(lines, spec)
    assert x0 >= -1e-9 and y1 <= 1e-9 and x1 <= width + 1e-9 and -y0 <= height + 1e-9
    assert block_size_mm([], spec) == (0.0, 0.0)


words_of_cells = st.lists(st.text(alphabet="⠁⠃⠉⠙⠑⠋", min_size=1, max_size=14), min_size=1, max_size=12)


@settings(max_examples=examples(120), deadline=None)
@given(words=words_of_cells, max_cells=st.integers(1, 10))
def test_wrapped_braille_lines_are_greedy_and_lose_nothing(words, max_cells):
    from tamp_os.tactile.braille import BLANK, wrap_cells

    lines = wrap_cells(BLANK.join(words), max_cells)
    assert all(1 <= len(line) <= max_cells for line in lines)
    assert "".join("".join(line.split(BLANK)) for line in lines) == "".join(words)  # every cell, in order
    for word in words:
        if len(word) <= max_cells:  # a word that fits a line is never split
            assert any(word in line.split(BLANK) for line in lines), (word, lines)
    for line, following in zip(lines, lines[1:]):
        first = following.split(BLANK)[0]
        if BLANK not in line and len(line) == max_cells:
            continue  # a piece of a long word
        assert len(line) + 1 + len(first) > max_cells  # greedy: the next word did not fit


def test_wrapping_examples_and_a_plate_too_narrow():
    from tamp_os.errors import ParameterError
    from tamp_os.tactile.braille import BLANK, wrap_cells

    b = BLANK
    assert wrap_cells(f"⠁⠁{b}⠃⠃{b}⠉⠉", 5) == [f"⠁⠁{b}⠃⠃", "⠉⠉"]
    assert wrap_cells(f"⠁⠁{b}⠃⠃{b}⠉⠉", 8) == [f"⠁⠁{b}⠃⠃{b}⠉⠉"]
    assert wrap_cells("⠁⠃⠉⠙⠑⠋⠛", 3) == ["⠁⠃⠉", "⠙⠑⠋", "⠛"]
    assert wrap_cells(f"⠁{b}⠃⠉⠙⠑⠋⠛{b}⠓", 3) == ["⠁", "⠃⠉⠙", "⠑⠋⠛", "⠓"]
    assert wrap_cells("", 4) == []
    with pytest.raises(ParameterError, match="too narrow"):
        wrap_cells("⠁", 0)


def test_braille_ascii_folds_lower_case_onto_the_same_cells():
    from tamp_os.tactile.braille import _fold

    assert [_fold(c) for c in "az`{|}~"] == list("AZ@[\\]^")
    assert [_fold(c) for c in "AZ@_ 09"] == list("AZ@_ 09")


def test_the_lou_translate_command_and_its_failures(tmp_path):
    from conftest import need

    from tamp_os.errors import MissingDependencyError, ParameterError
    from tamp_os.tactile.braille import Liblouis

    command = Liblouis.system().command
    need(command is not None, "liblouis' lou_translate (apt-get install liblouis-bin)")
    by_command = Liblouis(binding=None, command=command)
    assert by_command.translate("abc", "en-ueb-g1.ctb") == "⠁⠃⠉"
    assert by_command.translate("ABC", "en-ueb-g1.ctb").endswith("⠁⠃⠉")
    assert by_command.translate("中", "en-ueb-g1.ctb") == "\u2873"  # a character the table lacks: marked for refusal
    if Liblouis.system().binding is not None:
        assert Liblouis.system().translate("5 µm", "en-ueb-g1.ctb") == by_command.translate("5 µm", "en-ueb-g1.ctb")
    failing = tmp_path / "lou_translate"
    failing.write_text("#!/bin/sh\necho 'bad table' >&2\nexit 3\n")
    failing.chmod(0o755)
    with pytest.raises(ParameterError, match="lou_translate failed \\(bad table\\)"):
        Liblouis(binding=None, command=str(failing)).translate("abc", "x.ctb")
    with pytest.raises(MissingDependencyError):
        Liblouis(binding=None, command=None).translate("abc", "x.ctb")
    assert not Liblouis(binding=None, command=None).available and by_command.available


def test_a_binding_that_refuses_a_table_is_a_parameter_error():
    from tamp_os.errors import ParameterError
    from tamp_os.tactile.braille import Liblouis

    class Binding:
        dotsIO, ucBrl = 1, 2

        @staticmethod
        def translateString(tables, text, mode=0):
            assert mode == 3 and tables == ["t.ctb"]
            if text == "bad":
                raise RuntimeError("cannot compile table")
            return "⠁"

    louis = Liblouis(binding=Binding, command=None)
    assert louis.translate("a", "t.ctb") == "⠁"
    with pytest.raises(ParameterError, match="braille table 't.ctb': liblouis cannot use it \\(cannot compile table\\)"):
        louis.translate("bad", "t.ctb")
