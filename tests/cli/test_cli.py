"""The command line: exit codes, plain output, recipes that rebuild byte for byte, presets, info."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from tamp_os import LithoParams
from tamp_os.cli.commands import OPENBLAS_THREAD_VARIABLES, main
from tamp_os.errors import ParameterError
from conftest import examples, need


@pytest.fixture
def image(tmp_path, gradient_image):
    path = tmp_path / "in" / "ramp.png"
    path.parent.mkdir()
    Image.fromarray(gradient_image).save(path)
    return path


def test_help_imports_no_heavy_libraries():
    code = "import sys; from tamp_os.cli.commands import build_parser; build_parser().format_help(); print(sorted(m for m in ('numpy','scipy','skimage','trimesh','PIL') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# The tamp-os program (commands.run) or main() called by a program, in a child process whose
# atexit handler reports how many objects the cycle collector holds frozen, whether it collects,
# the OpenBLAS thread setting, how many threads the process has left (0: not known here) and
# whether NumPy's f2py was loaded.
ENTRY = """
import atexit, gc, os, sys
from tamp_os.cli import commands
entry, argv = sys.argv[1], sys.argv[2:]
sys.argv = ["tamp-os"] + argv
threads = lambda: len(os.listdir("/proc/self/task")) if os.path.isdir("/proc/self/task") else 0
atexit.register(lambda: print("collector", gc.get_freeze_count(), gc.isenabled(), os.environ.get("OPENBLAS_NUM_THREADS"), threads(),
                              "numpy.f2py.crackfortran" in sys.modules))
sys.exit(commands.run() if entry == "run" else commands.main(argv))
"""


def test_program_exits_as_python_does_and_writes_what_main_writes(fixture, tmp_path):
    picture = fixture("fept_spheres_sem.png")
    reports = {}
    for entry in ("run", "main"):
        temp = tmp_path / f"tmp-{entry}"
        temp.mkdir()
        argv = ["convert", str(picture), "-o", str(tmp_path / entry), "--formats", "stl,3mf,glb"]
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONUNBUFFERED", *OPENBLAS_THREAD_VARIABLES)}
        done = subprocess.run([sys.executable, "-c", ENTRY, entry, *argv], capture_output=True, text=True, timeout=240,
                              env={**env, "TMPDIR": str(temp)})
        assert done.returncode == 0, done.stderr
        lines = done.stdout.splitlines()  # a pipe: block-buffered, so the result line shows the output was flushed
        assert lines[0].startswith("fept_spheres_sem.png: ") and lines[-1].startswith("collector "), lines
        reports[entry] = lines[-1].split()[1:]
        assert not list(temp.iterdir()), entry  # temporary files removed, as at any exit
    assert reports["run"][1] == reports["main"][1] == "True"  # the collector is back on after the imports
    assert reports["run"][2] == "1" and reports["main"][2] == "None"  # one OpenBLAS thread in the program only
    if int(reports["main"][3]) and len(os.sched_getaffinity(0)) > 1:  # Linux, more than one core: OpenBLAS's threads
        assert int(reports["run"][3]) < int(reports["main"][3])  # are not started in the program
    assert int(reports["run"][0]) > 50_000  # NumPy's, SciPy's and scikit-image's objects, kept out of collections
    assert int(reports["main"][0]) == 0  # a program calling main() keeps its own objects collectable
    assert reports["run"][4] == "False" and reports["main"][4] == "True"  # NumPy's tools loaded only where used
    names = sorted(p.name for p in (tmp_path / "run").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "main").iterdir()) and len(names) >= 5
    for name in names:
        assert (tmp_path / "run" / name).read_bytes() == (tmp_path / "main" / name).read_bytes(), name


def test_numpy_tools_deferred_by_the_program_still_work_when_used():
    # As in the tamp-os program: SciPy imported while NumPy's tool submodules are deferred, then each used.
    code = """
import sys
from tamp_os.cli import commands
commands._ONE_COMMAND = True
with commands._loading():
    import scipy.ndimage
import numpy as np
print(sorted(m for m in sys.modules if m.startswith(("numpy.f2py.", "numpy.testing._private"))))
from numpy.testing import assert_array_equal
assert_array_equal(np.arange(3), [0, 1, 2])
np.testing.assert_allclose(np.polynomial.Polynomial([1, 2])(2.0), 5.0)
print(np.char.upper(["ab"])[0], np.rec.fromarrays([[1, 2]], names="x").x.sum(), np.strings.lower("AB"), callable(np.f2py.run_main))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["[]", "AB 3 ab True"]


