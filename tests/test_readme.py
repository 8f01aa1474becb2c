"""The README stays true: its Python example runs and its commands exist."""

import re

from conftest import ROOT

from tamp_os.cli.commands import build_parser


def test_python_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    assert (tmp_path / "readme-output" / "array.stl").is_file()
    assert namespace["litho"].params.relief_mm == 2.5


def test_every_option_in_the_readme_exists():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    parser = build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command").choices
    known = {opt for sub in [parser, *subparsers.values()] for a in sub._actions for opt in a.option_strings}
    used = set(re.findall(r"(?<![\w-])(--[a-z][a-z-]+)", text))
    assert used <= known | {"--slice"}, used - known  # --slice belongs to bench_adaptive.py
    commands = re.findall(r"(?:bin/|`)tamp-os ([a-z][\w-]*)", text)
    assert commands and set(commands) <= set(subparsers), commands
