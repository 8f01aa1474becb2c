"""Issue 33.5: a square label box holding a panel letter is no scale bar, so a figure's panels are
not warned that "a scale bar was found, but its label did not read cleanly"."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image, ImageDraw

from figures import font
from tamp_os.clean.scalebar import scale_from_bars


def _box(text: str, width: int, height: int = 54, bar: bool = False) -> np.ndarray:
    canvas = Image.new("L", (width, height), 255)
    draw = ImageDraw.Draw(canvas)
    draw.text((8, 6), text, fill=0, font=font(36))
    if bar:
        draw.rectangle([width - 110, height // 2 - 3, width - 10, height // 2 + 3], fill=0)
    return np.asarray(canvas, np.float32) / 255.0


@pytest.mark.timeout(60)
@pytest.mark.parametrize("letter", ["a", "b", "c", "d"])
def test_a_panel_letter_in_its_box_is_no_scale_bar(letter):
    found = scale_from_bars([], [_box(letter, 45)])
    assert found.metres is None and not found.bar_seen and "no scale bar" in found.detail, found


@pytest.mark.timeout(60)
def test_a_wide_box_with_a_bar_is_still_taken_for_one():
    found = scale_from_bars([], [_box("5 um", 260, bar=True)])
    assert found.bar_seen, found
