"""`tamp-os convert --help` as a screen reader user meets it: each heading once, its options under
it, each option's default said once (issue 54)."""

import collections
import os
import re
import subprocess
import sys

import pytest

from tamp_os.params import SECTIONS


def convert_help() -> str:
    done = subprocess.run([sys.executable, "-m", "tamp_os.cli", "convert", "--help"], capture_output=True,
                          text=True, timeout=120, env={**os.environ, "COLUMNS": "80"})
    assert done.returncode == 0 and done.stderr == "", done.stderr
    return done.stdout


def headings(text: str) -> list[str]:
    """argparse's group headings: a line of its own at the margin, ending in a colon."""
    return [line for line in text.splitlines() if re.fullmatch(r"\S.*:", line)]


def option_helps(text: str) -> dict[str, str]:
    """Each option's help, its wrapped lines joined: '--width-mm' -> 'print width (...)'."""
    helps: dict[str, list[str]] = {}
    current = None
    body = text.split("\n\n", 2)[-1]  # past the usage (it names every option) and the description
    for line in body.splitlines():
        start = re.match(r"  (-{1,2}[\w-]+)(?:[ ,]\S+)*(?:\s{2,}(.*))?$", line)
        if start:
            current = start.group(1)
            helps[current] = [start.group(2) or ""]
        elif current and line.startswith(" " * 10):
            helps[current].append(line.strip())
        else:
            current = None
    return {option: " ".join(" ".join(parts).split()) for option, parts in helps.items()}


@pytest.mark.timeout(120)
def test_convert_help_says_each_heading_once_with_its_options_under_it():
    text = convert_help()
    found = headings(text)
    counts = collections.Counter(found)
    assert all(n == 1 for n in counts.values()), [h for h, n in counts.items() if n > 1]
    assert len(found) < 20, found
    # every stage of the parameters is one heading, in the pipeline's order
    stages = [h for h in found if h.startswith("parameters: ")]
    assert stages == [f"parameters: {title}:" for title, _ in SECTIONS]
    # and the option lines under a heading are that stage's options
    sections = re.split(r"^(parameters: .*):$", text, flags=re.M)[1:]
    under = dict(zip(sections[::2], sections[1::2]))
    assert "--nozzle-mm" in under["parameters: printer and size"] and "--nozzle-mm" not in under["parameters: volumes"]
    assert "--sections" in under["parameters: volumes"]
    # each format's sentence from the format table, one a line under the outputs heading
    from tamp_os.formats import TABLE

    outputs = " ".join(under["parameters: outputs"].split())
    for f in TABLE:
        assert f"{f.name}: {f.purpose}" in outputs, f.name
    assert "--formats" in outputs and "--formats" not in under["parameters: volumes"]
    assert len(text.splitlines()) < 300


@pytest.mark.timeout(120)
def test_no_option_of_convert_says_its_default_twice():
    helps = option_helps(convert_help())
    assert {"--width-mm", "--preset", "--formats", "--volume", "--invert"} <= set(helps), sorted(helps)
    twice = {option: text for option, text in helps.items() if len(re.findall(r"\bdefault\b", text)) > 1}
    assert not twice, twice
    # an option that takes a value says its default once: given by the parameter's words or added
    for option in ("--width-mm", "--preset", "--relief-mm", "--caption", "--formats", "--nozzle-mm"):
        assert len(re.findall(r"\bdefault\b", helps[option])) == 1, (option, helps[option])
    # a choice the words already name is not listed again ("low, medium or high (one of low, medium, high")
    assert "one of" not in helps["--preset"], helps["--preset"]
    assert "(any" not in helps["--printer"], helps["--printer"]


@pytest.mark.timeout(60)
def test_option_help_says_what_the_words_leave_out():
    """Checked without a child process: the pieces option_help adds and leaves out."""
    import dataclasses

    from tamp_os.cli.commands import option_help
    from tamp_os.params import LithoParams

    fields = {f.name: f for f in dataclasses.fields(LithoParams)}
    assert option_help(fields["relief_mm"]).endswith("(> 0.0 and ≤ 50.0 mm; default: 3.0)")
    assert option_help(fields["nozzle_mm"]) == "nozzle diameter (default: from the printer) (≥ 0.05 and ≤ 2.0 mm)"
    assert option_help(fields["orientation_corner"]).endswith("or none (default: cut)")
    assert "%%" in option_help(fields["stretch_low_pct"])  # argparse would read a bare % as a format
