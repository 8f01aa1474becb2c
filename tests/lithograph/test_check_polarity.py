"""Issue 53, the check's first verdict: `tamp-os check` and the summary of every conversion say in
one plain line, with the option that changes it, "raised parts darker than their ground (possibly
inverted)" when the source is darker under the raised parts than under the ground, against the
side the picture shows as matter (its modality, else its members' shape, else an empty bright
ground, else bright). A deliberately inverted print of a synthetic backscatter field (exact truth)
is flagged; the print made the right way round is not."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from conftest import need, run_cli
from synthetic_content import bse_blood_cells, with_data_band
from tamp_os.clean import ocr
from tamp_os.lithograph.pipeline import make_lithograph
from tamp_os.relief.agreement import INVERTED_WORDS

LINE = f"Raised parts darker than their ground ({INVERTED_WORDS})"


def _cells_png(tmp_path, image: np.ndarray, name: str = "cells.png"):
    path = tmp_path / name
    Image.fromarray((np.clip(image, 0, 1) * 255).astype(np.uint8)).save(path)
    return path


def _cell_lift_mm(litho, members: np.ndarray) -> float:
    h = litho.heightmap
    rows = np.linspace(0, members.shape[0] - 1, h.shape[0]).round().astype(int)
    cols = np.linspace(0, members.shape[1] - 1, h.shape[1]).round().astype(int)
    cells = members[rows][:, cols] > 0
    return float(np.median(h[cells]) - np.median(h[~cells]))


@pytest.mark.timeout(240)
def test_an_inverted_print_of_backscatter_cells_is_flagged_and_the_right_one_is_not():
    t = bse_blood_cells()
    right = make_lithograph(t.image, width_mm=100, scale_bar="off")
    wrong = make_lithograph(t.image, width_mm=100, scale_bar="off", relief_style="structure", invert=True)
    assert _cell_lift_mm(right, t.members) >= 0.5 and _cell_lift_mm(wrong, t.members) < 0  # the truth: one right, one inverted
    assert not right.report.check_flags, right.report.check_flags
    flags = [f for f in wrong.report.check_flags if INVERTED_WORDS in f]
    assert len(flags) == 1 and flags[0].startswith(LINE), wrong.report.check_flags
    # why the bright side is matter (no detector named: the cells' shape), and the one option that turns it over
    assert "compact and convex" in flags[0] and "`invert` off" in flags[0].template, flags[0]
    assert "\n" not in flags[0]
    assert flags[0] in wrong.report.legibility.verdicts  # `tamp-os check` prints the verdicts
    assert wrong.report.as_dict()["check_flags"] == [str(flags[0])] and "check_flags" not in right.report.as_dict()


@pytest.mark.timeout(240)
def test_with_bsd_in_the_band_the_modality_says_why(tmp_path):
    need(ocr.backend() is not None, "OCR (tesserocr with the eng model, or the tesseract command)")
    t = bse_blood_cells()
    image = with_data_band(t.image, "BSD Full  10 kV  x2000  WD 8 mm")
    wrong = make_lithograph(image, width_mm=100, scale_bar="off", relief_style="structure", invert=True)
    flags = [f for f in wrong.report.check_flags if INVERTED_WORDS in f]
    assert len(flags) == 1 and "backscattered-electron image bright is matter" in flags[0], wrong.report.check_flags


@pytest.mark.timeout(300)
def test_check_and_convert_say_it_on_the_command_line(capsys, tmp_path):
    t = bse_blood_cells()
    path = _cells_png(tmp_path, t.image)
    code, out, _ = run_cli(capsys, "check", path, "--relief-style", "structure", "--invert", "--scale-bar", "off")
    assert code == 0 and LINE in out and "--invert off" in out, out
    code, out, _ = run_cli(capsys, "check", path, "--scale-bar", "off")
    assert code == 0 and INVERTED_WORDS not in out, out
    code, out, _ = run_cli(capsys, "convert", path, "-o", tmp_path / "out", "--relief-style", "structure", "--invert",
                           "--scale-bar", "off", "--formats", "stl")
    lines = out.splitlines()
    assert code == 0, out
    said = [line for line in lines if line.startswith("  check: ")]
    assert len(said) == 1 and LINE in said[0] and "--invert off" in said[0], out
