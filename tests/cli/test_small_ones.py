"""Issue 54.9, each run as a user types it (a child process): one warning for an XZ scan; a port out
of range, an unknown format and an unknown braille table are usage errors (exit 2) that name what
is wrong; a recipe rebuilds the PDF byte for byte; a resin's cost is at a resin's price, said as
an assumption; `slice` and `estimate` take convert's price option (the old name still works);
the command-line synopsis names the options a newcomer looks for."""

from __future__ import annotations

import re
import shutil

import numpy as np
import pytest
from PIL import Image

from cli_support import run_tamp
from conftest import ROOT, need

EXIT_USAGE = 2


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.strip()]


@pytest.fixture
def ramp(tmp_path):
    image = np.tile(np.linspace(0, 255, 80, dtype=np.float32), (60, 1))
    image[10:25, 10:30] = 255
    Image.fromarray(image.astype(np.uint8)).save(tmp_path / "ramp.png")
    return tmp_path / "ramp.png"


@pytest.mark.timeout(300)
def test_an_xz_scan_is_one_warning(tmp_path):
    from lif_builder import write_lif

    z, x = np.mgrid[:96, :96]
    data = np.zeros((2, 96, 96), np.uint8)
    for cz, cx in ((30, 30), (60, 60), (40, 75)):  # beads drawn long along Z, as the optical axis blurs them
        data[0] += (((x - cx) ** 2 + ((z - cz) / 2.2) ** 2) < 36).astype(np.uint8) * 200
    data[1] = (np.random.default_rng(0).random((96, 96)) * 40).astype(np.uint8)
    write_lif(tmp_path / "xz.lif", [("xz", "CZX", data, {"X": (0.0, 1e-7), "Z": (0.0, 1e-7)})])
    done = run_tamp("convert", "xz.lif", "-o", "out", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    side = [line for line in done.stderr.splitlines() if "side view" in line or "XZ" in line]
    assert len(side) == 1 and side[0].startswith("warning: image 'xz' is an XZ scan"), done.stderr
    described = (tmp_path / "out" / "xz.description.txt").read_text(encoding="utf-8")
    assert "XZ section" in described  # how its shapes were measured is still said, in the description


@pytest.mark.timeout(120)
@pytest.mark.parametrize("port", ["99999", "-1"])
def test_a_port_out_of_range_is_a_usage_error_naming_the_range(tmp_path, port):
    done = run_tamp("gui", "--port", port, "--no-browser", cwd=tmp_path, timeout_s=60)
    assert done.returncode == EXIT_USAGE, done.stderr
    assert error_lines(done.stderr) == [f"error: --port: must be a port number from 0 to 65535; got {port}."]


@pytest.mark.timeout(120)
def test_an_unknown_format_is_named_as_the_user_wrote_it(tmp_path, ramp):
    done = run_tamp("convert", ramp.name, "--formats", "stl,jpg", "-o", "out", cwd=tmp_path)
    assert done.returncode == EXIT_USAGE, done.stderr
    (line,) = error_lines(done.stderr)
    assert line.startswith("error: --formats: 'jpg' is not a format TAMP-OS writes; give each one of stl, 3mf,"), line
    assert line.endswith("; got stl,jpg.") and "(" not in line, line  # no Python tuple
    assert not (tmp_path / "out").exists()


@pytest.mark.timeout(120)
def test_an_unknown_braille_table_is_a_usage_error_before_any_work(tmp_path, ramp):
    from tamp_os.tactile.braille_tables import table_dirs

    need(bool(table_dirs()), "liblouis's braille tables (Debian liblouis-data)")
    done = run_tamp("convert", ramp.name, "--braille-table", "de", "-o", "out", cwd=tmp_path)
    assert done.returncode == EXIT_USAGE, done.stderr
    (line,) = error_lines(done.stderr)
    assert line.startswith("error: --braille-table: liblouis has no table called 'de'.") and "de-g1.ctb" in line, line
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.timeout(300)
def test_the_readme_recipe_rebuilds_the_pdf_byte_for_byte(tmp_path, ramp):
    """README: `tamp-os convert --recipe first/cell.tamp.json -o again/` rebuilds the print byte for byte."""
    import time

    first = run_tamp("convert", ramp.name, "-o", "first/", "--formats", "stl,3mf,pdf", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    time.sleep(1.1)  # PDF dates are to the second
    again = run_tamp("convert", "--recipe", "first/ramp.tamp.json", "-o", "again/", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    for name in ("ramp.stl", "ramp.3mf", "ramp.pdf", "ramp.description.txt"):
        assert (tmp_path / "first" / name).read_bytes() == (tmp_path / "again" / name).read_bytes(), name
    assert b"/CreationDate" not in (tmp_path / "first" / "ramp.pdf").read_bytes()
    if shutil.which("pdfinfo"):  # the PDF is still a PDF a reader opens, with its title
        import subprocess

        info = subprocess.run(["pdfinfo", str(tmp_path / "again" / "ramp.pdf")], capture_output=True, text=True, timeout=30)
        assert info.returncode == 0 and "Tactile lithograph of ramp.png" in info.stdout, info.stdout + info.stderr


@pytest.fixture
def box_stl(tmp_path):
    import trimesh

    trimesh.creation.box((40, 30, 3)).export(tmp_path / "plate.stl")
    return tmp_path / "plate.stl"


@pytest.mark.timeout(120)
def test_resin_is_costed_at_a_resin_price_said_as_an_assumption(tmp_path, box_stl):
    done = run_tamp("estimate", box_stl.name, "--printer", "sl1s", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    head = done.stdout.splitlines()[0]
    ml = 40 * 30 * 3 / 1000
    cost = ml * 1.1 / 1000 * 35  # resin's own assumed price, not filament's 25
    assert f"costing about {cost:.2f} at 35 per kg" in head, head
    assert "35 per kg (an assumed price, in your currency)" in head, head
    given = run_tamp("estimate", box_stl.name, "--printer", "sl1s", "--resin-price-per-kg", "60", cwd=tmp_path)
    head = given.stdout.splitlines()[0]
    assert f"costing about {ml * 1.1 / 1000 * 60:.2f} at 60 per kg" in head and "assumed price" not in head, head


@pytest.mark.timeout(120)
@pytest.mark.parametrize("option", ["--filament-price-per-kg", "--filament-price"])
def test_estimate_takes_converts_price_option_and_the_old_name(tmp_path, box_stl, option):
    done = run_tamp("estimate", box_stl.name, option, "20", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    head = done.stdout.splitlines()[0]
    assert "at 20 per kg" in head and "PLA at 1.24 g/cm³ and 20 per kg." in head, head


@pytest.mark.timeout(120)
def test_slice_help_names_the_price_options(tmp_path):
    done = run_tamp("slice", "--help", cwd=tmp_path)
    assert done.returncode == 0
    assert "--filament-price-per-kg PER_KG, --filament-price PER_KG" in done.stdout and "--resin-price-per-kg" in done.stdout


def synopsis(command: str) -> str:
    """The `tamp-os COMMAND` synopsis of docs/command-line.md, its continuation lines joined."""
    text = (ROOT / "docs" / "command-line.md").read_text(encoding="utf-8")
    block = re.search(r"```sh\n(.*?)```", text, re.S).group(1)
    lines, taking = [], False
    for line in block.splitlines():
        if line.startswith(".venv/bin/tamp-os "):
            taking = line.split()[1] == command and "--recipe" not in line
        if taking:
            lines.append(line)
    return " ".join(lines)


@pytest.mark.timeout(120)
def test_the_convert_synopsis_names_the_options_a_newcomer_looks_for(tmp_path):
    said = synopsis("convert")
    named = set(re.findall(r"\[(--[a-z-]+)", said)) | set(re.findall(r"\| (--[a-z-]+)", said))
    for option in ("--channels", "--key-labels", "--volume", "--sections", "--braille-table", "--material"):
        assert option in named, option
    helped = run_tamp("convert", "--help", cwd=tmp_path).stdout
    assert not [o for o in named if not re.search(rf"^\s+{o}\b", helped, re.M)]  # each is an option convert has
