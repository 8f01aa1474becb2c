"""Issue 24.5: messages in the command line's words, sweep --vary in CLI spellings, the closest real
braille tables for a wrong one, result lines of at most 160 characters, progress only on a terminal."""

from __future__ import annotations

import io
import time

import numpy as np
import pytest
import tifffile
from PIL import Image

from conftest import need, run_cli
from tamp_os.errors import ParameterError


@pytest.fixture
def small_png(tmp_path):
    img = np.tile(np.linspace(0, 255, 40, dtype=np.uint8), (30, 1))
    img[5:12, 5:15] = 255
    path = tmp_path / "in" / "small.png"
    path.parent.mkdir()
    Image.fromarray(img).save(path)
    return path


def test_vary_takes_the_command_lines_spellings():
    from tamp_os.cli.commands import _vary_in_field_names
    from tamp_os.lithograph.sweep import parse_vary

    specs = _vary_in_field_names(["relief-style=structure,levels", "--slice=0,1", "height-mm=20,30", "resolution=8,16"])
    vary = parse_vary(specs)
    assert vary == {"relief_style": ["structure", "levels"], "z_slice": [0, 1], "depth_mm": [20.0, 30.0], "resolution_px": [8, 16]}


@pytest.mark.timeout(300)
def test_sweep_runs_with_a_dashed_name(tmp_path, small_png, capsys):
    code, out, err = run_cli(capsys, "sweep", small_png, "--vary", "relief-style=structure,levels", "-o", tmp_path / "sw",
                             "--no-render", "--width-mm", "40")
    assert code == 0, err
    assert "sweep: 2 variants" in out


def _need_tables():
    from tamp_os.tactile.braille_tables import installed_tables

    need(bool(installed_tables()), "liblouis tables (apt-get install liblouis-data)")


def test_a_wrong_table_gets_the_closest_real_tables_by_name():
    _need_tables()
    from tamp_os.tactile.braille import to_braille

    with pytest.raises(ParameterError) as info:
        to_braille("bonjour", "fr")
    text = str(info.value)
    assert "fr-bfu-g2.ctb (French contracted braille)" in text and "fr-bfu-comp6.utb" in text
    assert "inbuf" not in text and "Can't translate" not in text


@pytest.mark.timeout(120)
def test_the_cli_says_it_with_the_option_name_and_no_liblouis_internals(tmp_path, small_png, capsys):
    _need_tables()
    code, out, err = run_cli(capsys, "convert", small_png, "--caption", "bonjour", "--braille-table", "fr", "-o", tmp_path / "o")
    assert code != 0 and err.startswith("error: --braille-table: liblouis has no table called 'fr'")
    assert "compiled" not in err and "inbuf" not in err
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_tables_by_language():
    _need_tables()
    from tamp_os.tactile.braille_tables import tables_for_language

    french = tables_for_language("fr")
    assert french and all(t.language.lower().startswith("fr") for t in french)
    english = [t.name for t in tables_for_language("en")]
    assert "en-ueb-g1.ctb" in english and "en-ueb-g2.ctb" in english


@pytest.mark.timeout(300)
def test_result_line_at_most_160_characters_and_details_with_verbose(tmp_path, small_png, capsys):
    long = small_png.with_name("a-very-long-file-name-from-a-microscope-export-" + "x" * 120 + ".png")
    small_png.rename(long)
    code, out, err = run_cli(capsys, "convert", long, "-o", tmp_path / "o", "--formats", "stl,3mf,glb,obj,ply,step", "--verbose",
                             "--width-mm", "40")
    assert code == 0, err
    lines = out.splitlines()
    # the name is said whole (never cut); the files as their count and folder (tests/cli/test_result_lines.py)
    assert lines[0].startswith(f"{long.name}: ") and "…" not in lines[0] and lines[0].endswith(f"files to {tmp_path / 'o'}/")
    written = sorted(p.name for p in (tmp_path / "o").iterdir())
    assert sorted(line.removeprefix("  wrote: ") for line in lines if line.startswith("  wrote: ")) == written
    assert any(line.startswith("  mesh: ") and "triangles" in line for line in lines)


@pytest.mark.timeout(60)
def test_info_notes_speak_in_option_names(tmp_path, capsys):
    stack = (np.random.default_rng(0).random((3, 24, 32)) * 255).astype(np.uint8)
    path = tmp_path / "stack.tif"
    tifffile.imwrite(path, stack, imagej=True, metadata={"axes": "ZYX"})
    code, out, err = run_cli(capsys, "info", path)
    assert code == 0, err
    note = next(line for line in out.splitlines() if "z-stack" in line)
    assert "--slice" in note and "z_slice" not in note


class _Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.mark.timeout(30)
def test_working_line_only_on_a_terminal_and_only_after_a_while(monkeypatch):
    from tamp_os.cli.commands import _WorkingLine

    monkeypatch.setattr(_WorkingLine, "PROGRESS_AFTER_S", 0.2)
    tty, pipe = _Terminal(), io.StringIO()
    with _WorkingLine("slow.tif", tty):
        time.sleep(1.5)
    with _WorkingLine("slow.tif", pipe):
        time.sleep(0.5)
    assert "slow.tif: working" in tty.getvalue() and tty.getvalue().endswith("\r\x1b[K")
    assert pipe.getvalue() == ""
    quick = _Terminal()
    with _WorkingLine("quick.tif", quick):
        pass
    assert quick.getvalue() == ""
