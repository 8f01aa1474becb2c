"""The report's words: the line the terminal prints and the web app's lines."""

from __future__ import annotations

import dataclasses

import numpy as np

from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.lithograph.report import summary_line, web_summary_lines


def test_the_summary_line_says_the_print_size_to_a_tenth_of_a_millimetre():
    # the SiO2 35kx print was "116 × 92.478 × 4 mm" on the terminal and "92.5 mm deep" in its description
    litho = make_lithograph(np.eye(40, 56, dtype=np.float32), width_mm=100, relief_style="reference")
    report = dataclasses.replace(litho.report, print_mm=[116.0, 92.478, 4.0])
    line = summary_line(report, ["x.stl"])
    assert "116 × 92.5 × 4 mm" in line and "92.478" not in line, line
    assert web_summary_lines(report)[0].startswith("Print 116 × 92.5 mm, up to 4 mm high"), web_summary_lines(report)[0]
