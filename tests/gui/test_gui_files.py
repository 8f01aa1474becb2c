"""What the web app says each file is for (the results page and the zip's README.txt): every
format's own sentence from the format table, and the pin displays' side files their own (issue 54)."""

from __future__ import annotations

import re

import pytest

from tamp_os.formats import TABLE
from tamp_os.gui.jobs import file_purpose, readme_text


@pytest.mark.timeout(60)
def test_every_format_is_described_by_its_sentence_in_the_table():
    names = [f"cells{f.suffix}" for f in TABLE]
    text = readme_text(names)
    for f, name in zip(TABLE, names):
        said = f.purpose[0].lower() + f.purpose[1:]
        assert re.search(rf"^{re.escape(name)}: {re.escape(said)}$", text, re.M), (name, text)
    assert "an output of TAMP-OS" not in text


@pytest.mark.timeout(60)
def test_a_pin_displays_side_files_are_not_called_swell_paper():
    # NAME.monarch-2.svg ends in .svg and NAME.graphiti-1.png in .png: neither is a swell-paper graphic
    assert file_purpose("cells.monarch-2.svg").startswith("for the Monarch pin display: page 2")
    assert file_purpose("cells.graphiti-1.png").startswith("page 1 of the Graphiti file")
    for fmt in ("dotpad", "graphiti", "monarch"):
        assert "pin display" in file_purpose(f"cells.{fmt}-simulator.png")
    assert file_purpose("cells.svg").startswith("for swell paper")
    assert file_purpose("cells.monarch.svg").startswith("for the Monarch pin display")
    assert file_purpose("cells.base.stl").startswith("two-colour print")
    assert file_purpose("cells.unknown") == "an output of TAMP-OS"