@pytest.mark.parametrize("variable", ["OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS"])
def test_program_keeps_the_users_openblas_threads(variable):
    env = {k: v for k, v in os.environ.items() if k not in OPENBLAS_THREAD_VARIABLES}
    done = subprocess.run([sys.executable, "-c", ENTRY, "run", "--version"], capture_output=True, text=True, timeout=120,
                          env={**env, variable: "2"})
    # OpenBLAS reads the older two only when its own is unset: the program leaves it unset then
    expected = "2" if variable == "OPENBLAS_NUM_THREADS" else "None"
    assert done.returncode == 0 and done.stdout.splitlines()[-1].split()[3] == expected, done.stdout + done.stderr


def test_program_exit_code_and_messages_survive_the_quick_exit(tmp_path):
    done = subprocess.run([sys.executable, "-m", "tamp_os.cli", "convert", str(tmp_path / "missing.png"), "-o", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and done.stderr.startswith("error: ") and "missing.png" in done.stderr, done.stderr


def test_convert_prints_one_plain_line_per_file(tmp_path, image, capsys):
    code = main(["convert", str(image), "-o", str(tmp_path / "out"), "--formats", "stl,3mf,glb,obj,ply", "--preset", "low"])
    out = capsys.readouterr().out.strip().splitlines()
    assert code == 0 and len(out) == 1
    assert out[0].startswith("ramp.png: 100 × 75 × 4 mm, grid 125 × 94,")
    assert "up to 25 levels" in out[0] and "wrote ramp.{stl,3mf,glb,obj,ply}, its description and recipe" in out[0]
    assert len(out[0]) <= 160  # a result line a screen reader reads at once (issue 24.5); details with --verbose
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["ramp.3mf", "ramp.description.txt", "ramp.glb", "ramp.obj", "ramp.ply", "ramp.stl", "ramp.tamp.json"]
    assert not any(ch in out[0] for ch in "\x1b\r")  # no terminal control codes for screen readers


def test_recipe_rebuilds_byte_for_byte(tmp_path, image, capsys):
    first, second = tmp_path / "a", tmp_path / "b"
    assert main(["convert", str(image), "-o", str(first), "--formats", "stl,3mf,glb,step", "--relief-mm", "2.2", "--invert",
                 "--caption", "Ramp", "--pixel-size", "2um"]) == 0
    recipe = json.loads((first / "ramp.tamp.json").read_text(encoding="utf-8"))
    assert recipe["params"]["relief_mm"] == 2.2 and recipe["params"]["invert"] is True
    assert len(recipe["input"]["sha256"]) == 64 and "numpy" in recipe["versions"]
    assert main(["convert", "--recipe", str(first / "ramp.tamp.json"), "-o", str(second)]) == 0
    for name in ("ramp.stl", "ramp.3mf", "ramp.glb", "ramp.step", "ramp.description.txt", "ramp.tamp.json"):
        assert (first / name).read_bytes() == (second / name).read_bytes(), name
    image.write_bytes(image.read_bytes() + b"changed")
    assert main(["convert", "--recipe", str(first / "ramp.tamp.json"), "-o", str(second)]) == 1  # a bad input file is exit 1; 2 is for usage errors only
    assert "has changed" in capsys.readouterr().err


def test_presets_table_and_suggestion(image, capsys):
    assert main(["presets", str(image), "--formats", "stl,3mf,glb"]) == 0
    out = capsys.readouterr().out
    assert "height levels: 25" in out
    for line in ("Low: grid 125 × 94", "Medium: grid 250 × 188", "High: grid 500 × 375"):
        assert line in out
    assert "STL" in out and "3MF" in out and "GLB" in out
    assert "suggested for ramp.png:" in out


def test_user_printer_profiles_from_toml(tmp_path, image, capsys, monkeypatch):
    toml = tmp_path / "printers.toml"
    toml.write_text('[bigbox]\nnozzle_mm = 0.8\nlayer_mm = 0.3\nwidth_mm = 160\n')
    monkeypatch.setenv("TAMP_PRINTERS", str(toml))
    assert main(["presets", "--printer", "bigbox"]) == 0
    out = capsys.readouterr().out
    assert "Medium: grid 200 × 150" in out and "height levels: 10" in out
    toml.write_text("[broken]\nnozzle_mm = 'wide'\n")
    assert main(["presets", "--printer", "broken"]) == 2
    assert "nozzle_mm" in capsys.readouterr().err


def test_info_json(fixture, capsys):
    assert main(["info", "--json", str(fixture("FEI-Helios-Ebeam-16bits.tif"))]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert facts["width_px"] == 512 and facts["height_px"] == 471 and facts["bit_depth"] == 16
    assert "fei_metadata" in facts["metadata_found"]
    assert main(["info", str(fixture("fept_spheres_sem.png"))]) == 0
    assert "JPEG, 1024 × 768 pixels, 8-bit uint8, 3 channels" in capsys.readouterr().out


def test_usage_errors_exit_2(capsys):
    assert main(["convert"]) == 2
    assert main(["frobnicate"]) == 2
    assert main(["convert", "x.png", "--relief-mm", "lots"]) == 2


def test_debug_shows_traceback(tmp_path):
    bad = tmp_path / "bad.png"
    bad.write_text("nope")
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-m", "tamp_os.cli.commands", "--debug", "convert", str(bad), "-o", str(tmp_path)], capture_output=True, text=True, env=env)
    assert out.returncode != 0 and "Traceback" in out.stderr


@settings(max_examples=examples(50), deadline=None)
@given(
    relief=st.floats(0.01, 50), base=st.floats(0.01, 50), invert=st.booleans(),
    formats=st.lists(st.sampled_from(["stl", "3mf", "glb", "obj", "ply"]), min_size=1, unique=True),
    blur=st.one_of(st.none(), st.floats(0, 100)), width=st.one_of(st.none(), st.floats(5, 1000)),
)
def test_params_json_round_trip(relief, base, invert, formats, blur, width):
    p = LithoParams(relief_mm=relief, base_mm=base, invert=invert, formats=tuple(formats), blur_px=blur, width_mm=width)
    assert LithoParams.from_json(p.to_json()) == p


@given(st.floats(allow_nan=True, allow_infinity=True).filter(lambda v: not (0 < v <= 50)))
def test_relief_outside_range_is_refused_with_range_and_value(value):
    with pytest.raises(ParameterError, match=r"relief_mm: must be"):
        LithoParams(relief_mm=value)


def test_presets_count_the_triangles_of_the_mesher_in_use(image, capsys):
    from tamp_os import make_lithograph

    assert main(["presets", str(image)]) == 0
    out = capsys.readouterr().out
    medium = make_lithograph(image, preset="medium")
    assert f"{medium.mesh.n_triangles:,} triangles" in out and "mesher adaptive" in out
    assert main(["presets", str(image), "--mesher", "grid"]) == 0
    grid = make_lithograph(image, preset="medium", mesher="grid")
    assert f"{grid.mesh.n_triangles:,} triangles" in capsys.readouterr().out


def test_parse_field_types_text_for_every_kind_of_field():
    from tamp_os.params import parse_field

    assert parse_field("relief_mm", " 2.5 ") == 2.5
    assert parse_field("resolution_px", "128") == 128
    assert parse_field("invert", "Yes") is True and parse_field("flip_x", "off") is False
    assert parse_field("formats", "STL, .3mf") == ("stl", "3mf")
    assert parse_field("caption", "FePt spheres") == "FePt spheres"
    for name, text, needle in (("resolution_px", "1.5", "whole number"), ("invert", "maybe", "true or false"),
                               ("relief_mm", "lots", "relief_mm: must be a number"), ("nosuch", "1", "unknown parameter")):
        with pytest.raises(ParameterError, match=needle):
            parse_field(name, text)


def test_every_command_answers_help(capsys):
    from tamp_os.cli.commands import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    for name in [None, *commands]:
        assert main(["--help"] if name is None else [name, "--help"]) == 0, name
        assert "usage: tamp-os" in capsys.readouterr().out, name


def test_batch_says_which_inputs_became_a_flat_plate(tmp_path, capsys):
    # the progress line said only "converted (0.5 s)" for a uniform picture (the FEI Helios fixtures):
    # that the print is a flat plate was only in the CSV
    import numpy as np

    src = tmp_path / "in"
    src.mkdir()
    Image.fromarray(np.full((40, 50), 128, np.uint8)).save(src / "blank.png")
    ramp = np.tile(np.linspace(0, 255, 50, dtype=np.uint8), (40, 1))
    Image.fromarray(ramp).save(src / "ramp.png")
    code = main(["batch", str(src), "-o", str(tmp_path / "out"), "--preset", "low", "--workers", "1"])
    out = capsys.readouterr().out.splitlines()
    assert code == 0
    blank = [line for line in out if "blank.png" in line]
    ramp_lines = [line for line in out if "ramp.png" in line]
    assert blank and "flat plate" in blank[0], out
    assert ramp_lines and "flat plate" not in ramp_lines[0], out


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ["real/zeiss_dapi_gfp_2ch.czi", "real/nikon_pbmc_4ch.nd2"])
def test_info_says_what_convert_does_with_the_channels(fixture, capsys, name):
    """Issue 33.1: info on a multi-channel file names the channels convert prints and how (its key),
    not "using channel 0"; the same as the key convert's print carries."""
    from conftest import need
    from tamp_os.lithograph.pipeline import make_lithograph
    from tamp_os.tactile.braille import liblouis_available

    need(liblouis_available(), "liblouis (braille key)")
    assert main(["info", str(fixture(name))]) == 0
    out = capsys.readouterr().out
    assert "using channel 0" not in out, out
    key = make_lithograph(fixture(name)).report.key
    line = next(row for row in out.splitlines() if row.startswith("convert: prints"))
    assert f"prints {len(key)} channels as textures" in line and "--channels off" in line, line
    for entry in key:
        assert entry.label in line, (entry.label, line)
    assert main(["info", str(fixture(name)), "--json"]) == 0
    facts = json.loads(capsys.readouterr().out)
    assert [k["label"] for k in facts["convert_channels"]["key"]] == [e.label for e in key]
    # one channel asked for: info says what the reader does with it, and convert prints that channel
    assert main(["info", str(fixture(name)), "--channel", "1"]) == 0
    assert "convert: prints" not in capsys.readouterr().out


@pytest.mark.timeout(120)
def test_aperio_slide_edge_is_no_arrow(fixture, capsys):
    """Issue 33.10: the flat glass rows at the Aperio slide's bottom edge are no arrow burnt into its
    red channel; info (which says what convert will do with the channels) names no mark removed."""
    assert main(["info", str(fixture("real/aperio_cmu1_he_skin.svs"))]) == 0
    out = capsys.readouterr().out
    assert "stained brightfield" in out and "arrow" not in out and "Removed from the channel" not in out, out


@pytest.mark.timeout(180)
def test_touching_members_are_counted_once_in_the_description(fixture, tmp_path, capsys):
    """Issue 33.10: a population whose touching members the layout groups (36 groups of 83 particles)
    says one count in its description: no 'N raised groups' beside 'Found M members'."""
    import re

    from tamp_os.lithograph.pipeline import make_lithograph

    path = fixture("real/sem_fei_sio2_particles_35kx.tif")
    report = make_lithograph(path).report
    members = report.legibility.object_count
    assert report.content_kind == "members" and 0 < len(report.layout.pieces) < members  # the grouped case
    assert main(["convert", str(path), "-o", str(tmp_path), "--formats", "stl"]) == 0
    text = (tmp_path / "sem_fei_sio2_particles_35kx.description.txt").read_text()
    counts = {int(n) for n in re.findall(r"(\d+) (?:members|domes|raised groups|raised shapes|groups)\b", text)}
    assert counts == {members}, text
    spelled = re.findall(r"\b(?:[A-Z][a-z]+|[a-z]+-[a-z]+) (?:raised groups|domes|raised shapes) stand", text)
    assert not spelled, spelled


@pytest.mark.timeout(120)
def test_an_option_that_does_not_fit_the_file_fails_the_file_in_info_as_in_convert(fixture, tmp_path, capsys):
    """Issue 33.8: one exit-code rule everywhere (docs/command-line.md): a channel the file does not
    have fails that input (1) in info and convert alike; a malformed value is a usage error (2)."""
    czi = str(fixture("real/zeiss_dapi_gfp_2ch.czi"))
    assert main(["info", czi, "--channel", "7"]) == 1
    info_err = capsys.readouterr().err
    assert main(["convert", czi, "--channel", "7", "-o", str(tmp_path)]) == 1
    convert_err = capsys.readouterr().err
    assert "--channel must be 0–1 (DAPI, GFP); got 7" in info_err and info_err == convert_err
    assert main(["info", czi, "--pixel-size", "not-a-length"]) == 2


@pytest.mark.timeout(120)
def test_program_started_with_its_output_closed_exits_as_python_does(tmp_path):
    # `tamp-os --version >&-`: Python gives the program no sys.stdout (None); print() then writes
    # nothing and Python's exit skips the stream, so the quick exit must too (not a traceback).
    for entry in ("run", "main"):
        done = subprocess.run([sys.executable, "-c", ENTRY, entry, "--version"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE, text=True, timeout=120, close_fds=True,
                              preexec_fn=lambda: os.close(1))
        assert done.returncode == 0 and "Traceback" not in done.stderr, (entry, done.stderr)


@pytest.mark.timeout(120)
@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux) for an output that fails")
@pytest.mark.parametrize("buffered", [True, False])
def test_program_whose_output_fails_says_so_in_one_line(buffered):
    # A full disk behind `>`: buffered, the line fails at the exit's flush; unbuffered, at print().
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    env.update({} if buffered else {"PYTHONUNBUFFERED": "1"})
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "tamp_os.cli", "--version"], stdout=full, stderr=subprocess.PIPE,
                              text=True, timeout=120, env=env)
    lines = done.stderr.splitlines()
    assert done.returncode in (1, 120) and "Traceback" not in done.stderr, done.stderr
    assert len(lines) == 1 and lines[0].startswith("error: ") and "No space left on device" in lines[0], done.stderr


