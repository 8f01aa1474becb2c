"""The README and docs/ stay true: the first conversion runs as written, the Python example runs,
every option and command they name exists, and every link between them leads somewhere."""

import re
import shlex
import subprocess
import sys

import pytest

from conftest import ROOT

from tamp_os.cli.commands import build_parser

DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def sh_blocks(path) -> list[str]:
    return re.findall(r"```sh\n(.*?)```", path.read_text(encoding="utf-8"), re.S)


def test_python_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    assert (tmp_path / "readme-output" / "array.stl").is_file()
    assert namespace["litho"].params.relief_mm == 2.5


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_first_conversion_runs_as_written(tmp_path):
    """The README's first conversion, its recipe rebuild, presets and check, run as a user types them."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    first = next(b for b in sh_blocks(ROOT / "README.md") if "tamp-os convert" in b)
    commands = [line for line in first.splitlines() if line.strip()]
    commands += re.findall(r"`(\.venv/bin/tamp-os (?:convert --recipe|presets|check) [^`]+)`", text)
    assert len(commands) == 5, commands
    (tmp_path / ".venv").symlink_to(ROOT / ".venv" if (ROOT / ".venv").is_dir() else sys.prefix)
    outputs = []
    for command in commands:
        done = subprocess.run(shlex.split(command), cwd=tmp_path, capture_output=True, text=True, timeout=240)
        assert done.returncode == 0, (command, done.stdout, done.stderr)
        assert "Traceback" not in done.stderr
        outputs.append(done.stdout)
    # The line the README shows is the line printed; the files its table explains are the files
    # written; the recipe rebuilds the print byte for byte.
    assert outputs[1].strip() == re.search(r"```\n(cell\.png: .*)\n```", text).group(1)
    table = re.findall(r"^\| `(cell\.[\w.]+)` \|", text, re.M)
    assert sorted(table) == sorted(p.name for p in (tmp_path / "first").iterdir())
    assert (tmp_path / "again" / "cell.stl").read_bytes() == (tmp_path / "first" / "cell.stl").read_bytes()


def script_options() -> set[str]:
    """The options the benchmarks and scripts declare (argparse's add_argument)."""
    texts = [p.read_text(encoding="utf-8") for d in ("benchmarks", "scripts") for p in (ROOT / d).glob("*.py")]
    return {o for t in texts for o in re.findall(r"add_argument\(\s*\"(--[a-z][a-z-]*)\"", t)}


def test_every_option_and_command_in_the_docs_exists():
    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command").choices
    known = {opt for sub in [parser, *subparsers.values()] for a in sub._actions for opt in a.option_strings}
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        used = set(re.findall(r"(?<![\w-])(--[a-z][a-z-]+)", text))
        # the benchmarks' and scripts' own options (bench_*.py, check_identical.py); --config is lint-imports',
        # --upgrade uv's (make lock LOCK_ARGS=--upgrade)
        assert used <= known | script_options() | {"--config", "--upgrade"}, (path.name, used - known)
        commands = re.findall(r"(?:bin/|`)tamp-os ([a-z][\w-]*)", text)
        assert set(commands) <= set(subparsers), (path.name, commands)


def test_links_between_the_docs_lead_somewhere():
    for path in DOCS:
        for target in re.findall(r"\]\(((?!https?:)[^)#]+)", path.read_text(encoding="utf-8")):
            assert (path.parent / target).exists(), (path.name, target)


def test_the_readme_is_one_screen_and_points_to_every_doc():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 160
    for doc in sorted((ROOT / "docs").glob("*.md")):
        assert f"(docs/{doc.name})" in text, doc.name


@pytest.mark.timeout(60)
def test_the_readme_names_every_format_with_the_tables_sentence():
    """The README's table of formats is the format table: each format, its file and its one
    sentence, in order (issue 54: pin displays, eBraille and the tour were never named)."""
    from tamp_os.formats import TABLE

    text = (ROOT / "README.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([\w]+)` \| `NAME([\w.]+)` \| (.*) \|$", text, re.M)
    assert rows == [(f.name, f.suffix, f.purpose) for f in TABLE]
    for words in ("Dot Pad", "Graphiti", "Monarch", "eBraille", "touch tour", "`--volume`", "`--sections N`", "Resin printers"):
        assert words in text, words
