"""Every `tamp-os` command the README and docs/ show runs as written: each is taken from the text,
its placeholders (IMAGE, STACK, PICTURES/ …) filled with small real inputs, and run through the
command line in a folder of its own; it must exit 0 without a traceback."""

import re
import shlex
import shutil

import numpy as np
import pytest
import tifffile
from PIL import Image

from conftest import FIXTURES, ROOT, need, run_cli
from test_readme import DOCS

# What a placeholder in the docs stands for: a file the test makes (see `inputs`).
PLACEHOLDERS = {
    "IMAGE": "cell.png",
    "IMAGE...": "cell.png",
    "STACK": "beads.tif",
    "PICTURES/": "pictures/",
    "IMAGE_OR_MESH...": "cell.png",
    "MESH...": "first/cell.stl",
    "OUT/": "out/",
    "DIR": "again/",
    "OUT/NAME.tamp.json": "first/cell.tamp.json",
}
# A command named on its own (`tamp-os check`), or with an option only (`tamp-os estimate
# --material`), refers to the command: its help must work.
# `gui` starts a server that runs until stopped: only its help is run here (tests/gui start it).
HELP_ONLY = {"gui"}


def doc_commands() -> list[str]:
    """The `tamp-os …` command lines of the docs, in inline code and in sh blocks, without the
    synopsis lines (those with [optional] parts)."""
    found = []
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        inline = re.findall(r"`((?:\.venv/bin/)?tamp-os [^`]+)`", text)
        blocks = [line.split("#")[0].strip() for block in re.findall(r"```sh\n(.*?)```", text, re.S)
                  for line in block.splitlines() if re.match(r"\s*(\.venv/bin/)?tamp-os ", line)]
        found += [c for c in inline + blocks if "[" not in c]
    return sorted(set(found))


def expand(command: str) -> list[list[str]]:
    """The argument lists one documented command stands for: `a|b|c` alternatives each, a
    placeholder filled, `COMMAND` each subcommand, a bare command its --help."""
    from tamp_os.cli.commands import build_parser

    words = shlex.split(command)[1:]
    subcommands = next(a for a in build_parser()._actions if a.dest == "command").choices
    if words[0] == "COMMAND":
        return [[name, *words[1:]] for name in subcommands]
    if words[0] in HELP_ONLY or all(w.startswith("--") for w in words[1:]):
        return [[words[0], "--help"]]
    for i, word in enumerate(words):
        if "|" in word:
            return [args for choice in word.split("|") for args in expand(" ".join(["tamp-os", *words[:i], choice, *words[i + 1:]]))]
    filled = [PLACEHOLDERS.get(w, w) for w in words]
    unknown = [w for w in filled if re.search(r"\b[A-Z]{3,}\b", w) and not w.startswith("-")]
    assert not unknown, f"{command!r}: add a test input for {unknown} to PLACEHOLDERS"
    return [filled]


def inputs(folder) -> None:
    """The files the documented commands name, small enough to convert in a second or two."""
    from skimage import data

    Image.fromarray(data.cell()[::2, ::2]).save(folder / "cell.png")
    shutil.copy(FIXTURES / "fept_spheres_sem.png", folder)
    (folder / "pictures").mkdir()
    Image.fromarray(data.camera()[::4, ::4]).save(folder / "pictures" / "camera.png")
    # A z-stack of two beads with its voxel size, as ImageJ writes it.
    z, y, x = np.mgrid[:12, :40, :40]
    beads = ((x - 13) ** 2 + (y - 20) ** 2 + ((z - 6) * 2) ** 2 < 64) | ((x - 28) ** 2 + (y - 20) ** 2 + ((z - 6) * 2) ** 2 < 49)
    tifffile.imwrite(folder / "beads.tif", (beads * 200 + 10).astype(np.uint8), imagej=True,
                     resolution=(1 / 0.2, 1 / 0.2), metadata={"spacing": 0.4, "unit": "um", "axes": "ZYX"})


def test_the_docs_show_commands():
    commands = doc_commands()
    assert any(c.split()[1] == "convert" for c in commands), commands
    assert not [c for c in commands if c.split()[0] not in ("tamp-os", ".venv/bin/tamp-os")]


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_every_command_in_the_docs_runs(tmp_path, monkeypatch, capsys):
    need(FIXTURES.is_dir(), "the shared fixtures (../shared/fixtures)")
    inputs(tmp_path)
    monkeypatch.chdir(tmp_path)
    runs = [args for command in doc_commands() for args in expand(command)]
    # The first conversion first: later commands (check, a recipe) read what it wrote.
    runs.sort(key=lambda args: args[:2] != ["convert", "cell.png"])
    for args in runs:
        if "--gcode" in args or args[0] == "slice":
            need(shutil.which("prusa-slicer") is not None, "PrusaSlicer")
        try:
            code, out, err = run_cli(capsys, *args)
        except SystemExit as stop:  # --help exits through argparse
            code, err = stop.code, capsys.readouterr().err
        assert code == 0, (args, err[-2000:])
        assert "Traceback" not in err, (args, err)