@pytest.mark.timeout(120)
@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux) for an output that fails")
@pytest.mark.parametrize("buffered", [True, False])
@pytest.mark.parametrize("asked", [["--help"], ["convert", "--help"]])
def test_help_whose_output_fails_says_so_in_one_line_and_does_not_exit_0(asked, buffered):
    # `tamp-os --help > /dev/full` as `--version > /dev/full`: the help was not written, so one
    # error line and an exit status that says so (argparse swallows the failed write itself).
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    env.update({} if buffered else {"PYTHONUNBUFFERED": "1"})
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "tamp_os.cli", *asked], stdout=full, stderr=subprocess.PIPE,
                              text=True, timeout=120, env=env)
    lines = done.stderr.splitlines()
    assert done.returncode != 0 and "Traceback" not in done.stderr, (done.returncode, done.stderr)
    assert len(lines) == 1 and lines[0].startswith("error: ") and "No space left on device" in lines[0], done.stderr


@pytest.mark.timeout(120)
def test_help_piped_into_a_program_that_stopped_reading_exits_0_quietly():
    # `tamp-os convert --help | head -0`: as a command's output into a closed pipe (| head), not an error
    proc = subprocess.Popen([sys.executable, "-m", "tamp_os.cli", "convert", "--help"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before the help (17 KB, more than a pipe's buffer) is written
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0 and err == b"", err


def _processes_naming(marker: str) -> list[int]:
    """Ids of the live processes whose command line holds `marker` (Linux /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{entry}/cmdline", "rb") as fh:
                if marker.encode() in fh.read():
                    found.append(int(entry))
        except (OSError, ValueError):
            continue
    return found


@pytest.mark.slow
@pytest.mark.timeout(240)
def test_program_batch_on_two_workers_reports_every_file_and_leaves_no_worker(tmp_path):
    # The program's quick exit with a pool of worker processes: every input in the report and the
    # last line, the exit code of a failed file, no worker process and no temporary file left.
    need(os.path.isdir("/proc/self"), "/proc (to find worker processes)")
    folder, out, temp = tmp_path / "in", tmp_path / "out-batch-marker", tmp_path / "tmp"
    folder.mkdir()
    temp.mkdir()
    yy, xx = np.mgrid[0:48, 0:64]
    for i in range(3):
        Image.fromarray(((np.sin(xx / (4 + i)) + 1) * 100 + yy).astype(np.uint8)).save(folder / f"good{i}.png")
    (folder / "bad.png").write_bytes(b"not an image")
    done = subprocess.run([sys.executable, "-m", "tamp_os.cli", "batch", str(folder), "-o", str(out), "--workers", "2",
                           "--preset", "low", "--formats", "stl,3mf"], capture_output=True, text=True, timeout=200,
                          env={**os.environ, "TMPDIR": str(temp)})
    assert done.returncode == 1, done.stdout + done.stderr
    lines = done.stdout.splitlines()
    assert lines[-1].startswith("batch: 3 converted, 0 already up to date, 1 failed"), lines
    assert sorted(line.split()[3] for line in lines[:-1] if " of 4: " in line) == ["bad.png", "good0.png", "good1.png", "good2.png"]
    report = json.loads((out / "batch-report.json").read_text(encoding="utf-8"))
    assert sorted(r["status"] for r in report) == ["converted"] * 3 + ["failed"]
    assert len(list(out.glob("*.3mf"))) == 3 and not list(out.glob(".*.part"))
    assert _processes_naming(str(out)) == [] and list(temp.iterdir()) == []
